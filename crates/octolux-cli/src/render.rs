//! `octolux render`.

use crate::gi_args::GiArgs;
use crate::inputs::{load_scene, parse_output, GpuArgs};
use crate::outputs::{check_fps, Format};
use crate::sky_args::SkyArgs;
use anyhow::{bail, Context, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use octolux::gi::GiSettings;
use octolux::gpu::GpuContext;
use octolux::image_io::{check_image_size, write_rgb8_png, HdrImage};
use octolux::reference::{self, ReferenceImages, ReferenceSettings};
use octolux::render::{Output, RenderSettings, Renderer};
use octolux::scene::Scene;
use octolux::transport::{Bounces, EmissiveSurfaces, Transport};
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Arguments of `octolux render`.
#[derive(Args, Debug)]
pub struct RenderArgs {
    /// Scene file (.toml), Mitsuba 3 scene (.xml), or a model (.gltf, .glb, .obj, .ply,
    /// .ply.gz). Default: the built-in Cornell box.
    pub scene: Option<PathBuf>,
    /// Image width in pixels.
    #[arg(long, default_value_t = 640)]
    pub width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 360)]
    pub height: u32,
    /// Scene time in seconds of the (first) frame.
    #[arg(long, default_value_t = 0.0, conflicts_with = "frame")]
    pub time: f32,
    /// Start at frame N of the animation instead: time = N / fps.
    #[arg(long)]
    pub frame: Option<u32>,
    /// Number of frames to render, `1/fps` seconds apart; with more than one, outputs are
    /// numbered (render_0000.png, ...).
    #[arg(long, default_value_t = 1)]
    pub frames: u32,
    /// Frames rendered at the first frame's time before the first one written, so that a
    /// technique that converges over frames shows its settled picture (`probes-grid`'s
    /// history; GPU techniques only). Default: the technique's own count (`probes-grid`: its
    /// `--probes-history`, 32; the others 0).
    #[arg(long)]
    pub warmup: Option<u32>,
    /// Frames per second of scene time when rendering several frames.
    #[arg(long, default_value_t = 30.0)]
    pub fps: f32,
    /// Output image: .png (tone-mapped display image) or .exr (linear HDR radiance).
    #[arg(long, short, default_value = "render.png")]
    pub out: PathBuf,
    /// Also write the linear HDR image to this OpenEXR file.
    #[arg(long)]
    pub exr: Option<PathBuf>,
    /// GI technique: `none` (direct light only), `lpv`, `clpv`, `olpv`, `vct-svo`,
    /// `vct-clipmap`, `vpl`, `probes-grid`, `probes-octree`, or `reference` (the CPU path
    /// tracer).
    #[arg(long, default_value = crate::gi_args::DEFAULT_GI)]
    pub gi: String,
    /// What the image holds (GPU techniques): `final` (the frame), `direct`, `indirect` (the
    /// indirect irradiance E as E/pi), `ao` (ambient occlusion of the cone tracers) or
    /// `specular` (their specular cone, with --vct-specular).
    #[arg(long, default_value = "final")]
    pub output: String,
    /// Which of the scene's cameras to use: its index or its name.
    #[arg(long, default_value = "0")]
    pub camera: String,
    /// Print per-pass times and GPU memory per owner.
    #[arg(long)]
    pub stats: bool,
    /// Exposure in EV (stops), replacing the scene's: the display image is scaled by 2^EV.
    #[arg(long, allow_hyphen_values = true)]
    pub exposure: Option<f32>,
    /// What to show: `shaded` (the rendered image), `voxels` (the voxel structure's albedo,
    /// ray-marched; see --voxel-structure, --voxel-res and --level) or `probes` (with --gi
    /// probes-grid or probes-octree: the frame with the probes as spheres shaded by their
    /// irradiance, the octree's leaf cubes and the surfels drawn over it; see --probe-layers).
    #[arg(long, default_value = "shaded", help_heading = "Debug views")]
    pub view: String,
    /// Layers of `--view probes`: a comma-separated list of `probes`, `cells` (the octree's
    /// leaf cubes; yellow: holds a probe) and `surfels`, or `all`.
    #[arg(long, default_value = "all", help_heading = "Debug views")]
    pub probe_layers: String,
    /// Frames rendered before `--view probes` reads the probes (the octree grows one level
    /// per frame).
    #[arg(long, default_value_t = 10, help_heading = "Debug views")]
    pub probe_frames: u32,
    /// Structure shown by `--view voxels`: `svo`, `clipmap` or `clipmap-radiance` (the
    /// clipmap's injected direct radiance).
    #[arg(long, default_value = "svo", help_heading = "Debug views")]
    pub voxel_structure: String,
    /// Voxel resolution of `--view voxels` (the octree's grid; the clipmap's finest voxel
    /// matches it).
    #[arg(long, default_value_t = 128, help_heading = "Debug views")]
    pub voxel_res: u32,
    /// Level sampled by `--view voxels` (octree: 0 = root; clipmap: 0 = finest). Default: the
    /// finest.
    #[arg(long, help_heading = "Debug views")]
    pub level: Option<u32>,
    /// Reference path tracer options (used with `--gi reference`).
    #[command(flatten, next_help_heading = "Reference path tracer (--gi reference)")]
    pub reference: ReferenceArgs,
    /// GPU options.
    #[command(flatten, next_help_heading = "GPU")]
    pub gpu: GpuArgs,
    /// Technique settings.
    #[command(flatten, next_help_heading = "Technique settings")]
    pub gi_args: GiArgs,
    /// Sky light.
    #[command(flatten, next_help_heading = "Sky")]
    pub sky_args: SkyArgs,
    /// What the scene may pull in.
    #[command(flatten, next_help_heading = "Scene budget")]
    pub budget: crate::inputs::BudgetArgs,
}

