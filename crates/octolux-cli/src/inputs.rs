//! What the `render`, `bench` and `view` commands read alike: the GPU options, the scene with
//! the command line's settings on top, and the name of the image to show.

use crate::gi_args::GiArgs;
use crate::sky_args::SkyArgs;
use anyhow::{bail, Context, Result};
use clap::Args;
use octolux::gi::GiSettings;
use octolux::gpu::{AdapterChoice, GpuOptions, Timestamps};
use octolux::render::Output;
use octolux::scene::{cornell, Scene};
use std::path::Path;

/// GPU options (shared by `render` and `bench`).
#[derive(Args, Debug, Clone)]
pub struct GpuArgs {
    /// Shadow-map resolution per layer.
    #[arg(long, default_value_t = 2048)]
    pub shadow_map_size: u32,
    /// GPU adapter to use (substring of its name; see -v output). Also OCTOLUX_ADAPTER.
    #[arg(long)]
    pub adapter: Option<String>,
    /// Time passes on the CPU (submit + wait) even if GPU timestamps are available.
    #[arg(long)]
    pub no_timestamps: bool,
    /// Soft shadows for the sky's lights (percentage-closer, by each light's angular size).
    #[arg(long)]
    pub soft_sky_shadows: bool,
}

impl GpuArgs {
    /// Device options from the flags and the environment.
    pub fn options(&self) -> GpuOptions {
        let mut options = GpuOptions::from_env();
        if let Some(name) = &self.adapter {
            options.adapter = AdapterChoice::Named(name.clone());
        }
        if self.no_timestamps {
            options.timestamps = Timestamps::Off;
        }
        options
    }
}

/// Loads the scene named on the command line (default: the built-in Cornell box) and the GI
/// settings of its scene file, with the command-line flags (technique settings, sky) applied
/// on top.
pub fn load_scene(
    path: Option<&Path>,
    flags: &GiArgs,
    sky: &SkyArgs,
) -> Result<(Scene, GiSettings)> {
    let (mut scene, mut settings) = match path {
        None => (cornell::scene(), GiSettings::default()),
        Some(p)
            if p.extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("toml")) =>
        {
            let (scene, table) = octolux::scene::file::load_with_settings(p)?;
            (scene, GiSettings::from_table(&table, p)?)
        }
        Some(p) => (Scene::load(p)?, GiSettings::default()),
    };
    flags.apply(&mut settings);
    if sky.sky.is_some() || sky.sky_intensity.is_some() {
        sky.apply(&mut scene)?;
        // The sky's radiance is bounded like the scene's own (a map's texels times the
        // intensity).
        octolux::scene::validate(&mut scene).context("with --sky")?;
    } else {
        sky.apply(&mut scene)?;
    }
    Ok((scene, settings))
}

/// Parses an output name.
pub fn parse_output(text: &str) -> Result<Output> {
    match text {
        "final" => Ok(Output::Final),
        "direct" => Ok(Output::Direct),
        "indirect" | "indirect-irradiance" => Ok(Output::IndirectIrradiance),
        "ao" | "ambient-occlusion" => Ok(Output::AmbientOcclusion),
        "specular" => Ok(Output::Specular),
        other => bail!("--output {other}: expected final, direct, indirect, ao or specular"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn outputs_parse() {
        assert_eq!(parse_output("direct").unwrap(), Output::Direct);
        assert_eq!(
            parse_output("indirect").unwrap(),
            Output::IndirectIrradiance
        );
        assert!(parse_output("depth").is_err());
    }
}
