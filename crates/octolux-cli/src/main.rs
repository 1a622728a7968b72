//! `octolux`: render scenes with a GI technique or the reference path tracer, compare images
//! and benchmark techniques against the reference.

mod bench;
mod diff;
mod gi_args;
mod inputs;
mod outputs;
mod render;
mod sky_args;
mod stats;
mod view;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// Real-time diffuse global illumination on the GPU, with a reference path tracer to judge it.
#[derive(Parser)]
#[command(name = "octolux", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// Log more (-v: info, -vv: debug). RUST_LOG overrides.
    #[arg(short, long, global = true, action = clap::ArgAction::Count)]
    verbose: u8,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene (default: the built-in Cornell box) to PNG and/or OpenEXR.
    Render(render::RenderArgs),
    /// Render techniques and the matching reference on one scene; per-pass times, memory, error.
    Bench(bench::BenchArgs),
    /// Compare two images (MSE, relMSE, PSNR, SSIM, FLIP) and optionally write an error map.
    Diff(diff::DiffArgs),
    /// Open a window that renders a scene in real time: fly camera, technique switch and
    /// settings, pass times, GPU memory, and comparison with the CPU reference.
    View(view::ViewArgs),
}

fn main() -> ExitCode {
    // Mesa's Vulkan drivers print "XDG_RUNTIME_DIR is invalid or not set" on every device
    // creation when it is unset (headless machines, CI), which reads like a failure. Nothing
    // of ours uses it; point it at the temporary folder before any thread starts.
    #[cfg(target_os = "linux")]
    if std::env::var_os("XDG_RUNTIME_DIR").is_none() {
        // SAFETY: no other thread exists yet, so nothing can read the environment concurrently.
        unsafe { std::env::set_var("XDG_RUNTIME_DIR", std::env::temp_dir()) };
    }
    let cli = Cli::parse();
    let level = match cli.verbose {
        0 => "warn",
        1 => "info",
        _ => "debug",
    };
    env_logger::Builder::from_env(
        env_logger::Env::default()
            .default_filter_or(format!("{level},wgpu_core=error,wgpu_hal=error,naga=error")),
    )
    .format_timestamp(None)
    .init();
    let result = match &cli.command {
        Command::Render(args) => render::run(args),
        Command::Diff(args) => diff::run(args),
        Command::Bench(args) => bench::run(args),
        Command::View(args) => view::run(args, cli.verbose > 0),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", message(&e));
            ExitCode::FAILURE
        }
    }
}

/// The error and its causes on one line, `: `-separated, leaving out a cause whose text the
/// message before it already holds (an OS error inside a message that quotes it).
fn message(e: &anyhow::Error) -> String {
    let mut out = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if out.contains(&text) {
            continue;
        }
        if !out.is_empty() {
            out.push_str(": ");
        }
        out.push_str(&text);
    }
    out
}

#[cfg(test)]
mod tests {
    #[test]
    fn causes_are_printed_once() {
        let io = std::io::Error::new(std::io::ErrorKind::NotFound, "No such file");
        let e = anyhow::Error::from(octolux::Error::io("a.obj", io)).context("loading the scene");
        assert_eq!(super::message(&e), "loading the scene: a.obj: No such file");
    }
}
