//! What the `render`, `bench` and `view` commands read alike: the GPU options, the scene with
//! the command line's settings on top, and the name of the image to show.

use crate::gi_args::GiArgs;
use crate::sky_args::SkyArgs;
use anyhow::{bail, Context, Result};
use clap::Args;
use octolux::gi::GiSettings;
use octolux::gpu::{AdapterChoice, GpuOptions, Timestamps};
use octolux::limits::{Account, Budget};
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
    /// Soft shadows for the sky's lights (percentage-closer, by each light's angular size);
    /// `--soft-sky-shadows false` draws each light's shadow sharp, as a sun's.
    #[arg(long, value_name = "BOOL", default_value_t = true, num_args = 0..=1,
          default_missing_value = "true", action = clap::ArgAction::Set)]
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

/// `--budget NAME=N`: what one scene may pull in (`octolux::limits::Budget`).
#[derive(Args, Debug, Clone, Default)]
pub struct BudgetArgs {
    /// Raises (or lowers) a limit on what the scene pulls in, in all: `triangles=50M`,
    /// `instances=N`, `file-reads=N`, `bytes-read=16GiB` or `includes=N` (repeatable; the
    /// README's Limits section has the defaults).
    #[arg(long = "budget", value_name = "NAME=N")]
    pub budget: Vec<String>,
}

impl BudgetArgs {
    /// The default budget with the flags applied.
    pub fn budget(&self) -> Result<Budget> {
        let mut budget = Budget::default();
        for text in &self.budget {
            budget.apply(text)?;
        }
        Ok(budget)
    }
}

/// Loads the scene named on the command line (default: the built-in Cornell box) and the GI
/// settings of its scene file, with the command-line flags (technique settings, sky) applied
/// on top. A scene without a camera gets one that looks into it; a scene that nothing lights
/// (no light, no emissive surface, no sky, after `--sky`) is warned about.
pub fn load_scene(
    path: Option<&Path>,
    flags: &GiArgs,
    sky: &SkyArgs,
    budget: &BudgetArgs,
) -> Result<(Scene, GiSettings)> {
    let budget = budget.budget()?;
    let (mut scene, mut settings) = match path {
        None => (cornell::scene(), GiSettings::default()),
        Some(p)
            if p.extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("toml")) =>
        {
            let account = Account::new(budget);
            let (mut scene, table) = octolux::scene::file::load_within(p, &account)?;
            scene.add_framing_camera();
            (scene, GiSettings::from_table(&table, p)?)
        }
        Some(p) => (Scene::load_within(p, budget)?, GiSettings::default()),
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
    if !scene.has_light() {
        eprintln!(
            "warning: scene '{}' has no lights, no emissive surfaces and no sky: the image \
             will be black (add a light, or light it with --sky)",
            scene.name
        );
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

/// Warns about what the scene file asks that this render does not follow (a Mitsuba
/// integrator's depth or sampler's sample count), naming what it does instead: `follows` says
/// who follows `transport` ("the reference follows"), `spp` is the render's sample count where
/// it has one.
pub fn warn_unfollowed_requests(
    scene: &Scene,
    follows: &str,
    transport: octolux::transport::Transport,
    spp: Option<u32>,
) {
    use octolux::scene::Asked;
    use octolux::transport::Bounces;
    for request in &scene.requests {
        let at = &request.at;
        match &request.asked {
            Asked::Bounces(asked, words) => {
                let same = *asked == Some(transport.bounces)
                    && transport.max_emissive_reflections() == transport.max_light_reflections();
                if same {
                    continue;
                }
                let asked = match asked {
                    Some(b) => b.to_string(),
                    None => "emitters seen only, which octolux does not render".into(),
                };
                let hint = match request.asked {
                    Asked::Bounces(Some(b), _) if follows.starts_with("the reference") => {
                        format!(" (--bounces {})", bounces_flag(b))
                    }
                    _ => String::new(),
                };
                eprintln!("warning: {at}: {words} asks for {asked}{hint}; {follows} {transport}");
            }
            Asked::Spp(n) => {
                if let Some(spp) = spp.filter(|spp| spp != n) {
                    eprintln!(
                        "warning: {at}: asks for {n} samples per pixel (--spp {n}); this \
                         render takes {spp}"
                    );
                }
            }
            Asked::Integrator(kind) => eprintln!(
                "warning: {at}: the '{kind}' integrator is not one octolux has; {follows} \
                 {transport}"
            ),
        }
    }

    fn bounces_flag(b: Bounces) -> String {
        match b {
            Bounces::DirectOnly => "direct".into(),
            Bounces::Indirect(n) => n.to_string(),
            Bounces::Unlimited => "unlimited".into(),
        }
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
