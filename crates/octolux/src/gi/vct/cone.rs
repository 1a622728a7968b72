//! The cone marcher: `003`'s front-to-back compositing (eq. 3) of samples whose footprint
//! grows with the cone, with the step-length opacity correction `003` leaves out (without it
//! the result depends on the step size).
//!
//! A sample at distance `t` has footprint `max(2 t tan(aperture / 2), voxel)`; the sampler
//! picks the level from it (quadrilinear between levels), the step is `step x footprint`, and
//! the sample's opacity, defined over a path as long as its footprint, becomes
//! `1 - (1 - a)^(step / footprint)` for the step (its premultiplied radiance scaled alike).
//! The march starts at `start` (against self-occlusion by the surface's own voxels) and stops
//! at `max_distance`, at `stop_opacity` or after `max_steps`.

use super::{DiffuseCones, VctSettings};
use glam::{Vec3, Vec4};

/// How one cone is marched (the WGSL `ConeParams`, a storage block).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ConeParams {
    /// Full aperture in radians.
    pub aperture: f32,
    /// Distance of the first sample from the apex, in metres.
    pub start: f32,
    /// Step length as a fraction of the footprint at the current sample.
    pub step: f32,
    /// Distance at which the march ends, in metres.
    pub max_distance: f32,
    /// Finest voxel size in metres: the smallest footprint.
    pub voxel: f32,
    /// Accumulated opacity at which the march ends.
    pub stop_opacity: f32,
    /// Most samples per cone.
    pub max_steps: u32,
    /// The coarsest voxel size in metres: the largest footprint (a sample wider than the
    /// structure's coarsest voxel is not filtered further, and the step stays
    /// `step x max_footprint` so that a wall of such voxels is never stepped over). At least
    /// `voxel`.
    pub max_footprint: f32,
}

/// A cone to march: apex, unit direction and parameters.
#[derive(Clone, Copy, Debug)]
pub struct ConeMarch {
    /// Apex (metres).
    pub origin: Vec3,
    /// Unit direction.
    pub dir: Vec3,
    /// How to march it.
    pub params: ConeParams,
}

/// What one sample `s` (premultiplied rgb, opacity a) over `footprint` adds to `acc` for a
/// step of length `step` (CPU twin of `cone_composite`).
pub fn cone_composite(acc: Vec4, s: Vec4, step: f32, footprint: f32) -> Vec4 {
    let a = s.w.clamp(0.0, 1.0);
    let (corrected, scale) = if a > 0.0 && a < 1.0 {
        let c = 1.0 - (1.0 - a).powf(step / footprint);
        (c, c / a)
    } else {
        (a, 1.0)
    };
    let t = 1.0 - acc.w;
    (acc.truncate() + t * s.truncate() * scale).extend(acc.w + t * corrected)
}

/// Marches `cone` through `sample(p, footprint)` (CPU twin of the WGSL `march_cone`):
/// accumulated premultiplied radiance (xyz) and opacity (w). The WGSL sampler also gets the
/// cone's direction; it is constant along a cone, so a directional sampler here captures
/// `cone.dir` in the closure.
pub fn march_cone(sample: impl Fn(Vec3, f32) -> Vec4, cone: &ConeMarch) -> Vec4 {
    let c = &cone.params;
    let spread = 2.0 * (0.5 * c.aperture).tan();
    let mut acc = Vec4::ZERO;
    let mut t = c.start;
    for _ in 0..c.max_steps {
        if t >= c.max_distance || acc.w >= c.stop_opacity {
            break;
        }
        let footprint = (spread * t).max(c.voxel).min(c.max_footprint);
        let step = c.step * footprint;
        acc = cone_composite(
            acc,
            sample(cone.origin + t * cone.dir, footprint),
            step,
            footprint,
        );
        t += step;
    }
    acc
}

