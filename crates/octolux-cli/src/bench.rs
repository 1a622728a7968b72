//! `octolux bench`: every listed technique on one or more scenes with the same camera and
//! frames; per scene one table of frame-time statistics (per pass, GI total, whole frame), GPU
//! memory and, unless `--no-reference`, error against the matching CPU reference.

mod reference_cache;
mod report;
mod temporal;

use crate::gi_args::GiArgs;
use crate::inputs::{load_scene, GpuArgs};
use crate::render::{progress_bar, SamplingArgs};
use crate::stats::mib;
use anyhow::{bail, Context, Result};
use clap::Args;
use indicatif::ProgressBar;
use octolux::gi::{technique, GiSettings};
use octolux::gpu::GpuContext;
use octolux::image_io::check_image_size;
use octolux::image_io::HdrImage;
use octolux::metrics;
use octolux::reference::{self, ReferenceImages, ReferenceSettings};
use octolux::render::{RenderSettings, Renderer};
use octolux::scene::Scene;
use octolux::transport::{Bounces, Transport};
use report::{
    frame_stats, AdapterReport, BenchReport, MemoryEntry, OwnerMemory, ReferenceReport,
    SceneReport, TechniqueReport,
};
use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of `octolux bench`.
#[derive(Args, Debug)]
pub struct BenchArgs {
    /// Scene files or models, measured one after another (default: the built-in Cornell box).
    pub scenes: Vec<PathBuf>,
    /// Comma-separated GPU techniques to measure (see `octolux render --help`).
    #[arg(long, value_delimiter = ',', default_value = "none")]
    pub gi: Vec<String>,
    /// Image width.
    #[arg(long, default_value_t = 320)]
    pub width: u32,
    /// Image height.
    #[arg(long, default_value_t = 180)]
    pub height: u32,
    /// Scene time (s) of the first frame.
    #[arg(long, default_value_t = 0.0)]
    pub time: f32,
    /// Frames per second of scene time: animated scenes advance 1/fps per frame (warm-up
    /// included); static scenes render the same frame again.
    #[arg(long, default_value_t = 30.0)]
    pub fps: f32,
    /// Scene camera: its index or its name (in every scene).
    #[arg(long, default_value = "0")]
    pub camera: String,
    /// Frames rendered before measuring (pipelines warm, caches filled), not measured.
    #[arg(long, default_value_t = 3)]
    pub warmup: u32,
    /// Frames measured: per pass, GI total and whole frame, their mean, median and worst.
    #[arg(long, default_value_t = 20)]
    pub frames: u32,
    /// Warm every technique up to its settled picture: at least `--warmup` frames, and for a
    /// technique that converges over frames (probe histories, the cone tracers' bounces) as
    /// many as `octolux render` waits for it. The warm-up is held still at `--time`; measured
    /// frames of an animated scene then advance from there.
    #[arg(long)]
    pub settle: bool,
    /// Also judge the image of frame N (1 = the first frame rendered) against the reference:
    /// the early picture beside the settled one (JSON `early`). N at most the frames rendered.
    #[arg(long, value_name = "N", conflicts_with = "no_reference")]
    pub early: Option<u32>,
    /// Skip the work counts (per pass, what it did: cone samples, octree nodes, shadow-ray
    /// steps...), which take warm-up + 1 more frames per technique with a counting renderer.
    #[arg(long)]
    pub no_work_counts: bool,
    /// Skip flicker (the indirect irradiance's change from frame to frame at the same surface
    /// points): held still, 4 frames (or the technique's own settling count) to settle and 4 measured, after the timed ones, per
    /// technique; on an animated scene also 4 frames more of its motion.
    #[arg(long)]
    pub no_flicker: bool,
    /// Measure lag after EVENT (repeatable, needs the reference): `jump:A..B` holds the scene
    /// at time A, then at B (whatever animates jumps); `on:LIGHT` / `off:LIGHT` switches a
    /// light (name or index) on / off at `--time`. Per technique and event: 24 frames before,
    /// 24 after, each judged against the reference of the state after.
    #[arg(long = "lag", value_name = "EVENT", conflicts_with = "no_reference")]
    pub lag: Vec<temporal::LagEvent>,
    /// Skip the CPU reference: no error columns (shown as `-`, `null` in JSON).
    #[arg(long, conflicts_with = "against")]
    pub no_reference: bool,
    /// Judge every technique against this transport instead of the one it claims
    /// (`direct`, a number of bounces, `unlimited`); e.g. `1` to compare GI off and on.
    #[arg(long)]
    pub against: Option<String>,
    /// Write every scene's results into one JSON file (`-`: standard output, tables then go to
    /// standard error).
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write one JSON file per scene into this folder, named after the scene
    /// (`<scene>.json`), each in the same layout as `--json` with one scene.
    #[arg(long)]
    pub json_dir: Option<PathBuf>,
    /// Write every technique's image (last measured frame) and every reference as EXR + PNG
    /// into this folder (with several scenes, into one subfolder per scene).
    #[arg(long)]
    pub out_dir: Option<PathBuf>,
    /// Keep every reference rendered in this folder and take it from there when the same one
    /// is asked again (same scene content, frame, size, settings and path tracer), instead
    /// of rendering it anew.
    #[arg(long, value_name = "DIR", conflicts_with = "no_reference")]
    pub reference_cache: Option<PathBuf>,
    /// Reference sampling (the transport is the one each technique claims, or `--against`).
    #[command(flatten, next_help_heading = "Reference path tracer")]
    pub sampling: SamplingArgs,
    /// GPU options.
    #[command(flatten, next_help_heading = "GPU")]
    pub gpu: GpuArgs,
    /// Technique settings.
    #[command(flatten, next_help_heading = "Technique settings")]
    pub gi_args: GiArgs,
    /// Sky light.
    #[command(flatten, next_help_heading = "Sky")]
    pub sky_args: crate::sky_args::SkyArgs,
    /// What the scene may pull in.
    #[command(flatten, next_help_heading = "Scene budget")]
    pub budget: crate::inputs::BudgetArgs,
}

