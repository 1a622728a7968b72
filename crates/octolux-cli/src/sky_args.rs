//! Command-line sky: light any scene or model with a constant sky or an environment map
//! without writing a scene file (shared by `render`, `bench` and `view`).

use anyhow::{bail, Context, Result};
use clap::Args;
use glam::{Mat3, Vec3};
use octolux::scene::{EnvironmentMap, Scene, Sky};
use std::path::Path;

/// Sky flags; they replace the scene's own sky.
#[derive(Args, Debug, Clone, Default)]
pub struct SkyArgs {
    /// Sky light: a constant radiance `R,G,B` (W/(m^2 sr)) or an equirectangular `.hdr` or
    /// `.exr` map; replaces the scene's sky.
    #[arg(long, value_name = "R,G,B|FILE")]
    pub sky: Option<String>,
    /// Scale of the sky's radiance (with --sky, or the scene's own sky).
    #[arg(long, value_name = "X")]
    pub sky_intensity: Option<f32>,
    /// Turns the sky about the vertical axis, in degrees.
    #[arg(long, value_name = "DEGREES")]
    pub sky_rotate: Option<f32>,
}

impl SkyArgs {
    /// Applies the flags to `scene`.
    pub fn apply(&self, scene: &mut Scene) -> Result<()> {
        if let Some(value) = &self.sky {
            scene.sky = Some(parse_sky(value)?);
        }
        if self.sky_intensity.is_none() && self.sky_rotate.is_none() {
            return Ok(());
        }
        let Some(sky) = scene.sky.as_mut() else {
            bail!("--sky-intensity and --sky-rotate need a sky: give --sky or a scene with one");
        };
        if let Some(i) = self.sky_intensity {
            if !(i.is_finite() && i >= 0.0) {
                bail!("--sky-intensity {i}: must be a finite number >= 0");
            }
            sky.intensity = i;
        }
        if let Some(degrees) = self.sky_rotate {
            if !degrees.is_finite() {
                bail!("--sky-rotate {degrees}: must be a finite number of degrees");
            }
            sky.to_world = Mat3::from_rotation_y(degrees.to_radians()) * sky.to_world;
        }
        Ok(())
    }
}

/// `R,G,B` or a map file.
fn parse_sky(value: &str) -> Result<Sky> {
    let parts: Vec<&str> = value.split(',').map(str::trim).collect();
    if parts.len() == 3 {
        if let Ok(rgb) = parts
            .iter()
            .map(|p| p.parse::<f32>())
            .collect::<std::result::Result<Vec<f32>, _>>()
        {
            let c = Vec3::new(rgb[0], rgb[1], rgb[2]);
            if !c.is_finite() || c.min_element() < 0.0 {
                bail!("--sky {value}: a colour must be three finite numbers >= 0");
            }
            return Ok(Sky::constant(c));
        }
    }
    let path = Path::new(value);
    let map = EnvironmentMap::load(path)
        .with_context(|| format!("--sky {value}: expected R,G,B or an .hdr or .exr map"))?;
    Ok(Sky::map(map))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colours_maps_and_errors() {
        let mut scene = Scene::default();
        let args = SkyArgs {
            sky: Some("0.5, 1, 2".into()),
            sky_intensity: Some(2.0),
            sky_rotate: Some(90.0),
        };
        args.apply(&mut scene).unwrap();
        let sky = scene.sky.as_ref().unwrap();
        assert_eq!(sky.radiance(Vec3::Y), Vec3::new(1.0, 2.0, 4.0));
        assert!((sky.to_world * Vec3::X - Vec3::NEG_Z).length() < 1e-6);
        for bad in ["1,2", "-1,0,0", "nan,0,0", "nowhere.hdr"] {
            let args = SkyArgs {
                sky: Some(bad.into()),
                ..SkyArgs::default()
            };
            let e = format!("{:#}", args.apply(&mut Scene::default()).unwrap_err());
            assert!(e.contains(bad), "{bad}: {e}");
        }
        let orphan = SkyArgs {
            sky_intensity: Some(1.0),
            ..SkyArgs::default()
        };
        assert!(orphan.apply(&mut Scene::default()).is_err());
    }
}
