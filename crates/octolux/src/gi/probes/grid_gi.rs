//! `probes-grid`: probes at the cell centres of a uniform grid over the scene's bounds, with
//! surfels placed around each by rays, lit every frame, integrated into each probe's encoding
//! and interpolated per pixel (see the module documentation of [`super`] and docs/probes.md).

use super::encoding::COEFFS;
use super::engine::{
    facing_weight, moved_boxes, ProbeEngine, ProbeLayout, ProbeSetModules, PROBE_VEC4,
};
use super::lattice::direction;
use super::moments::MomentMaps;
use super::ProbeSettings;
use crate::gi::{GiFrame, GiTechnique};
use crate::gpu::{GpuContext, PassTimer};
use crate::{Error, Result};
use glam::{UVec3, Vec3};

const OWNER: &str = "probes-grid";

/// The probe grid's placement: the box it fills and the probe spacing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProbeGrid {
    /// Lower corner of the box.
    pub lo: Vec3,
    /// Distance between neighbouring probes per axis.
    pub spacing: Vec3,
    /// Probes per axis.
    pub dims: UVec3,
}

impl ProbeGrid {
    /// The grid of `dims` probes over `bounds`, one probe at the centre of each cell. Flat
    /// axes get a thickness of 1/1000 of the largest extent.
    pub fn over(bounds: (Vec3, Vec3), dims: [u32; 3]) -> Result<ProbeGrid> {
        let (lo, hi) = bounds;
        let extent = hi - lo;
        let largest = extent.max_element();
        if !(largest.is_finite() && largest > 0.0) {
            return Err(Error::InvalidArgument(format!(
                "probes need a scene with extent; its bounds are {lo} to {hi}"
            )));
        }
        let extent = extent.max(Vec3::splat(largest * 1e-3));
        let dims = UVec3::from(dims);
        Ok(ProbeGrid {
            lo,
            spacing: extent / dims.as_vec3(),
            dims,
        })
    }

    /// World position of the probe at grid coordinate `c`.
    pub fn position(&self, c: UVec3) -> Vec3 {
        self.lo + (c.as_vec3() + 0.5) * self.spacing
    }

    /// Probe count.
    pub fn count(&self) -> u32 {
        self.dims.x * self.dims.y * self.dims.z
    }
}

/// CPU twin of integrate.wgsl for one probe: its encoding's coefficients and (back-face
/// share, hit share, valid, 0) from its surfels' states (0 miss, 1 front, 2 back) and outgoing
/// radiance, in lattice order.
pub fn integrate_probe(
    settings: &ProbeSettings,
    states: &[f32],
    radiance: &[Vec3],
) -> ([Vec3; COEFFS], [f32; 4]) {
    let n = settings.surfel_count();
    let mut coeffs = [Vec3::ZERO; COEFFS];
    let (mut hits, mut back) = (0, 0);
    for k in 0..n {
        let state = states[k as usize];
        hits += (state > 0.5) as u32;
        back += (state > 1.5) as u32;
        let (dir, dw) = direction(settings.lattice, k, n);
        settings
            .encoding
            .add(&mut coeffs, radiance[k as usize], dir, dw);
    }
    let valid = if back <= settings.max_back_faces() {
        1.0
    } else {
        0.0
    };
    (
        coeffs,
        [back as f32 / n as f32, hits as f32 / n as f32, valid, 0.0],
    )
}

/// CPU twin of `probes_irradiance` in grid_sample.wgsl: irradiance at `p` (unit normal `n`)
/// from `probes` (the probe buffer's `vec4`s) on `grid`, each probe weighed by its visibility
/// from `moments` where given.
pub fn grid_irradiance(
    grid: &ProbeGrid,
    settings: &ProbeSettings,
    probes: &[[f32; 4]],
    moments: Option<MomentMaps>,
    p: Vec3,
    n: Vec3,
) -> Vec3 {
    let q = p + n * (settings.normal_bias * grid.spacing.min_element());
    let g = (q - grid.lo) / grid.spacing - 0.5;
    let hi = grid.dims.as_ivec3() - 2;
    let base = g.floor().as_ivec3().clamp(glam::IVec3::ZERO, hi);
    let t = (g - base.as_vec3()).clamp(Vec3::ZERO, Vec3::ONE);
    let (mut sum, mut total) = (Vec3::ZERO, 0.0);
    for c in 0..8u32 {
        let off = UVec3::new(c & 1, (c >> 1) & 1, (c >> 2) & 1);
        let coord = base.as_uvec3() + off;
        let probe = (coord.x + grid.dims.x * (coord.y + grid.dims.y * coord.z)) as usize;
        let b = probe * PROBE_VEC4 as usize;
        if probes[b + 8][2] < 0.5 {
            continue;
        }
        let tri = Vec3::select(off.cmpeq(UVec3::ONE), t, Vec3::ONE - t);
        let x = grid.position(coord);
        let vis = moments.map_or(1.0, |m| m.visibility(probe, x, q));
        let w = tri.x * tri.y * tri.z * facing_weight(x - p, n) * vis;
        let coeffs: [Vec3; COEFFS] = std::array::from_fn(|k| Vec3::from_slice(&probes[b + k]));
        sum += settings.encoding.irradiance(&coeffs, n) * w;
        total += w;
    }
    if total > 0.0 {
        sum / total
    } else {
        Vec3::ZERO
    }
}