/// A scene to measure.
struct SceneInput {
    file: Option<PathBuf>,
    scene: Scene,
    gi_settings: GiSettings,
}

/// Most warm-up or measured frames.
const MAX_FRAMES: u32 = 1_000_000;

/// Loads every scene of `args` (the built-in one when none is named).
fn load_inputs(args: &BenchArgs) -> Result<Vec<SceneInput>> {
    if args.scenes.is_empty() {
        let (scene, gi_settings) = load_scene(None, &args.gi_args, &args.sky_args, &args.budget)?;
        Ok(vec![SceneInput {
            file: None,
            scene,
            gi_settings,
        }])
    } else {
        args.scenes
            .iter()
            .map(|path| {
                let (scene, gi_settings) =
                    load_scene(Some(path), &args.gi_args, &args.sky_args, &args.budget)
                        .with_context(|| format!("scene file {}", path.display()))?;
                Ok(SceneInput {
                    file: Some(path.clone()),
                    scene,
                    gi_settings,
                })
            })
            .collect::<Result<_>>()
    }
}

/// Checks `--json` (when it names a file) against the inputs: the scene files, the models they
/// name and the `--sky` map, and `loaded`, every file the scenes' loading read.
fn check_json(args: &BenchArgs, loaded: &[PathBuf]) -> Result<()> {
    let Some(json) = args.json.as_deref().filter(|p| p.as_os_str() != "-") else {
        return Ok(());
    };
    crate::outputs::check(
        &[crate::outputs::Planned {
            flag: "--json",
            path: json,
            format: crate::outputs::Format::Json,
        }],
        &bench_inputs(args, loaded),
    )
}

/// The files a bench run reads: the scene files, the models they name, the `--sky` map and
/// `loaded`, every file the scenes' loading read.
fn bench_inputs(args: &BenchArgs, loaded: &[PathBuf]) -> Vec<PathBuf> {
    let mut inputs = args.scenes.clone();
    for scene in &args.scenes {
        if scene
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("toml"))
        {
            inputs.extend(octolux::scene::file::model_files(scene).unwrap_or_default());
        }
    }
    inputs.extend(args.sky_args.sky.iter().map(PathBuf::from));
    inputs.extend(loaded.iter().cloned());
    inputs
}