impl RenderArgs {
    /// Scene time of the first frame.
    pub fn start_time(&self) -> f32 {
        match self.frame {
            Some(n) => n as f32 / self.fps,
            None => self.time,
        }
    }
}

/// Options of the reference path tracer.
#[derive(Args, Debug, Clone)]
pub struct ReferenceArgs {
    /// Samples, time budget and seed.
    #[command(flatten)]
    pub sampling: SamplingArgs,
    /// Light transport of the reference, counted by reflections as Mitsuba counts them:
    /// `direct` (light straight from any emitter reflected once: lights, sky and emissive
    /// surfaces), a number of indirect bounces (`1` = one bounce, what LPV and VPL methods
    /// compute), or `unlimited`.
    #[arg(long, default_value = "unlimited")]
    pub bounces: String,
    /// How emissive surfaces light the scene: `lights` (like any emitter), `one-fewer` (one
    /// bounce fewer than the lights, as the cone tracers and probes compute them) or `unlit`
    /// (seen only, as the LPV family, VPLs and GI off compute them).
    #[arg(long, default_value = "lights")]
    pub emissive: String,
    /// Also write the direct-light part as linear OpenEXR.
    #[arg(long)]
    pub direct_exr: Option<PathBuf>,
    /// Also write the indirect part (outgoing radiance) as linear OpenEXR.
    #[arg(long)]
    pub indirect_exr: Option<PathBuf>,
    /// Also write the indirect irradiance at the first hit (what GI techniques output).
    #[arg(long)]
    pub irradiance_exr: Option<PathBuf>,
    /// Also write the irradiance at the first hit arriving straight from emissive surfaces
    /// (part of the direct light; the cone tracers and probes output it with their indirect
    /// irradiance).
    #[arg(long)]
    pub emitter_irradiance_exr: Option<PathBuf>,
}

