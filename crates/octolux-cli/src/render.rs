//! `octolux render`.

use anyhow::{bail, Context, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use octolux::gpu::{AdapterChoice, GpuContext, GpuOptions};
use octolux::image_io::{write_rgb8_png, HdrImage};
use octolux::render::{check_image_size, RenderSettings, Renderer};
use octolux::scene::{cornell, Scene};
use std::path::{Path, PathBuf};

/// Arguments of `octolux render`.
#[derive(Args, Debug)]
pub struct RenderArgs {
    /// Scene file (.toml), or a model (.gltf, .glb, .obj, .ply, .ply.gz). Default: the
    /// built-in Cornell box.
    pub scene: Option<PathBuf>,
    /// Image width in pixels.
    #[arg(long, default_value_t = 640)]
    pub width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 360)]
    pub height: u32,
    /// Scene time in seconds of the (first) frame.
    #[arg(long, default_value_t = 0.0)]
    pub time: f32,
    /// Number of frames to render, `1/fps` seconds apart; with more than one, outputs are
    /// numbered (render_0000.png, ...).
    #[arg(long, default_value_t = 1)]
    pub frames: u32,
    /// Frames per second of scene time when rendering several frames.
    #[arg(long, default_value_t = 30.0)]
    pub fps: f32,
    /// Output image: .png (tone-mapped display image) or .exr (linear HDR radiance).
    #[arg(long, short, default_value = "render.png")]
    pub out: PathBuf,
    /// Also write the linear HDR image to this OpenEXR file.
    #[arg(long)]
    pub exr: Option<PathBuf>,
    /// GI technique: none (direct light only).
    #[arg(long, default_value = "none")]
    pub gi: String,
    /// Which of the scene's cameras to use.
    #[arg(long, default_value_t = 0)]
    pub camera: usize,
    /// Shadow-map resolution per layer.
    #[arg(long, default_value_t = 2048)]
    pub shadow_map_size: u32,
    /// Print per-pass times and GPU memory per owner.
    #[arg(long)]
    pub stats: bool,
    /// GPU adapter to use (substring of its name; see -v output). Also OCTOLUX_ADAPTER.
    #[arg(long)]
    pub adapter: Option<String>,
    /// Time passes on the CPU (submit + wait) even if GPU timestamps are available.
    #[arg(long)]
    pub no_timestamps: bool,
    /// Technique settings.
    #[command(flatten)]
    pub gi_args: crate::gi_args::GiArgs,
}

/// Loads the scene named on the command line, or the built-in Cornell box.
pub fn load_scene(path: Option<&Path>) -> Result<Scene> {
    match path {
        None => Ok(cornell::scene()),
        Some(p) => Ok(Scene::load(p)?),
    }
}

/// GPU options from the command line and the environment.
pub fn gpu_options(adapter: Option<&str>, no_timestamps: bool) -> GpuOptions {
    let mut options = GpuOptions::from_env();
    if let Some(name) = adapter {
        options.adapter = AdapterChoice::Named(name.to_string());
    }
    options.timestamps = !no_timestamps;
    options
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

fn check_output(path: &Path) -> Result<()> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_lowercase())
        .unwrap_or_default();
    if ext != "png" && ext != "exr" {
        bail!("{}: output must end in .png or .exr", path.display());
    }
    Ok(())
}

/// Runs `octolux render`.
pub fn run(args: &RenderArgs) -> Result<()> {
    check_image_size(args.width, args.height)?;
    check_output(&args.out)?;
    if let Some(exr) = &args.exr {
        check_output(exr)?;
    }
    if args.frames == 0 || !(args.fps > 0.0 && args.fps.is_finite()) || !args.time.is_finite() {
        bail!("--frames must be at least 1, --fps positive and --time finite");
    }
    let scene = load_scene(args.scene.as_deref())?;
    let ctx = GpuContext::new(&gpu_options(args.adapter.as_deref(), args.no_timestamps))?;
    log::info!("adapter: {}", ctx.describe());
    let settings = RenderSettings {
        width: args.width,
        height: args.height,
        shadow_map_size: args.shadow_map_size,
        camera: args.camera,
        gi: args.gi.clone(),
        gi_settings: {
            let mut s = octolux::gi::GiSettings::default();
            args.gi_args.apply(&mut s);
            s
        },
    };
    let start = std::time::Instant::now();
    let mut renderer = Renderer::new(&ctx, &scene, settings).context("setting up the renderer")?;
    let progress = if args.frames > 1 {
        ProgressBar::new(args.frames as u64).with_style(
            ProgressStyle::with_template("{bar:40} {pos}/{len} frames, {elapsed} ({eta} left)")
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        )
    } else {
        ProgressBar::hidden()
    };
    let mut all_timings = Vec::new();
    for i in 0..args.frames {
        let t = args.time + i as f32 / args.fps;
        all_timings.push(renderer.render(&scene, t)?);
        let hdr = renderer.read_hdr()?;
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
        "rendered {} frame(s) of '{}' ({} triangles) at {}x{} with --gi {} in {:.2} s -> {}",
        args.frames,
        scene.name,
        scene.triangle_count(),
        args.width,
        args.height,
        args.gi,
        start.elapsed().as_secs_f64(),
        args.out.display()
    );
    if args.stats {
        println!("adapter: {}", ctx.describe());
        crate::stats::print_timings(
            &crate::stats::average_timings(&all_timings),
            all_timings.len(),
        );
        crate::stats::print_memory(&ctx.ledger);
    }
    Ok(())
}