/// Where `--out-dir` puts the images of the scenes measured in this order (one subfolder per
/// scene with several), named as the run names them.
fn out_dirs(dir: &Path, scenes: &[&str]) -> Vec<PathBuf> {
    let mut names = Vec::new();
    scenes
        .iter()
        .map(|scene| {
            if scenes.len() > 1 {
                dir.join(unique_name(scene, &mut names))
            } else {
                dir.to_path_buf()
            }
        })
        .collect()
}

/// Checks the files `--json-dir` and `--out-dir` will write (each scene's JSON, each
/// technique's EXR and PNG) against the inputs before any work. The references' images are
/// named after the transport each technique claims, known once it is made: they are checked
/// when written ([`write_out_image`]).
fn check_dir_outputs(args: &BenchArgs, scenes: &[&str], loaded: &[PathBuf]) -> Result<()> {
    use crate::outputs::Format;
    let mut files: Vec<(&str, PathBuf, Format)> = Vec::new();
    if let Some(dir) = &args.json_dir {
        let mut names = Vec::new();
        for scene in scenes {
            let name = unique_name(scene, &mut names);
            files.push(("--json-dir", dir.join(format!("{name}.json")), Format::Json));
        }
    }
    if let Some(dir) = &args.out_dir {
        for sub in out_dirs(dir, scenes) {
            for gi in &args.gi {
                files.push(("--out-dir", sub.join(format!("{gi}.exr")), Format::Exr));
                files.push(("--out-dir", sub.join(format!("{gi}.png")), Format::Png));
            }
        }
    }
    crate::outputs::check_paths(&files, &bench_inputs(args, loaded))
}

/// Writes one image of `--out-dir` after checking it is not one of the inputs.
fn write_out_image(
    path: &Path,
    image: &HdrImage,
    exposure: Option<f32>,
    inputs: &[PathBuf],
) -> Result<()> {
    let format = match exposure {
        Some(_) => crate::outputs::Format::Png,
        None => crate::outputs::Format::Exr,
    };
    crate::outputs::check(
        &[crate::outputs::Planned {
            flag: "--out-dir",
            path,
            format,
        }],
        inputs,
    )?;
    match exposure {
        Some(ev) => image.write_png(path, ev)?,
        None => image.write_exr(path)?,
    }
    Ok(())
}

/// Checks every argument before any work starts, so a long run fails at once.
fn validate(args: &BenchArgs) -> Result<()> {
    check_image_size(args.width, args.height)
        .with_context(|| format!("--width {} --height {}", args.width, args.height))?;
    if args.frames == 0 || args.frames > MAX_FRAMES {
        bail!(
            "--frames {}: must be at least 1 (the measured frames) and at most {MAX_FRAMES}",
            args.frames
        );
    }
    if args.warmup > MAX_FRAMES {
        bail!("--warmup {}: expected 0..={MAX_FRAMES}", args.warmup);
    }
    if let Some(n) = args
        .early
        .filter(|&n| n == 0 || n > args.warmup + args.frames)
    {
        bail!(
            "--early {n}: expected a frame rendered, 1..={} (--warmup + --frames)",
            args.warmup + args.frames
        );
    }
    crate::outputs::check_fps(args.fps)?;
    if !args.time.is_finite() {
        bail!("--time {}: must be a finite number of seconds", args.time);
    }
    if args.gi.is_empty() || args.gi.iter().any(|g| g.trim().is_empty()) {
        bail!("--gi: list at least one technique, e.g. --gi none,lpv");
    }
    for (i, name) in args.gi.iter().enumerate() {
        if name == "reference" {
            bail!(
                "--gi lists GPU techniques; the reference is rendered for the error columns \
                 unless --no-reference"
            );
        }
        technique(name).context("--gi")?;
        if args.gi[..i].contains(name) {
            bail!("--gi: '{name}' is listed twice");
        }
    }
    for path in &args.scenes {
        if !path.is_file() {
            bail!("scene file {}: no such file", path.display());
        }
    }
    if let Some(json) = args.json.as_deref().filter(|p| p.as_os_str() != "-") {
        let parent = json.parent().filter(|p| !p.as_os_str().is_empty());
        if let Some(parent) = parent.filter(|p| !p.is_dir()) {
            bail!(
                "--json {}: folder {} does not exist",
                json.display(),
                parent.display()
            );
        }
        if json.is_dir() {
            bail!("--json {}: is a folder (use --json-dir)", json.display());
        }
        check_json(args, &[])?;
    }
    for (flag, dir) in [("--json-dir", &args.json_dir), ("--out-dir", &args.out_dir)] {
        if let Some(dir) = dir {
            if dir.is_file() {
                bail!("{flag} {}: is a file; expected a folder", dir.display());
            }
            crate::outputs::check_writable_dir(flag, dir, dir)?;
        }
    }
    if let Some(against) = &args.against {
        against.parse::<Bounces>()?;
    }
    if !args.no_reference {
        args.sampling.settings(Bounces::Unlimited)?;
    }
    Ok(())
}

