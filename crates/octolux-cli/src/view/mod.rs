//! `octolux view`: a window that renders a scene in real time with the same [`Renderer`] as
//! `octolux render`, with a fly camera, a run-time technique switch and its settings, live pass
//! times and GPU memory, the renderer's outputs, and a comparison with the CPU reference that
//! refines while the camera rests.
//!
//! One file per concern: [`app`] (window, surface and event loop), [`camera`] (fly camera),
//! [`panels`] (the egui panels), [`timing`] (pass-time history and its graph), [`compare`]
//! (the progressive reference and its error) and [`screenshot`] (images of the view).
//!
//! [`Renderer`]: octolux::render::Renderer

mod app;
mod camera;
mod compare;
mod panels;
mod screenshot;
mod timing;

use crate::gi_args::{GiArgs, DEFAULT_GI};
use crate::inputs::GpuArgs;
use anyhow::{bail, Result};
use clap::Args;
use std::path::PathBuf;

/// Arguments of `octolux view`.
#[derive(Args, Debug)]
pub struct ViewArgs {
    /// Scene file (.toml), or a model (.gltf, .glb, .obj, .ply, .ply.gz). Default: the
    /// built-in Cornell box.
    pub scene: Option<PathBuf>,
    /// GI technique at start: any GPU technique of `render --gi` (switch in the window).
    #[arg(long, default_value = DEFAULT_GI)]
    pub gi: String,
    /// Which of the scene's cameras to start at: its index or its name (R returns to it).
    #[arg(long, default_value = "0")]
    pub camera: String,
    /// Scene time in seconds at start.
    #[arg(long, default_value_t = 0.0)]
    pub time: f32,
    /// Start with the animation playing.
    #[arg(long)]
    pub play: bool,
    /// What to show at start: `final`, `direct`, `indirect` (the indirect irradiance), `ao`
    /// (the cone tracers' ambient occlusion) or `specular` (their specular cone).
    #[arg(long, default_value = "final")]
    pub output: String,
    /// Exposure in EV (stops), replacing the scene's.
    #[arg(long, allow_hyphen_values = true)]
    pub exposure: Option<f32>,
    /// Window size in pixels, WIDTHxHEIGHT.
    #[arg(long, default_value = "1280x720")]
    pub window: String,
    /// Render at this fixed size, WIDTHxHEIGHT, scaled to fit the view (default: the size of
    /// the view area times --scale).
    #[arg(long)]
    pub size: Option<String>,
    /// Render resolution relative to the view area when --size is not given (0.1..=2).
    #[arg(long, default_value_t = 1.0)]
    pub scale: f32,
    /// Split screen: the right half of the view shows this technique (a second renderer on the
    /// same view), the left half the one chosen with --gi.
    #[arg(long)]
    pub split: Option<String>,
    /// Start in compare mode: the CPU reference refines while the camera rests, with the FLIP
    /// error map and FLIP / relMSE against it.
    #[arg(long)]
    pub compare: bool,
    /// What the view shows in compare mode: `technique`, `reference` or `error` (the FLIP
    /// error map).
    #[arg(long, default_value = "technique")]
    pub compare_view: String,
    /// Samples per pixel the reference refines to in compare mode.
    #[arg(long, default_value_t = 256)]
    pub spp: u32,
    /// Render --frames frames, write the rendered image (without panels) to this PNG and the
    /// linear image beside it as .exr, and exit.
    #[arg(long, help_heading = "Scripted runs")]
    pub screenshot: Option<PathBuf>,
    /// Also (or only) write the whole window, panels included, to this PNG before exiting.
    #[arg(long, help_heading = "Scripted runs")]
    pub screenshot_window: Option<PathBuf>,
    /// Frames to render before a --screenshot / --screenshot-window (default 10) or before
    /// exiting.
    #[arg(long, help_heading = "Scripted runs")]
    pub frames: Option<u32>,
    /// Exit after this many seconds (a soak run; with -v the frame-rate and memory summary is
    /// printed at exit).
    #[arg(long, help_heading = "Scripted runs")]
    pub seconds: Option<f64>,
    /// Switch to this technique after half of --frames, through the same switch the panel
    /// uses.
    #[arg(long, help_heading = "Scripted runs")]
    pub then_gi: Option<String>,
    /// GPU options.
    #[command(flatten, next_help_heading = "GPU")]
    pub gpu: GpuArgs,
    /// Technique settings (also editable in the window).
    #[command(flatten, next_help_heading = "Technique settings")]
    pub gi_args: GiArgs,
    /// Sky light.
    #[command(flatten, next_help_heading = "Sky")]
    pub sky_args: crate::sky_args::SkyArgs,
    /// What the scene may pull in.
    #[command(flatten, next_help_heading = "Scene budget")]
    pub budget: crate::inputs::BudgetArgs,
}

/// Parses `WIDTHxHEIGHT`.
pub fn parse_size(text: &str, flag: &str) -> Result<(u32, u32)> {
    let parsed = text
        .split_once(['x', 'X'])
        .and_then(|(w, h)| Some((w.trim().parse().ok()?, h.trim().parse().ok()?)));
    match parsed {
        Some((w, h)) if w > 0 && h > 0 => Ok((w, h)),
        _ => bail!("{flag} {text}: expected WIDTHxHEIGHT, e.g. 1280x720"),
    }
}

/// The explanation given whenever no window can be opened.
pub(super) const NO_DISPLAY_HINT: &str =
    "`octolux view` needs a display (X11, or XWayland on a Wayland \
desktop); on a machine without one, render images with `octolux render` instead, or run the \
viewer under a virtual display such as Xvfb";

/// Fails with a clear message when no display server is named in the environment (Linux and
/// the BSDs; elsewhere the window system is always there).
fn check_display() -> Result<()> {
    if cfg!(all(
        unix,
        not(target_os = "macos"),
        not(target_os = "android")
    )) {
        let set = |name: &str| std::env::var_os(name).is_some_and(|v| !v.is_empty());
        if !set("DISPLAY") && !set("WAYLAND_DISPLAY") {
            bail!("no display: DISPLAY and WAYLAND_DISPLAY are unset. {NO_DISPLAY_HINT}");
        }
    }
    Ok(())
}

/// Runs `octolux view`.
pub fn run(args: &ViewArgs, verbose: bool) -> Result<()> {
    let config = app::Config::from_args(args)?;
    check_display()?;
    app::run(config, verbose)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_or_explain() {
        assert_eq!(parse_size("640x360", "--size").unwrap(), (640, 360));
        assert_eq!(parse_size(" 8 X 4 ", "--size").unwrap(), (8, 4));
        for bad in ["640", "0x10", "ax4", "-3x4", ""] {
            let err = parse_size(bad, "--size").unwrap_err().to_string();
            assert!(err.contains("WIDTHxHEIGHT"), "{bad}: {err}");
        }
    }
}
