//! `octolux bench`: every listed technique and the matching reference on the same scene,
//! camera and frame; one table of per-pass GPU time, memory and error against the reference.

use crate::gi_args::GiArgs;
use crate::render::{load_scene, reference_frame, GpuArgs, SamplingArgs};
use crate::stats::{average_timings, mib};
use anyhow::{bail, Context, Result};
use clap::Args;
use octolux::gpu::{GpuContext, PassTiming};
use octolux::image_io::HdrImage;
use octolux::metrics::{self, Metrics};
use octolux::reference::{Bounces, ReferenceImages};
use octolux::render::{check_image_size, RenderSettings, Renderer};
use serde::Serialize;
use std::path::PathBuf;

/// Arguments of `octolux bench`.
#[derive(Args, Debug)]
pub struct BenchArgs {
    /// Scene file or model (default: the built-in Cornell box).
    pub scene: Option<PathBuf>,
    /// Comma-separated GPU techniques to measure (see `octolux render --help`).
    #[arg(long, value_delimiter = ',', default_value = "none")]
    pub gi: Vec<String>,
    /// Image width.
    #[arg(long, default_value_t = 320)]
    pub width: u32,
    /// Image height.
    #[arg(long, default_value_t = 180)]
    pub height: u32,
    /// Scene time (s) of the benchmarked frame.
    #[arg(long, default_value_t = 0.0)]
    pub time: f32,
    /// Scene camera.
    #[arg(long, default_value_t = 0)]
    pub camera: usize,
    /// Frames rendered before measuring (pipelines warm, caches filled).
    #[arg(long, default_value_t = 2)]
    pub warmup: u32,
    /// Frames measured; pass times are their mean.
    #[arg(long, default_value_t = 8)]
    pub frames: u32,
    /// Judge every technique against this transport instead of the one it claims
    /// (`direct`, a number of bounces, `unlimited`); e.g. `1` to compare GI off and on.
    #[arg(long)]
    pub against: Option<String>,
    /// Write the results as JSON to this file (`-` for standard output).
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write every technique's image and every reference as EXR + PNG into this folder.
    #[arg(long)]
    pub out_dir: Option<PathBuf>,
    /// Reference sampling (the transport is the one each technique claims, or `--against`).
    #[command(flatten, next_help_heading = "Reference path tracer")]
    pub sampling: SamplingArgs,
    /// GPU options.
    #[command(flatten, next_help_heading = "GPU")]
    pub gpu: GpuArgs,
    /// Technique settings.
    #[command(flatten, next_help_heading = "Technique settings")]
    pub gi_args: GiArgs,
}

/// One technique's results.
#[derive(Serialize)]
pub struct TechniqueResult {
    /// Technique name.
    pub technique: String,
    /// The reference it was judged against.
    pub reference: String,
    /// Mean per-pass times.
    pub passes: Vec<PassTiming>,
    /// Sum of the pass times.
    pub total_ms: f64,
    /// GPU memory the technique itself owns.
    pub technique_mib: f64,
    /// All GPU memory of the frame (scene, G-buffer, shadows, technique...).
    pub total_mib: f64,
    /// Error against the reference.
    pub metrics: Metrics,
}

/// One reference render.
#[derive(Serialize)]
pub struct ReferenceResult {
    /// Light transport.
    pub bounces: String,
    /// Samples per pixel done.
    pub spp: u32,
    /// CPU wall time in seconds.
    pub seconds: f64,
}

/// The whole report.
#[derive(Serialize)]
pub struct BenchReport {
    /// Scene name.
    pub scene: String,
    /// Image size.
    pub width: u32,
    /// Image size.
    pub height: u32,
    /// Scene time of the frame.
    pub time: f32,
    /// GPU adapter and timing source.
    pub adapter: String,
    /// Per technique.
    pub techniques: Vec<TechniqueResult>,
    /// Per reference rendered.
    pub references: Vec<ReferenceResult>,
}