/// Runs `octolux bench`.
pub fn run(args: &BenchArgs) -> Result<()> {
    validate(args)?;
    let against = args
        .against
        .as_deref()
        .map(str::parse::<Bounces>)
        .transpose()?
        .map(Transport::uniform);
    let reference_settings = if args.no_reference {
        None
    } else {
        Some(args.sampling.settings(Bounces::Unlimited)?)
    };
    // Every scene is loaded before any is measured, so a bad file fails the run at once; the
    // output is checked again against every file the loads read.
    let (inputs, loaded) = octolux::limits::recording_reads(|| load_inputs(args));
    let inputs = inputs?;
    check_json(args, &loaded)?;
    let names: Vec<&str> = inputs.iter().map(|i| i.scene.name.as_str()).collect();
    check_dir_outputs(args, &names, &loaded)?;
    let read = bench_inputs(args, &loaded);
    // Every technique's settings are checked before the first is measured.
    for input in &inputs {
        for name in &args.gi {
            (technique(name)?.validate)(&input.gi_settings)
                .with_context(|| format!("--gi {name}"))?;
        }
    }
    for input in &inputs {
        for event in &args.lag {
            event
                .states(&input.scene, args.time)
                .with_context(|| format!("--lag {event}"))?;
        }
        input.scene.camera_index(&args.camera).with_context(|| {
            format!(
                "--camera {}: {}",
                args.camera,
                input
                    .file
                    .as_ref()
                    .map_or("the built-in scene".into(), |f| f.display().to_string())
            )
        })?;
    }
    if let Some(dir) = &args.json_dir {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("--json-dir: creating {}", dir.display()))?;
    }
    let json_stdout = args.json.as_deref().is_some_and(|p| p.as_os_str() == "-");
    let quiet = json_stdout || !std::io::stdout().is_terminal();
    let out_dirs = args
        .out_dir
        .as_deref()
        .map(|dir| out_dirs(dir, &names))
        .unwrap_or_default();

    // The adapter's peaks, for the roofline of the counted passes.
    let peaks = if args.no_work_counts {
        None
    } else {
        let ctx = GpuContext::new(&args.gpu.options())?;
        Some(octolux::gpu::roofline::measure_peaks(&ctx).context("measuring the adapter's peaks")?)
    };
    let mut run: Option<BenchReport> = None;
    let mut json_names: Vec<String> = Vec::new();
    for (i, input) in inputs.iter().enumerate() {
        // With several scenes, images go to one subfolder per scene.
        let out = out_dirs.get(i).map(|dir| (dir.as_path(), read.as_slice()));
        let (adapter, mut scene_report) = bench_scene(
            args,
            input,
            against,
            reference_settings.as_ref(),
            quiet,
            out,
        )?;
        for technique in &mut scene_report.techniques {
            report::attach_roofline(&mut technique.passes, peaks.as_ref());
        }
        let run = run.get_or_insert_with(|| BenchReport {
            version: report::JSON_VERSION,
            provenance: report::Provenance::now(),
            adapter,
            width: args.width,
            height: args.height,
            warmup: args.warmup,
            settle: args.settle,
            frames: args.frames,
            fps: args.fps,
            time: args.time,
            camera: args.camera.clone(),
            reference: !args.no_reference,
            peaks: peaks.clone(),
            scenes: Vec::new(),
        });
        {
            let stdout = std::io::stdout();
            let stderr = std::io::stderr();
            let mut out: Box<dyn Write> = if json_stdout {
                Box::new(stderr.lock())
            } else {
                Box::new(stdout.lock())
            };
            report::print_scene(&mut out, run, &scene_report)?;
            out.flush()?;
        }
        if let Some(dir) = &args.json_dir {
            let name = unique_name(&scene_report.scene, &mut json_names);
            let one = BenchReport {
                scenes: vec![scene_report.clone()],
                ..run.clone()
            };
            write_json(&dir.join(format!("{name}.json")), &one)?;
        }
        run.scenes.push(scene_report);
        // Rewritten after every scene, so a long run keeps what it measured if a later scene
        // fails.
        if let Some(path) = args.json.as_deref().filter(|_| !json_stdout) {
            write_json(path, run)?;
        }
    }
    if let (true, Some(run)) = (json_stdout, &run) {
        println!("{}", serde_json::to_string_pretty(run)?);
    }
    Ok(())
}

