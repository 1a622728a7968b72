//! `probes-grid`: probes at the cell centres of a uniform grid over the scene's bounds, with
//! surfels placed around each by rays, lit every frame, integrated into each probe's encoding
//! and interpolated per pixel (see the module documentation of [`super`] and docs/probes.md).

use super::encoding::COEFFS;
use super::engine::{facing_weight, ProbeEngine, ProbeLayout, ProbeSetModules, PROBE_VEC4};
use super::history::{Changes, FrameChanges, RayPlan};
use super::lattice::direction;
use super::moments::MomentMaps;
use super::ProbeSettings;
use crate::gi::{GiFrame, GiTechnique};
use crate::gpu::{GpuContext, PassTimer};
use crate::{Error, Result};
use glam::{Mat3, UVec3, Vec3};

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

/// One surfel set of a probe as integrate.wgsl reads it: the surfels' states (0 miss,
/// 1 front, 2 back) and outgoing radiance in lattice order, and the rotation the set's
/// lattice was turned by.
#[derive(Clone, Copy)]
pub struct SurfelSet<'a> {
    pub states: &'a [f32],
    pub radiance: &'a [Vec3],
    pub rotation: Mat3,
}

/// A set's coefficients and its back-face and total hits.
fn integrate_set(settings: &ProbeSettings, set: SurfelSet) -> ([Vec3; COEFFS], u32, u32) {
    let n = settings.surfel_count();
    let mut coeffs = [Vec3::ZERO; COEFFS];
    let (mut hits, mut back) = (0, 0);
    for k in 0..n {
        let state = set.states[k as usize];
        hits += (state > 0.5) as u32;
        back += (state > 1.5) as u32;
        let (d, dw) = direction(settings.lattice, k, n);
        // As probe_ray_dir: each row of the rotation dotted with the lattice direction.
        let r = set.rotation;
        let dir = Vec3::new(r.row(0).dot(d), r.row(1).dot(d), r.row(2).dot(d));
        settings
            .encoding
            .add(&mut coeffs, set.radiance[k as usize], dir, dw);
    }
    (coeffs, back, hits)
}

/// What a probe with a history holds between frames (integrate.wgsl with two surfel sets):
/// its value (the mean over its samples, relit), its state (back-face share, hit share,
/// valid, frames in the history) and the latest set's coefficients as last integrated.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ProbeHistory {
    pub coeffs: [Vec3; COEFFS],
    pub state: [f32; 4],
    pub raw: [Vec3; COEFFS],
}

/// Sum of the absolute values of every coefficient's channels (`level` in integrate.wgsl).
fn level(c: &[Vec3; COEFFS]) -> f32 {
    c.iter().map(|v| v.abs().element_sum()).sum()
}

/// How strongly a probe's history forgets in a frame where a light or an object changed: the
/// frames it keeps shrink by this times its change over its level (a change of a quarter or
/// more starts it afresh). The relit history carries the change at once, but seen through
/// one lattice, whose noise on the change a long history would keep for many frames (the
/// lag after a light or an object jumps); forgetting harder lets the new samples average it
/// away. In frames where nothing changed, the probes' change is the bounces converging and
/// their own noise fed back, which nothing needs forgotten (forgetting it there would feed
/// the noise back again).
pub const FORGETTING: f32 = 4.0;

/// CPU twin of integrate.wgsl with two surfel sets, for one probe: `before` is the set
/// placed before (integrated again in this frame's light: the history is relit by what
/// changed since `history.raw` and forgets `forgetting` times in proportion: [`FORGETTING`]
/// in a frame where a light or an object changed, else 0), `new` the set placed this frame
/// (`None`: no new sample; the history is only relit), with at most `settings.history`
/// frames kept; a full history whose light did not change keeps its value.
pub fn integrate_probe_history(
    settings: &ProbeSettings,
    history: &ProbeHistory,
    before: SurfelSet,
    new: Option<SurfelSet>,
    forgetting: f32,
) -> ProbeHistory {
    let n = settings.surfel_count() as f32;
    let (relit, _, _) = integrate_set(settings, before);
    let mut coeffs = history.coeffs;
    let mut change = 0.0;
    for k in 0..COEFFS {
        let delta = relit[k] - history.raw[k];
        coeffs[k] += delta;
        change += delta.abs().element_sum();
    }
    let scale = level(&history.raw).max(level(&relit)).max(1e-30);
    let mut frames = history.state[3] * (1.0 - forgetting * change / scale).max(0.0);
    let [mut back, mut hits, _, _] = history.state;
    let mut latest = relit;
    let settled = frames >= settings.history as f32 && change == 0.0;
    if let (Some(new), true) = (new, settled) {
        latest = integrate_set(settings, new).0;
    } else if let Some(new) = new {
        let (c, b, h) = integrate_set(settings, new);
        let keep = frames / (frames + 1.0);
        for k in 0..COEFFS {
            coeffs[k] = c[k] + (coeffs[k] - c[k]) * keep;
        }
        back = b as f32 / n + (back - b as f32 / n) * keep;
        hits = h as f32 / n + (hits - h as f32 / n) * keep;
        frames = (frames + 1.0).min(settings.history as f32);
        latest = c;
    }
    let valid = back * n <= settings.max_back_faces() as f32 + 0.5;
    ProbeHistory {
        coeffs,
        state: [back, hits, if valid { 1.0 } else { 0.0 }, frames],
        raw: latest,
    }
}