/// Sampling options of the reference path tracer (shared by `render` and `bench`).
#[derive(Args, Debug, Clone)]
pub struct SamplingArgs {
    /// Samples per pixel of the reference.
    #[arg(long, default_value_t = 64)]
    pub spp: u32,
    /// Stop refining after this many seconds (the image keeps the samples done so far).
    #[arg(long)]
    pub time_budget: Option<f64>,
    /// Random seed (same seed, same image).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

impl ReferenceArgs {
    /// Library settings from the flags.
    pub fn settings(&self) -> Result<ReferenceSettings> {
        Ok(self
            .sampling
            .settings(self.bounces.parse::<Bounces>()?)?
            .with_transport(Transport {
                bounces: self.bounces.parse::<Bounces>()?,
                emissive: self.emissive.parse::<EmissiveSurfaces>()?,
            }))
    }
}

impl SamplingArgs {
    /// Library settings from the flags, for the given transport.
    pub fn settings(&self, bounces: Bounces) -> Result<ReferenceSettings> {
        if self.spp == 0 {
            bail!("--spp must be at least 1");
        }
        let time_budget = match self.time_budget {
            Some(s) if s.is_finite() && s > 0.0 => Some(Duration::from_secs_f64(s)),
            Some(s) => bail!("--time-budget {s}: must be a positive number of seconds"),
            None => None,
        };
        Ok(ReferenceSettings {
            spp: self.spp,
            bounces,
            time_budget,
            seed: self.seed,
            ..ReferenceSettings::default()
        })
    }
}

/// A progress bar for `len` units of work labelled `what`, hidden when not on a terminal.
pub fn progress_bar(len: u64, what: &str) -> ProgressBar {
    ProgressBar::new(len).with_style(
        ProgressStyle::with_template(&format!(
            "{{bar:40}} {{pos}}/{{len}} {what}, {{elapsed}} ({{eta}} left)"
        ))
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    )
}

/// Renders the reference for one frame with a progress bar over samples per pixel.
pub fn reference_frame(
    scene: &Scene,
    t: f32,
    camera: usize,
    width: u32,
    height: u32,
    settings: &ReferenceSettings,
) -> Result<ReferenceImages> {
    let frame = scene.frame(t, camera);
    let bar = progress_bar(
        settings.spp as u64,
        &format!("spp ({})", settings.transport()),
    );
    let images = reference::render(scene, &frame, width, height, settings, &|done, _| {
        bar.set_position(done as u64)
    })?;
    bar.finish_and_clear();
    Ok(images)
}

fn run_reference(args: &RenderArgs, scene: &Scene) -> Result<()> {
    let settings = args.reference.settings()?;
    crate::inputs::warn_unfollowed_requests(
        scene,
        "the reference follows",
        settings.transport(),
        Some(settings.spp),
    );
    let start = std::time::Instant::now();
    let mut spp_done = 0;
    for i in 0..args.frames {
        let t = args.start_time() + i as f32 / args.fps;
        let camera = scene.camera_index(&args.camera)?;
        let images = reference_frame(scene, t, camera, args.width, args.height, &settings)?;
        spp_done = images.spp_done;
        warn_if_black(scene, camera, t, &images.total);
        write_image(
            &frame_path(&args.out, i, args.frames),
            &images.total,
            None,
            scene.exposure,
        )?;
        let extra = [
            (&args.exr, &images.total),
            (&args.reference.direct_exr, &images.direct),
            (&args.reference.indirect_exr, &images.indirect),
            (&args.reference.irradiance_exr, &images.indirect_irradiance),
            (
                &args.reference.emitter_irradiance_exr,
                &images.emitter_irradiance,
            ),
        ];
        for (path, image) in extra {
            if let Some(path) = path {
                image.write_exr(&frame_path(path, i, args.frames))?;
            }
        }
    }
    println!(
        "reference: {} frame(s) of '{}' at {}x{}, {} spp, {} in {:.2} s -> {}",
        args.frames,
        scene.name,
        args.width,
        args.height,
        spp_done,
        settings.transport(),
        start.elapsed().as_secs_f64(),
        args.out.display()
    );
    Ok(())
}

fn run_voxel_view(args: &RenderArgs, scene: &Scene) -> Result<()> {
    use octolux::voxel::debug;
    if !args
        .out
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("png"))
    {
        bail!("{}: --view voxels writes a .png", args.out.display());
    }
    let ctx = GpuContext::new(&args.gpu.options())?;
    let (rgb, summary) = debug::render_scene(
        &ctx,
        scene,
        args.start_time(),
        scene.camera_index(&args.camera)?,
        args.width,
        args.height,
        args.voxel_structure.parse()?,
        args.voxel_res,
        args.level,
    )?;
    write_rgb8_png(&args.out, args.width, args.height, rgb)?;
    println!("{summary} -> {}", args.out.display());
    Ok(())
}

/// The GPU renderer's settings from the command line.
fn render_settings(
    args: &RenderArgs,
    scene: &Scene,
    gi_settings: GiSettings,
) -> Result<RenderSettings> {
    Ok(RenderSettings {
        width: args.width,
        height: args.height,
        shadow_map_size: args.gpu.shadow_map_size,
        camera: scene.camera_index(&args.camera)?,
        gi: args.gi.clone(),
        gi_settings,
        soft_sky_shadows: args.gpu.soft_sky_shadows,
    })
}