/// A file name for `scene` not used before in this run (`name`, `name-2`, ...), made of
/// characters that are safe in file names.
fn unique_name(scene: &str, used: &mut Vec<String>) -> String {
    let base: String = scene
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' || c == '.' {
                c
            } else {
                '_'
            }
        })
        .collect();
    let base = if base.is_empty() {
        "scene".into()
    } else {
        base
    };
    let mut name = base.clone();
    let mut n = 1;
    while used.contains(&name) {
        n += 1;
        name = format!("{base}-{n}");
    }
    used.push(name.clone());
    name
}

fn write_json(path: &Path, report: &BenchReport) -> Result<()> {
    // Compact: a scene with many textures lists hundreds of memory entries per technique, and
    // the committed runs travel with the repository (`jq .` prints them indented).
    let text = serde_json::to_string(report)? + "\n";
    octolux::image_io::write_atomically(path, |file| {
        std::fs::write(file, &text).map_err(|e| octolux::Error::io(path, e))
    })
    .with_context(|| format!("writing {}", path.display()))
}

/// Measures every technique on one scene, then renders the references and measures error.
fn bench_scene(
    args: &BenchArgs,
    input: &SceneInput,
    against: Option<Transport>,
    reference_settings: Option<&ReferenceSettings>,
    quiet: bool,
    out: Option<(&Path, &[PathBuf])>,
) -> Result<(AdapterReport, SceneReport)> {
    let out_dir = out.map(|(dir, _)| dir);
    let scene = &input.scene;
    let animated = scene.is_animated();
    // Scene time of frame i of a technique whose warm-up is held still for `held` frames
    // (`--settle`: its own warm-up; otherwise none, the warm-up already moves).
    let frame_time = |i: u32, held: u32| {
        if animated {
            args.time + i.saturating_sub(held) as f32 / args.fps
        } else {
            args.time
        }
    };
    let total_frames = args.warmup + args.frames;
    let last_time = match args.settle {
        true => frame_time(args.frames - 1, 0),
        false => frame_time(total_frames - 1, 0),
    };
    let bar = if quiet {
        ProgressBar::hidden()
    } else {
        progress_bar(
            (args.gi.len() as u64) * total_frames as u64,
            &format!("frames of '{}'", scene.name),
        )
    };
    let mut adapter = None;
    let mut techniques = Vec::new();
    let mut images: Vec<(String, Transport, HdrImage)> = Vec::new();
    // `--early`: each technique's image of that frame, with its frame and scene time.
    let mut earlies: Vec<(String, Transport, u32, f32, HdrImage)> = Vec::new();
    let mut lag_references = LagReferences {
        settings: reference_settings,
        quiet,
        images: Vec::new(),
    };
    for name in &args.gi {
        // A fresh device per technique keeps its memory ledger to itself.
        let ctx = GpuContext::new(&args.gpu.options())?;
        adapter.get_or_insert_with(|| AdapterReport::of(&ctx));
        let settings = RenderSettings {
            width: args.width,
            height: args.height,
            shadow_map_size: args.gpu.shadow_map_size,
            camera: scene.camera_index(&args.camera)?,
            gi: name.clone(),
            gi_settings: input.gi_settings.clone(),
            soft_sky_shadows: args.gpu.soft_sky_shadows,
        };
        let mut renderer = Renderer::new(&ctx, scene, settings.clone())
            .with_context(|| format!("scene '{}': setting up '{name}'", scene.name))?;
        let warmup = match args.settle {
            true => args.warmup.max(renderer.technique().settle_frames()),
            false => args.warmup,
        };
        let held = if args.settle { warmup } else { 0 };
        let time_of = |i: u32| frame_time(i, held);
        bar.inc_length(u64::from(warmup - args.warmup));
        let mut frames = Vec::with_capacity(args.frames as usize);
        let mut wall_ms = Vec::with_capacity(args.frames as usize);
        let mut after_warmup = None;
        let mut early_image = None;
        for i in 0..warmup + args.frames {
            if i == warmup {
                after_warmup = ctx.resource_counts();
            }
            let start = Instant::now();
            let timings = renderer
                .render(scene, time_of(i))
                .with_context(|| format!("scene '{}': rendering '{name}'", scene.name))?;
            if i >= warmup {
                wall_ms.push(start.elapsed().as_secs_f64() * 1e3);
                frames.push(timings);
            }
            if args.early == Some(i + 1) {
                early_image = Some((i + 1, time_of(i), renderer.read_hdr()?));
            }
            bar.inc(1);
        }
        let objects = after_warmup.zip(ctx.resource_counts()).map(|(a, b)| [a, b]);
        if let Some([a, b]) = objects.filter(|[a, b]| a != b) {
            eprintln!(
                "warning: scene '{}', {name}: wgpu objects alive changed during the measured \
                 frames: {a:?} -> {b:?}",
                scene.name
            );
        }
        let bounces = against
            .unwrap_or_else(|| renderer.technique().reference_transport())
            .for_scene(scene.has_emissive_surfaces());
        let (passes, gi_total, frame_total, frame_wall) = frame_stats(&frames, &wall_ms);
        let by_owner = ctx.ledger.by_owner();
        let technique_bytes: u64 = by_owner
            .iter()
            .filter(|(o, _)| o == name)
            .map(|(_, b)| b)
            .sum();
        techniques.push(TechniqueReport {
            scene: scene.name.clone(),
            technique: name.clone(),
            reference: reference_settings.map(|_| bounces.to_string()),
            passes,
            gi_total,
            frame_total,
            frame_wall,
            technique_mib: mib(technique_bytes),
            total_mib: mib(ctx.ledger.total()),
            memory: by_owner
                .into_iter()
                .map(|(owner, bytes)| OwnerMemory {
                    owner,
                    mib: mib(bytes),
                })
                .collect(),
            memory_entries: ctx
                .ledger
                .entries()
                .into_iter()
                .map(|e| MemoryEntry {
                    owner: e.owner,
                    name: e.name,
                    mib: mib(e.bytes),
                })
                .collect(),
            objects,
            warmup,
            metrics: None,
            early: None,
            flicker: None,
            motion_flicker: None,
            lag: Vec::new(),
        });
        let image = match reference_settings.is_some() || out_dir.is_some() {
            true => Some(renderer.read_hdr()?),
            false => None,
        };
        let Some(report) = techniques.last_mut() else {
            bail!("internal error: no report for '{name}'");
        };
        let references = (bounces, &mut lag_references);
        measure_temporal(args, scene, last_time, &mut renderer, references, report)
            .with_context(|| format!("scene '{}': temporal behaviour of '{name}'", scene.name))?;
        if let Some(image) = image {
            if let Some((x, y, v)) = image.first_non_finite() {
                bail!(
                    "scene '{}', {name}: the last frame holds {v} at pixel ({x}, {y}): the \
                     light is beyond what the technique stores",
                    scene.name
                );
            }
            images.push((name.clone(), bounces, image));
        }
        if let Some((frame, time, image)) = early_image {
            earlies.push((name.clone(), bounces, frame, time, image));
        }
        if !args.no_work_counts {
            drop(renderer);
            let work =
                work_counts(&ctx, scene, &settings, warmup, &time_of).with_context(|| {
                    format!("scene '{}': counting the work of '{name}'", scene.name)
                })?;
            if let Some(report) = techniques.last_mut() {
                report::attach_work(&mut report.passes, name, work);
            }
        }
    }
    bar.finish_and_clear();

    let mut references: Vec<(Transport, ReferenceImages, f64)> = Vec::new();
    if let Some(settings) = reference_settings {
        for (_, bounces, _) in &images {
            if references.iter().any(|(b, _, _)| b == bounces) {
                continue;
            }
            let settings = settings.clone().with_transport(*bounces);
            crate::inputs::warn_unfollowed_requests(
                scene,
                "a technique here is judged against",
                *bounces,
                references.is_empty().then_some(settings.spp),
            );
            let (images, seconds) = reference_frame(scene, last_time, args, &settings, quiet)?;
            references.push((*bounces, images, seconds));
        }
        for (result, (name, bounces, image)) in techniques.iter_mut().zip(&images) {
            let Some((_, reference, _)) = references.iter().find(|(b, _, _)| b == bounces) else {
                bail!("no reference rendered for '{name}'");
            };
            result.metrics = Some(metrics::compare(image, &reference.total, None)?);
        }
        for (name, bounces, frame, time, image) in &earlies {
            // An animated scene's early frame shows another time than the reference: judged
            // against a reference of its own.
            let early_reference;
            let reference = match (
                animated && *time != last_time,
                references.iter().find(|(b, _, _)| b == bounces),
            ) {
                (false, Some((_, reference, _))) => &reference.total,
                _ => {
                    let settings = settings.clone().with_transport(*bounces);
                    early_reference = reference_frame(scene, *time, args, &settings, quiet)?.0;
                    &early_reference.total
                }
            };
            let Some(result) = techniques.iter_mut().find(|t| t.technique == *name) else {
                bail!("internal error: no report for '{name}'");
            };
            result.early = Some(report::EarlyReport {
                frame: *frame,
                metrics: metrics::compare(image, reference, None)?,
            });
        }
    }
    if let Some((dir, read)) = out {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        let technique_images = images.iter().map(|(name, _, image)| (name.clone(), image));
        let reference_images = references.iter().map(|(bounces, reference, _)| {
            let stem = bounces.to_string().replace("; ", "-").replace(' ', "-");
            (format!("reference-{stem}"), &reference.total)
        });
        for (stem, image) in technique_images.chain(reference_images) {
            write_out_image(&dir.join(format!("{stem}.exr")), image, None, read)?;
            write_out_image(
                &dir.join(format!("{stem}.png")),
                image,
                Some(scene.exposure),
                read,
            )?;
        }
    }
    let Some(adapter) = adapter else {
        bail!("--gi: no technique to measure");
    };
    Ok((
        adapter,
        SceneReport {
            scene: scene.name.clone(),
            file: input.file.as_ref().map(|p| p.display().to_string()),
            triangles: scene.triangle_count(),
            animated,
            first_time: frame_time(0, 0),
            last_time,
            techniques,
            references: references
                .iter()
                .map(|(b, r, s)| ReferenceReport {
                    bounces: b.to_string(),
                    spp: r.spp_done,
                    seconds: *s,
                })
                .collect(),
        },
    ))
}