/// CPU twin of integrate.wgsl for one probe without a history (one fixed lattice): its
/// encoding's coefficients and (back-face share, hit share, valid, 0) from its surfels'
/// states (0 miss, 1 front, 2 back) and outgoing radiance, in lattice order.
pub fn integrate_probe(
    settings: &ProbeSettings,
    states: &[f32],
    radiance: &[Vec3],
) -> ([Vec3; COEFFS], [f32; 4]) {
    let n = settings.surfel_count();
    let (coeffs, back, hits) = integrate_set(
        settings,
        SurfelSet {
            states,
            radiance,
            rotation: Mat3::IDENTITY,
        },
    );
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
    /// What changed from frame to frame.
    changes: FrameChanges,
    /// The rays of each frame (with a history).
    rays: RayPlan,
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
        let settings = &settings.for_technique(false)?;
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
            sample_work: super::engine::GRID_SAMPLE_WORK,
        };
        let passes = ProbeEngine::new(ctx, OWNER, settings, scene, (width, height), &layout, &set)?;
        Ok(ProbesGrid {
            grid,
            passes,
            placed: false,
            changes: FrameChanges::default(),
            rays: RayPlan::default(),
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
    /// and the surfels' outgoing radiance. With a history each probe holds two sets of
    /// `surfel_count` surfels, set 0 first.
    pub fn surfel_buffers(&self) -> (&wgpu::Buffer, &wgpu::Buffer) {
        self.passes.surfel_buffers()
    }

    /// With a history: per probe, the latest set's 8 coefficients as last integrated.
    pub fn sample_buffer(&self) -> &wgpu::Buffer {
        self.passes.sample_buffer()
    }

    /// The rays of the last frame: the surfel set placed most recently, whether the last
    /// frame placed it (a new sample), and each set's lattice rotation.
    pub fn frame_rays(&self) -> (u32, bool, [Mat3; 2]) {
        (self.rays.latest, self.rays.sampled, self.rays.rotations)
    }
}

impl GiTechnique for ProbesGrid {
    fn name(&self) -> &str {
        OWNER
    }

    fn update(&mut self, ctx: &GpuContext, frame: &GiFrame, timer: &mut PassTimer) -> Result<()> {
        let extent = self.grid.spacing * self.grid.dims.as_vec3();
        let Changes {
            moved,
            changed,
            bounce_scale,
        } = self.changes.observe(frame, extent);
        self.passes.set_bounce_scale(bounce_scale);
        self.passes
            .set_forgetting(if changed { FORGETTING } else { 0.0 });
        self.rays.plan(&mut self.passes, changed, !moved.is_empty());
        // Surfels are placed once, then again where an object moved: only the rays that cross
        // its old or new bounds. With a history, a new set along the turned lattice every
        // frame until the light has been still for `history` frames.
        let place = !self.placed || !moved.is_empty() || self.rays.sampled;
        if place {
            let selective = self.placed && !moved.is_empty();
            self.passes
                .set_moved(ctx, selective.then_some(moved.as_slice()))?;
        }
        self.passes.begin_frame(ctx, frame, timer)?;
        // 1. Surfels: rays from every probe along its lattice (see above), and the probes'
        //    depth moments from them.
        if place {
            self.passes.place(ctx, timer, None);
            let history = self.passes.settings.history > 0;
            if !history || self.rays.moments_due() {
                self.passes.build_moments(ctx, timer, None);
            }
            self.placed = true;
        }
        // 2. Surfel light: direct light with shadow-map visibility (+ last frame's probes).
        self.passes.light(ctx, frame, timer, None)?;
        // 3. Probes: each integrates its surfels into its encoding (with a history: relights
        //    it and blends the new sample in).
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

    fn settle_frames(&self) -> u32 {
        // Every probe's history full; the next frame stops tracing.
        self.passes.settings.history
    }
}