/// Probe + surfel GI on a uniform grid.
pub struct ProbesGrid {
    grid: ProbeGrid,
    passes: ProbeEngine,
    placed: bool,
    /// Object transforms of the previous frame (None before the first).
    last_transforms: Option<Vec<glam::Mat4>>,
}

impl ProbesGrid {
    /// The technique for `scene` at `width` x `height`.
    pub fn new(
        ctx: &GpuContext,
        settings: &ProbeSettings,
        scene: &crate::scene::Scene,
        width: u32,
        height: u32,
    ) -> Result<ProbesGrid> {
        let settings = &settings.resolved(false);
        settings.validate()?;
        let grid = ProbeGrid::over(scene.gi_bounds_at(0.0), settings.grid)?;
        let layout = ProbeLayout {
            lo: grid.lo,
            spacing: grid.spacing,
            dims: grid.dims,
            bias: settings.normal_bias * grid.spacing.min_element(),
            cell: grid.spacing.min_element(),
            probes: grid.count(),
        };
        let set = ProbeSetModules {
            set: "gi/probes/grid",
            sample: "gi/probes/grid_sample",
            tree: None,
        };
        let passes = ProbeEngine::new(ctx, OWNER, settings, scene, (width, height), &layout, &set)?;
        Ok(ProbesGrid {
            grid,
            passes,
            placed: false,
            last_transforms: None,
        })
    }

    /// The indirect irradiance image (as [`GiTechnique::indirect_view`] views it).
    pub fn indirect_texture(&self) -> &wgpu::Texture {
        self.passes.texture()
    }

    /// The grid the probes sit on.
    pub fn grid(&self) -> &ProbeGrid {
        &self.grid
    }

    /// The settings in use.
    pub fn settings(&self) -> &ProbeSettings {
        &self.passes.settings
    }

    /// The probe buffer (per probe 8 coefficients, then back-face share, hit share, valid).
    pub fn probe_buffer(&self) -> &wgpu::Buffer {
        self.passes.probe_buffer()
    }

    /// The probes' depth moment maps (see [`super::moments`]).
    pub fn moment_buffer(&self) -> &wgpu::Buffer {
        self.passes.moment_buffer()
    }

    /// The variance floor of the visibility test (m^2).
    pub fn variance_floor(&self) -> f32 {
        super::moments::variance_floor(self.grid.spacing.min_element())
    }

    /// The surfel buffer (per surfel position + state, normal + albedo, emission + distance)
    /// and the surfels' outgoing radiance.
    pub fn surfel_buffers(&self) -> (&wgpu::Buffer, &wgpu::Buffer) {
        self.passes.surfel_buffers()
    }
}

impl GiTechnique for ProbesGrid {
    fn name(&self) -> &str {
        OWNER
    }

    fn update(&mut self, ctx: &GpuContext, frame: &GiFrame, timer: &mut PassTimer) -> Result<()> {
        let now = &frame.frame.object_transforms;
        let moved = match &self.last_transforms {
            Some(before) => moved_boxes(frame.scene, before, now),
            None => Vec::new(),
        };
        self.last_transforms = Some(now.clone());
        // Surfels are placed once, then again where an object moved: only the rays that cross
        // its old or new bounds.
        let place = !self.placed || !moved.is_empty();
        if place {
            self.passes
                .set_moved(ctx, self.placed.then_some(moved.as_slice()))?;
        }
        self.passes.begin_frame(ctx, frame, timer)?;
        // 1. Surfels: rays from every probe along its lattice (see above), and the probes'
        //    depth moments from them.
        if place {
            self.passes.place(ctx, timer, None);
            self.passes.build_moments(ctx, timer, None);
            self.placed = true;
        }
        // 2. Surfel light: direct light with shadow-map visibility (+ last frame's probes).
        self.passes.light(ctx, frame, timer, None)?;
        // 3. Probes: each integrates its surfels into its encoding.
        self.passes.integrate(ctx, timer, None);
        // 4. Pixels: interpolation between the 8 probes around each.
        self.passes.gather(ctx, frame, timer, None);
        Ok(())
    }

    fn indirect_view(&self) -> &wgpu::TextureView {
        self.passes.view()
    }

    fn reference_transport(&self) -> crate::transport::Transport {
        self.passes.reference_transport()
    }

    fn other_ledger_owners(&self) -> &[&'static str] {
        self.passes.other_ledger_owners()
    }

    fn as_any(&self) -> Option<&dyn std::any::Any> {
        Some(self)
    }
}