/// After the measured frames: flicker with the scene's own motion (animated scenes: 4 more
/// frames of it), flicker held still at the time reached, and lag after every `--lag` event.
fn measure_temporal(
    args: &BenchArgs,
    scene: &Scene,
    last_time: f32,
    renderer: &mut Renderer,
    (bounces, references): (Transport, &mut LagReferences),
    report: &mut TechniqueReport,
) -> Result<()> {
    let mut t = last_time;
    if !args.no_flicker {
        if scene.is_animated() {
            let start = temporal::Snapshot::of(renderer)?;
            let times: Vec<f32> = (1..=temporal::FLICKER_FRAMES)
                .map(|k| last_time + k as f32 / args.fps)
                .collect();
            report.motion_flicker = Some(temporal::flicker(renderer, scene, start, &times)?);
            t = times.last().copied().unwrap_or(t);
        }
        report.flicker = Some(temporal::still_flicker(renderer, scene, t)?);
    }
    for event in &args.lag {
        let (before, after) = event.states(scene, args.time)?;
        let reference = references.get(args, event, &after, bounces)?;
        let lag = temporal::lag(renderer, &before, &after, reference)?;
        report.lag.push(report::LagReport {
            event: event.to_string(),
            frames: lag.frames,
            settled_rel_mse: lag.rel_mse.last().copied().unwrap_or(0.0),
            rel_mse: lag.rel_mse,
        });
    }
    Ok(())
}