impl ConeParams {
    /// The marcher's parameters for the settings `s` and the `diffuse` cones, a finest voxel of
    /// `voxel` metres, a coarsest of `coarsest` metres and cones that end at `max_distance` metres.
    pub(crate) fn for_settings(
        s: &VctSettings,
        diffuse: DiffuseCones,
        voxel: f32,
        coarsest: f32,
        max_distance: f32,
    ) -> ConeParams {
        ConeParams {
            aperture: diffuse.aperture.to_radians(),
            start: diffuse.start * voxel,
            step: s.step,
            max_distance,
            voxel,
            stop_opacity: s.stop_opacity,
            max_steps: 1024,
            max_footprint: coarsest.max(voxel),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params() -> ConeParams {
        ConeParams {
            aperture: 0.5,
            start: 0.05,
            step: 0.5,
            max_distance: 4.0,
            voxel: 0.05,
            stop_opacity: 0.99,
            max_steps: 256,
            max_footprint: 1e30,
        }
    }

    fn cone() -> ConeMarch {
        ConeMarch {
            origin: Vec3::ZERO,
            dir: Vec3::X,
            params: params(),
        }
    }

    #[test]
    fn empty_space_gives_nothing() {
        assert_eq!(march_cone(|_, _| Vec4::ZERO, &cone()), Vec4::ZERO);
    }

    #[test]
    fn an_opaque_wall_stops_the_cone_with_its_radiance() {
        // Opaque radiance 2 from x = 1 on: the first sample past the wall takes it all.
        let wall = |p: Vec3, _| {
            if p.x >= 1.0 {
                Vec4::new(2.0, 1.0, 0.5, 1.0)
            } else {
                Vec4::ZERO
            }
        };
        let r = march_cone(wall, &cone());
        assert_eq!(r, Vec4::new(2.0, 1.0, 0.5, 1.0));
    }

    #[test]
    fn a_uniform_medium_attenuates_by_distance_whatever_the_step() {
        // Constant opacity a per footprint-long path in a constant-footprint cone (aperture
        // 0): after distance D the transmittance is (1 - a)^(D / footprint) for any step, and
        // premultiplied radiance L a per footprint gives emission L (1 - T) in total.
        let (a, l) = (0.2f32, 3.0f32);
        for step in [0.25f32, 0.5, 1.0] {
            let samples = std::cell::Cell::new(0u32);
            let medium = |_: Vec3, _| {
                samples.set(samples.get() + 1);
                Vec4::new(l * a, l * a, l * a, a)
            };
            let mut c = cone();
            c.params.aperture = 0.0;
            c.params.step = step;
            c.params.start = 0.0;
            c.params.max_distance = 1.0;
            c.params.stop_opacity = 2.0;
            let r = march_cone(medium, &c);
            // The march covers samples x step x footprint (about 1 m).
            let covered = samples.get() as f32 * step * 0.05;
            assert!((covered - 1.0).abs() <= step * 0.05 + 1e-4);
            let transmittance = (1.0 - a).powf(covered / 0.05);
            assert!(
                (r.w - (1.0 - transmittance)).abs() < 1e-4,
                "step {step}: {r}"
            );
            // Each step adds L x its corrected opacity: L (1 - T) in all.
            assert!(
                (r.x - l * (1.0 - transmittance)).abs() < 1e-3 * l,
                "step {step}: {r}"
            );
        }
    }

    #[test]
    fn the_footprint_grows_with_distance_and_never_falls_below_a_voxel() {
        let seen = std::cell::RefCell::new(Vec::new());
        let record = |p: Vec3, f: f32| {
            seen.borrow_mut().push((p.x, f));
            Vec4::ZERO
        };
        let c = cone();
        march_cone(record, &c);
        let seen = seen.into_inner();
        let spread = 2.0 * (0.25f32).tan();
        let mut t = c.params.start;
        for &(x, f) in &seen {
            assert!((x - t).abs() < 1e-5);
            assert!((f - (spread * t).max(0.05)).abs() < 1e-6);
            t += 0.5 * f;
        }
        assert!(t >= 4.0 && seen.len() > 5);
    }

    #[test]
    fn past_the_largest_footprint_the_samples_keep_its_size_and_step() {
        // A wall of coarse voxels (0.2 m) must not be stepped over: past max_footprint the
        // samples stay 0.2 m wide and 0.1 m apart.
        let seen = std::cell::RefCell::new(Vec::new());
        let record = |p: Vec3, f: f32| {
            seen.borrow_mut().push((p.x, f));
            Vec4::ZERO
        };
        let mut c = cone();
        c.params.max_footprint = 0.2;
        march_cone(record, &c);
        let seen = seen.into_inner();
        let spread = 2.0 * (0.25f32).tan();
        assert!(seen.iter().all(|&(_, f)| f <= 0.2));
        let wide: Vec<_> = seen.iter().filter(|&&(x, _)| spread * x >= 0.2).collect();
        assert!(
            wide.len() > 20,
            "{} samples past the largest footprint",
            wide.len()
        );
        for pair in wide.windows(2) {
            assert!((pair[1].0 - pair[0].0 - 0.1).abs() < 1e-5);
        }
    }
}