fn run_probe_view(args: &RenderArgs, scene: &Scene, gi_settings: GiSettings) -> Result<()> {
    use octolux::gi::probes::debug::{Layers, ProbeSnapshot};
    if !octolux::gi::technique(&args.gi).is_ok_and(|t| t.is_probes()) {
        bail!(
            "--view probes shows a probe technique: use --gi probes-grid or probes-octree, not {}",
            args.gi
        );
    }
    if !args
        .out
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("png"))
    {
        bail!("{}: --view probes writes a .png", args.out.display());
    }
    let layers: Layers = args.probe_layers.parse()?;
    if args.probe_frames == 0 || args.probe_frames > 10_000 {
        bail!("--probe-frames {}: expected 1..=10000", args.probe_frames);
    }
    let ctx = GpuContext::new(&args.gpu.options())?;
    let settings = render_settings(args, scene, gi_settings)?;
    let mut renderer = Renderer::new(&ctx, scene, settings).context("setting up the renderer")?;
    // The marks go over whichever image --output names (e.g. `indirect`).
    renderer.set_output(parse_output(&args.output)?);
    for _ in 0..args.probe_frames {
        renderer.render(scene, args.start_time())?;
    }
    let snapshot = ProbeSnapshot::read(&ctx, renderer.technique())?;
    let view = renderer
        .last_view()
        .context("the renderer kept no camera view")?;
    let depth = renderer.read_gbuffer()?.depth;
    let mut rgb = renderer.read_display()?;
    snapshot.draw(view, &depth, &mut rgb, scene.exposure, layers)?;
    write_rgb8_png(&args.out, args.width, args.height, rgb)?;
    println!(
        "{}: {} probes ({} gathered), {} octree cells, {} surfels on front faces -> {}",
        args.gi,
        snapshot.probes.len(),
        snapshot.valid_probes(),
        snapshot.cells.len(),
        snapshot.surfels.len(),
        args.out.display()
    );
    Ok(())
}

/// Output path of frame `i` of `n`.
pub fn frame_path(base: &Path, i: u32, n: u32) -> PathBuf {
    if n <= 1 {
        return base.to_path_buf();
    }
    let stem = base
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let ext = base
        .extension()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    base.with_file_name(format!("{stem}_{i:04}.{ext}"))
}

/// Linear radiance under which a pixel shows as 0 in an 8-bit sRGB image (half a step).
const DISPLAYS_AS_BLACK: f32 = 0.5 / 255.0 / 12.92;

/// Warns, with the likely cause, when `image` (camera `camera` at time `t`) shows nothing but
/// the scene has light: a camera outside a closed room, behind a wall or looking at nothing,
/// or lights that do not reach what it sees.
fn warn_if_black(scene: &Scene, camera: usize, t: f32, image: &HdrImage) {
    if !scene.has_light() {
        return; // warned when the scene was loaded
    }
    let gain = 2f32.powf(scene.exposure);
    if image
        .pixels
        .iter()
        .any(|p| p.max_element() * gain >= DISPLAYS_AS_BLACK)
    {
        return;
    }
    let view = scene.camera_at(t, camera);
    let survey = scene.view_survey(&view, t);
    let percent = |n: u32| 100 * n / survey.rays.max(1);
    let cause = if survey.misses == survey.rays {
        format!(
            "camera '{}' sees no geometry: check its position and target",
            view.name
        )
    } else if survey.back_faces > survey.front_faces {
        format!(
            "camera '{}' sees mostly the backs of surfaces ({}% of its view), as from outside a \
             closed room or behind a wall: move it inside, or leave the scene without a camera \
             and octolux frames it",
            view.name,
            percent(survey.back_faces)
        )
    } else {
        format!(
            "the light does not reach what camera '{}' sees (the lights are blocked, point \
             away or are far too weak), or the exposure ({} EV) is far too low",
            view.name, scene.exposure
        )
    };
    eprintln!("warning: the image is black although the scene has light: {cause}");
}

/// Writes an image to `path`, choosing PNG or EXR by extension.
pub fn write_image(
    path: &Path,
    hdr: &HdrImage,
    display: Option<Vec<u8>>,
    exposure: f32,
) -> Result<()> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_lowercase())
        .unwrap_or_default();
    match ext.as_str() {
        "exr" => hdr.write_exr(path)?,
        "png" => match display {
            Some(rgb) => write_rgb8_png(path, hdr.width, hdr.height, rgb)?,
            None => hdr.write_png(path, exposure)?,
        },
        _ => bail!("{}: output must end in .png or .exr", path.display()),
    }
    Ok(())
}

/// Most frames one `render` writes.
const MAX_FRAMES: u32 = 1_000_000;