/// The references of the states after the lag events, rendered once per event and transport.
struct LagReferences<'a> {
    settings: Option<&'a ReferenceSettings>,
    quiet: bool,
    images: Vec<(String, Transport, HdrImage)>,
}

impl LagReferences<'_> {
    fn get(
        &mut self,
        args: &BenchArgs,
        event: &temporal::LagEvent,
        after: &temporal::SceneState,
        bounces: Transport,
    ) -> Result<&HdrImage> {
        let key = event.to_string();
        let found = self
            .images
            .iter()
            .position(|(e, b, _)| *e == key && *b == bounces);
        let index = match found {
            Some(i) => i,
            None => {
                let Some(settings) = self.settings else {
                    bail!("--lag needs the reference (it conflicts with --no-reference)");
                };
                let settings = settings.clone().with_transport(bounces);
                let (images, _) =
                    reference_frame(&after.scene, after.time, args, &settings, self.quiet)
                        .with_context(|| format!("reference after '{key}'"))?;
                self.images.push((key, bounces, images.total));
                self.images.len() - 1
            }
        };
        Ok(&self.images[index].2)
    }
}

/// The work counts of the first measured frame (`warmup`), rendered again from the first
/// frame by a renderer of its own that counts (counting slows the counted passes, so the timed
/// frames never count).
fn work_counts(
    ctx: &GpuContext,
    scene: &Scene,
    settings: &RenderSettings,
    warmup: u32,
    frame_time: &dyn Fn(u32) -> f32,
) -> Result<Vec<octolux::gpu::WorkCount>> {
    let counting = ctx.with_work_counter();
    let mut renderer = Renderer::new(&counting, scene, settings.clone())?;
    let Some(work) = counting.work() else {
        bail!("internal error: the counting context has no work counters");
    };
    for i in 0..=warmup {
        if i == warmup {
            work.take(&counting)?;
        }
        renderer.render(scene, frame_time(i))?;
    }
    Ok(work.take(&counting)?)
}