/// Runs `octolux bench`.
pub fn run(args: &BenchArgs) -> Result<()> {
    check_image_size(args.width, args.height)?;
    if args.frames == 0 {
        bail!("--frames must be at least 1");
    }
    if args.gi.iter().any(|g| g == "reference") {
        bail!("--gi lists GPU techniques; the reference is always rendered");
    }
    let against = args
        .against
        .as_deref()
        .map(str::parse::<Bounces>)
        .transpose()?;
    let mut reference_settings = args.sampling.settings(Bounces::Unlimited)?;
    let (scene, gi_settings) = load_scene(args.scene.as_deref(), &args.gi_args)?;
    let options = args.gpu.options();
    let mut techniques = Vec::new();
    let mut images: Vec<(String, Bounces, HdrImage)> = Vec::new();
    let mut adapter = String::new();
    for name in &args.gi {
        // A fresh device per technique keeps its memory ledger to itself.
        let ctx = GpuContext::new(&options)?;
        adapter = ctx.describe();
        let settings = RenderSettings {
            width: args.width,
            height: args.height,
            shadow_map_size: args.gpu.shadow_map_size,
            camera: args.camera,
            gi: name.clone(),
            gi_settings: gi_settings.clone(),
        };
        let mut renderer = Renderer::new(&ctx, &scene, settings)
            .with_context(|| format!("setting up '{name}'"))?;
        for _ in 0..args.warmup {
            renderer.render(&scene, args.time)?;
        }
        let mut frames = Vec::new();
        for _ in 0..args.frames {
            frames.push(renderer.render(&scene, args.time)?);
        }
        let bounces = against.unwrap_or_else(|| renderer.technique().reference_bounces());
        let passes = average_timings(&frames);
        let technique_bytes: u64 = ctx
            .ledger
            .by_owner()
            .iter()
            .filter(|(o, _)| o == name)
            .map(|(_, b)| b)
            .sum();
        techniques.push(TechniqueResult {
            technique: name.clone(),
            reference: bounces.to_string(),
            total_ms: passes.iter().map(|p| p.ms).sum(),
            passes,
            technique_mib: mib(technique_bytes),
            total_mib: mib(ctx.ledger.total()),
            metrics: Metrics::default(),
        });
        images.push((name.clone(), bounces, renderer.read_hdr()?));
    }

    let mut references: Vec<(Bounces, ReferenceImages, f64)> = Vec::new();
    for (_, bounces, _) in &images {
        if references.iter().any(|(b, _, _)| b == bounces) {
            continue;
        }
        reference_settings.bounces = *bounces;
        let start = std::time::Instant::now();
        let images = reference_frame(
            &scene,
            args.time,
            args.camera,
            args.width,
            args.height,
            &reference_settings,
        )?;
        references.push((*bounces, images, start.elapsed().as_secs_f64()));
    }
    for (result, (name, bounces, image)) in techniques.iter_mut().zip(&images) {
        let Some((_, reference, _)) = references.iter().find(|(b, _, _)| b == bounces) else {
            bail!("no reference rendered for '{name}'");
        };
        result.metrics = metrics::compare(image, &reference.total, None)?;
    }
    if let Some(dir) = &args.out_dir {
        for (name, _, image) in &images {
            image.write_exr(&dir.join(format!("{name}.exr")))?;
            image.write_png(&dir.join(format!("{name}.png")), scene.exposure)?;
        }
        for (bounces, reference, _) in &references {
            let stem = format!("reference-{}", bounces.to_string().replace(' ', "-"));
            reference
                .total
                .write_exr(&dir.join(format!("{stem}.exr")))?;
            reference
                .total
                .write_png(&dir.join(format!("{stem}.png")), scene.exposure)?;
        }
    }
    let report = BenchReport {
        scene: scene.name.clone(),
        width: args.width,
        height: args.height,
        time: args.time,
        adapter,
        techniques,
        references: references
            .iter()
            .map(|(b, r, s)| ReferenceResult {
                bounces: b.to_string(),
                spp: r.spp_done,
                seconds: *s,
            })
            .collect(),
    };
    print_report(&report);
    if let Some(path) = &args.json {
        let text = serde_json::to_string_pretty(&report)?;
        if path.as_os_str() == "-" {
            println!("{text}");
        } else {
            std::fs::write(path, text).with_context(|| format!("writing {}", path.display()))?;
        }
    }
    Ok(())
}

fn print_report(report: &BenchReport) {
    println!(
        "bench: '{}' at {}x{}, t = {} s; adapter: {}",
        report.scene, report.width, report.height, report.time, report.adapter
    );
    println!(
        "  {:<16} {:>10} {:>10} {:>10} {:>9} {:>11}  reference",
        "technique", "GPU ms", "tech MiB", "total MiB", "FLIP", "relMSE"
    );
    for t in &report.techniques {
        println!(
            "  {:<16} {:>10.3} {:>10.3} {:>10.3} {:>9.4} {:>11.4e}  {}",
            t.technique,
            t.total_ms,
            t.technique_mib,
            t.total_mib,
            t.metrics.flip,
            t.metrics.rel_mse,
            t.reference
        );
    }
    for r in &report.references {
        println!(
            "  reference ({}): {} spp in {:.2} s (CPU)",
            r.bounces, r.spp, r.seconds
        );
    }
    println!("per-pass ms:");
    for t in &report.techniques {
        let passes: Vec<String> = t
            .passes
            .iter()
            .map(|p| format!("{} {:.3}", p.name, p.ms))
            .collect();
        println!("  {:<16} {}", t.technique, passes.join(", "));
    }
}