/// The files `render` reads that it must never overwrite: the scene, the models its scene
/// file names, and a `--sky` map.
fn input_files(args: &RenderArgs) -> Vec<PathBuf> {
    let mut inputs = Vec::new();
    if let Some(scene) = &args.scene {
        inputs.push(scene.clone());
        if scene
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("toml"))
        {
            inputs.extend(octolux::scene::file::model_files(scene).unwrap_or_default());
        }
    }
    if let Some(sky) = &args.sky_args.sky {
        inputs.push(PathBuf::from(sky));
    }
    inputs
}

/// Checks the flags that need no scene, and every output file, before anything is loaded;
/// once the scene is loaded, again with `loaded`, every file its loading read (textures,
/// materials, sky maps), before anything is rendered.
fn check_args(args: &RenderArgs, loaded: &[PathBuf]) -> Result<()> {
    check_image_size(args.width, args.height)
        .with_context(|| format!("--width {} --height {}", args.width, args.height))?;
    if args.frames == 0 || args.frames > MAX_FRAMES {
        bail!("--frames {}: expected 1..={MAX_FRAMES}", args.frames);
    }
    if args.warmup.is_some_and(|w| w > MAX_FRAMES) {
        bail!(
            "--warmup {}: expected 0..={MAX_FRAMES}",
            args.warmup.unwrap_or(0)
        );
    }
    check_fps(args.fps)?;
    if !args.time.is_finite() {
        bail!("--time {}: expected a finite number of seconds", args.time);
    }
    let output = parse_output(&args.output)?;
    let gpu = args.gi != "reference";
    let reference_only = [
        ("--direct-exr", &args.reference.direct_exr),
        ("--indirect-exr", &args.reference.indirect_exr),
        ("--irradiance-exr", &args.reference.irradiance_exr),
        (
            "--emitter-irradiance-exr",
            &args.reference.emitter_irradiance_exr,
        ),
    ];
    if gpu {
        if let Some((flag, _)) = reference_only.iter().find(|(_, p)| p.is_some()) {
            bail!(
                "{flag} writes a part of the reference's light: use it with --gi reference \
                 (--output direct or indirect shows that part for a GPU technique)"
            );
        }
        match output {
            Output::AmbientOcclusion if !args.gi.starts_with("vct-") => bail!(
                "--output ao: only the cone tracers (--gi vct-svo, vct-clipmap) compute \
                 ambient occlusion, not --gi {}",
                args.gi
            ),
            Output::Specular if !args.gi.starts_with("vct-") => bail!(
                "--output specular: only the cone tracers (--gi vct-svo, vct-clipmap, with \
                 --vct-specular) compute a specular image, not --gi {}",
                args.gi
            ),
            _ => {}
        }
    } else if output != Output::Final {
        bail!(
            "--output {}: with --gi reference the image is the whole light; --direct-exr, \
             --indirect-exr and --irradiance-exr write its parts",
            args.output
        );
    }
    let out_format = if args.view == "shaded" {
        Format::Image
    } else {
        Format::Png
    };
    let mut planned = Vec::new();
    for i in 0..args.frames {
        let frame = |p: &Path| frame_path(p, i, args.frames);
        planned.push(("--out", frame(&args.out), out_format));
        if let Some(p) = &args.exr {
            planned.push(("--exr", frame(p), Format::Exr));
        }
        for (flag, path) in reference_only {
            if let Some(p) = path {
                planned.push((flag, frame(p), Format::Exr));
            }
        }
        if i == 0 && args.frames > 16 {
            // The later frames' names differ in their number alone: check the last one too.
            let last = args.frames - 1;
            planned.push((
                "--out",
                frame_path(&args.out, last, args.frames),
                out_format,
            ));
            break;
        }
    }

    let mut inputs = input_files(args);
    inputs.extend(loaded.iter().cloned());
    crate::outputs::check_paths(&planned, &inputs)
}