/// The reference of the frame at `t` and the seconds it took to render, with a progress bar
/// over samples per pixel unless quiet; from `--reference-cache` where it holds it.
fn reference_frame(
    scene: &Scene,
    t: f32,
    args: &BenchArgs,
    settings: &ReferenceSettings,
    quiet: bool,
) -> Result<(ReferenceImages, f64)> {
    let frame = scene.frame(t, scene.camera_index(&args.camera)?);
    let size = (args.width, args.height);
    let cache = args
        .reference_cache
        .as_deref()
        .map(reference_cache::ReferenceCache::new);
    if let Some(found) = cache
        .as_ref()
        .and_then(|c| c.find(scene, &frame, size, settings))
    {
        let (folder, images, seconds) = found;
        if !quiet {
            eprintln!(
                "bench: the '{}' reference ({}) from {}",
                scene.name,
                settings.bounces,
                folder.display()
            );
        }
        return Ok((images, seconds));
    }
    let start = Instant::now();
    let bar = if quiet {
        ProgressBar::hidden()
    } else {
        progress_bar(
            settings.spp as u64,
            &format!(
                "spp of the '{}' reference ({})",
                scene.name, settings.bounces
            ),
        )
    };
    let images = reference::render(
        scene,
        &frame,
        args.width,
        args.height,
        settings,
        &|done, _| bar.set_position(done as u64),
    )
    .with_context(|| format!("scene '{}': reference", scene.name))?;
    bar.finish_and_clear();
    let seconds = start.elapsed().as_secs_f64();
    if let Some(cache) = cache {
        cache.store(scene, &frame, size, settings, &images, seconds)?;
    }
    Ok((images, seconds))
}