/// Runs `octolux render`.
pub fn run(args: &RenderArgs) -> Result<()> {
    check_args(args, &[])?;
    let start_time = args.start_time();
    let load_start = std::time::Instant::now();
    let (loaded, files) = octolux::limits::recording_reads(|| {
        load_scene(
            args.scene.as_deref(),
            &args.gi_args,
            &args.sky_args,
            &args.budget,
        )
    });
    let (mut scene, gi_settings) = loaded?;
    check_args(args, &files)?;
    let load_s = load_start.elapsed().as_secs_f64();
    log::info!(
        "loaded '{}' ({} triangles) in {load_s:.2} s",
        scene.name,
        scene.triangle_count()
    );
    let camera = scene.camera_index(&args.camera)?;
    if let Some(ev) = args.exposure {
        if !ev.is_finite() || ev.abs() > 64.0 {
            bail!("--exposure {ev}: expected a finite EV within -64..=64");
        }
        scene.exposure = ev;
    }
    match args.view.as_str() {
        "shaded" => {}
        "voxels" => return run_voxel_view(args, &scene),
        "probes" => return run_probe_view(args, &scene, gi_settings),
        other => bail!("--view {other}: expected shaded, voxels or probes"),
    }
    if !gi_settings.vct.specular && parse_output(&args.output)? == Output::Specular {
        bail!(
            "--output specular: the cone tracers compute a specular image only with \
             --vct-specular (or `specular = true` in the scene's [settings.vct])"
        );
    }
    if args.gi == "reference" {
        run_reference(args, &scene)?;
        if args.stats {
            println!("scene load: {load_s:.3} s");
        }
        return Ok(());
    }
    let ctx = GpuContext::new(&args.gpu.options())?;
    log::info!("adapter: {}", ctx.describe());
    let settings = render_settings(args, &scene, gi_settings)?;
    let start = std::time::Instant::now();
    let output = parse_output(&args.output)?;
    let mut renderer = Renderer::new(&ctx, &scene, settings).context("setting up the renderer")?;
    crate::inputs::warn_unfollowed_requests(
        &scene,
        &format!("--gi {} computes", args.gi),
        renderer
            .technique()
            .reference_transport()
            .for_scene(scene.has_emissive_surfaces()),
        None,
    );
    renderer.set_output(output);
    let warmup = args
        .warmup
        .unwrap_or_else(|| renderer.technique().settle_frames());
    let progress = if args.frames + warmup > 1 {
        progress_bar((args.frames + warmup) as u64, "frames")
    } else {
        ProgressBar::hidden()
    };
    // A light beyond what a technique stores shows from its first frame: that one is checked
    // too, so the error does not wait for the technique to settle.
    let finite = |hdr: &HdrImage, frame: &str, t: f32| -> Result<()> {
        if let Some((x, y, v)) = hdr.first_non_finite() {
            bail!(
                "{frame} at t = {t} s: --gi {} produced {v} at pixel ({x}, {y}): the light is \
                 beyond what it stores (the cone tracers keep radiance in half floats, at most \
                 65504); lower the scene's light intensities or emission",
                args.gi
            );
        }
        Ok(())
    };
    for w in 0..warmup {
        renderer.render(&scene, start_time)?;
        if w == 0 {
            finite(&renderer.read_hdr()?, "warm-up frame 0", start_time)?;
        }
        progress.inc(1);
    }
    let mut all_timings = Vec::new();
    for i in 0..args.frames {
        let t = start_time + i as f32 / args.fps;
        all_timings.push(renderer.render(&scene, t)?);
        let hdr = renderer.read_hdr()?;
        finite(&hdr, &format!("frame {i}"), t)?;
        if output == Output::Final {
            warn_if_black(&scene, camera, t, &hdr);
        }
        let display = renderer.read_display()?;
        write_image(
            &frame_path(&args.out, i, args.frames),
            &hdr,
            Some(display),
            scene.exposure,
        )?;
        if let Some(exr) = &args.exr {
            hdr.write_exr(&frame_path(exr, i, args.frames))?;
        }
        progress.inc(1);
    }
    progress.finish_and_clear();
    println!(
        "rendered {} frame(s){} of '{}' ({} triangles) at {}x{} with --gi {} in {:.2} s -> {}",
        args.frames,
        if warmup > 0 {
            format!(" after {warmup} to settle")
        } else {
            String::new()
        },
        scene.name,
        scene.triangle_count(),
        args.width,
        args.height,
        args.gi,
        start.elapsed().as_secs_f64(),
        args.out.display()
    );
    if args.stats {
        println!("scene load: {load_s:.3} s");
        println!("adapter: {}", ctx.describe());
        crate::stats::print_timings(
            &crate::stats::average_timings(&all_timings),
            all_timings.len(),
        );
        crate::stats::print_memory(&ctx.ledger);
        crate::stats::print_objects(&ctx);
        crate::stats::print_technique_state(&ctx, renderer.technique())?;
    }
    Ok(())
}
