//! Light Propagation Volumes (001 Elvek 2012, 000 Olovsson & Doggett 2013): `lpv` (one uniform
//! volume fitted to the scene), `clpv` (nested cascades around the camera) and `olpv` (a full
//! octree of volumes with an index volume, merged into one).
//!
//! A frame, pass by pass (each a named, timed pass):
//! 1. `rsm`: reflective shadow maps, one per shadow layer (6 per point light) ([`rsm`]).
//! 2. `inject`: RSM blocks become VPLs, injected as Lambertian SH lobes; RSM texels and
//!    G-buffer pixels become surfels of the geometry volume, max-combined ([`inject`]).
//! 3. `olpv` only: `downsample` (eq. 2) and `index` (index volume levels) ([`octree`]).
//! 4. `propagate`: k gather steps per grid, ping-pong, accumulated ([`propagate`]).
//! 5. `olpv` only: `merge` (eq. 1) into one n^3 volume.
//! 6. `lookup`: trilinear SH sample per pixel -> indirect irradiance ([`lookup`]).
//!
//! Units: cells hold SH of radiant intensity (W/sr); a surface in a cell of side s receives
//! radiance I/s^2, so the lookup returns irradiance in W/m^2 (see `docs/lpv.md`).

pub mod cascades;
pub mod inject;
pub mod inject_cpu;
pub mod kernels;
pub mod lookup;
pub mod octree;
pub mod propagate;
pub mod sh;

use super::{GiFrame, GiTechnique};
use crate::frame::rsm;
use crate::gi::bounds::{require as check, Bounds};
use crate::gpu::alloc::{param_slots, storage};
use crate::gpu::pass::{bind, groups, slot, SLOT};
use crate::gpu::{GpuContext, PassTimer};
use crate::{Error, Result};
use bytemuck::{Pod, Zeroable};
use glam::Vec3;

/// Settings of the uniform LPV, also used for the RSM, injection, occlusion, damping and gain of
/// `clpv` and `olpv`. Scene files: `[settings.lpv]`.
#[derive(Clone, Debug, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LpvSettings {
    /// Cells per side of the volume (default 32).
    pub size: u32,
    /// Propagation iterations (default 32). LPV light diffuses, so it needs at least as many
    /// iterations as cells to cross the volume; keep it about equal to `size` (docs/lpv.md).
    pub iterations: u32,
    /// RSM side in texels (default 512).
    pub rsm_size: u32,
    /// RSM texels per VPL side: one VPL per `rsm_stride`^2 block (default 4, as in 000).
    pub rsm_stride: u32,
    /// The RSM layers whose content moved since the last frame (their light, or an object
    /// they see) at half `rsm_size`, read with half `rsm_stride`: the same VPLs from a quarter
    /// of the texels, in the frames where the layer must be drawn anew anyway; a layer whose
    /// content holds still keeps the whole side, drawn once (default true; needs an even
    /// `rsm_stride`; docs/lpv.md, "The RSM's side").
    pub rsm_moving_half: bool,
    /// Damping of leaks at lookup (001 §3.3.1), 0 = off (default 0).
    pub damping: f32,
    /// Share 0..=1 of the flux crossing a cell face that propagation re-emits as a beam along
    /// the direction it crossed the face; the rest becomes a Lambertian lobe about the face
    /// normal (001). 0 diffuses light (lit planes light themselves, the far field fades), 1
    /// keeps its direction (default 1, measured over every shipped scene: docs/lpv.md).
    pub directional: f32,
    /// Scale of the indirect irradiance (default 1: physical units, no fudge factor).
    pub gain: f32,
    /// Occlusion of propagation by the geometry volume (default true).
    pub occlusion: bool,
    /// Sky lights that get an RSM (default 8): an evenly spread subset of the renderer's sky
    /// lights, scaled to carry the whole sky's light (each RSM costs `rsm_size`^2 texels).
    pub sky_rsms: u32,
    /// The box `[[x0, y0, z0], [x1, y1, z1]]` (m) the volume covers instead of the scene's
    /// bounds (default: none, fitted to the scene each frame). For `clpv` it replaces the scene
    /// bounds that place the cascades and size the finest one. Useful when a large ground plane
    /// or sky dome would spread the cells over space nothing interesting happens in.
    pub bounds: Option<[[f32; 3]; 2]>,
}

impl Default for LpvSettings {
    fn default() -> Self {
        LpvSettings {
            size: 32,
            iterations: 32,
            rsm_size: 512,
            rsm_stride: 4,
            rsm_moving_half: true,
            damping: 0.0,
            directional: 1.0,
            gain: 1.0,
            occlusion: true,
            sky_rsms: 8,
            bounds: None,
        }
    }
}

/// Settings of the cascaded LPV. Scene files: `[settings.clpv]`.
#[derive(Clone, Debug, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ClpvSettings {
    /// Number of nested cascades, 1..=8 (default 3).
    pub cascades: u32,
    /// Cells per side of every cascade (default 32).
    pub size: u32,
    /// Propagation iterations per cascade (default 32: the lookup reads the finest cascade
    /// almost everywhere in the scene, and its light must cross it too).
    pub iterations: u32,
    /// Side of the finest cascade in metres; each coarser one is twice as wide; 0 = 1.25 x the
    /// largest scene extent (default 0).
    pub extent: f32,
}

impl Default for ClpvSettings {
    fn default() -> Self {
        ClpvSettings {
            cascades: 3,
            size: 32,
            iterations: 32,
            extent: 0.0,
        }
    }
}

/// Settings of the octree LPV. Scene files: `[settings.olpv]`.
#[derive(Clone, Debug, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct OlpvSettings {
    /// Side n of level 0, a power of two >= 2 (default 32); l = log2(n) + 1 levels.
    pub size: u32,
    /// Propagation iterations on every level (default 16: light keeps its direction and moves
    /// one cell per step, so level 0, which serves the pixels near geometry, must carry it
    /// across half the volume; 8 left the Cornell box's ceiling dark, docs/lpv.md).
    pub iterations: u32,
}

impl Default for OlpvSettings {
    fn default() -> Self {
        OlpvSettings {
            size: 32,
            iterations: 16,
        }
    }
}

/// Which member of the family.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Variant {
    /// One volume fitted to the scene bounds.
    Uniform,
    /// Nested cascades around the camera.
    Cascaded,
    /// Full octree of volumes, merged.
    Octree,
}

impl Variant {
    /// Command-line name.
    pub fn name(self) -> &'static str {
        match self {
            Variant::Uniform => "lpv",
            Variant::Cascaded => "clpv",
            Variant::Octree => "olpv",
        }
    }
}

/// Most grids (cascades or octree levels) one technique uses.
pub const MAX_GRIDS: usize = 8;

/// `Grid` of `sh.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GpuGrid {
    /// World position of the minimum corner.
    pub origin: [f32; 3],
    /// Cell side (m).
    pub cell: f32,
    /// Cells per side.
    pub n: u32,
    /// First cell in the light buffers.
    pub offset: u32,
    /// First cell of the geometry volume.
    pub gv_offset: u32,
    /// Bit 0: occlusion, bit 1: receives injected light; bits 8..16: the surfel stride
    /// ([`GpuGrid::surfel_stride`]).
    pub flags: u32,
}

/// Flag: propagation is occluded by the geometry volume.
pub const FLAG_OCCLUSION: u32 = 1;
/// Flag: the grid receives injected VPLs.
pub const FLAG_INJECT: u32 = 2;
/// First bit of the surfel stride in [`GpuGrid::flags`].
const SURFEL_STRIDE_SHIFT: u32 = 8;

impl GpuGrid {
    /// The grid takes one geometry surfel per `stride` x `stride` block of RSM texels or camera
    /// samples, with the block's area (`inject_surfel` in `inject.wgsl`): its cell over the
    /// finest grid's, rounded once here so the GPU and the CPU twin use the same (0 reads as
    /// 1).
    pub fn surfel_stride(&self) -> u32 {
        ((self.flags >> SURFEL_STRIDE_SHIFT) & 0xff).max(1)
    }

    /// Sets the surfel stride for a finest cell of `finest` metres.
    fn set_surfel_stride(&mut self, finest: f32) {
        let stride = (self.cell / finest).round().clamp(1.0, 255.0) as u32;
        self.flags = (self.flags & 0xff) | stride << SURFEL_STRIDE_SHIFT;
    }
}

/// `Grids` of `sh.wgsl`: every grid of a technique and the settings of injection and lookup.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuGrids {
    /// Number of grids in use.
    pub count: u32,
    /// Cells of all geometry volumes together.
    pub gv_total: u32,
    /// RSM texels per VPL side.
    pub stride: u32,
    /// G-buffer pixels per camera surfel side ([`inject::camera_stride`]).
    pub camera_stride: u32,
    /// Scale of the indirect irradiance.
    pub gain: f32,
    /// Damping at lookup.
    pub damping: f32,
    /// Cascade blend width in cells.
    pub blend: f32,
    /// Fixed-point scale of the injected light sums ([`inject::light_scale`]).
    pub light_scale: f32,
    /// Bit i (word i / 32, bit i % 32): RSM layer i is drawn at half the side, read with half
    /// the stride ([`LpvSettings::rsm_moving_half`]; [`half_layer_mask`]).
    pub half_layers: [u32; 8],
    /// The grids, `count` of them in use.
    pub grids: [GpuGrid; MAX_GRIDS],
}

/// A grid's shape without its placement: side and buffer offsets.
#[derive(Clone, Copy, Debug)]
pub struct Layout {
    /// Cells per side.
    pub n: u32,
    /// First cell in the light buffers.
    pub offset: u32,
    /// First cell of its geometry volume.
    pub gv_offset: u32,
    /// `FLAG_*` bits.
    pub flags: u32,
}

/// Cells in all grids and in all geometry volumes, for a list of sides.
pub(crate) fn layouts(sides: &[u32], flags: impl Fn(usize) -> u32) -> (Vec<Layout>, u32, u32) {
    let (mut cells, mut gv) = (0u32, 0u32);
    let mut out = Vec::with_capacity(sides.len());
    for (i, &n) in sides.iter().enumerate() {
        out.push(Layout {
            n,
            offset: cells,
            gv_offset: gv,
            flags: flags(i),
        });
        cells += n * n * n;
        gv += (n + 1) * (n + 1) * (n + 1);
    }
    (out, cells, gv)
}

/// Bytes of one cell (3 channels x 4 coefficients x f32).
pub const CELL_BYTES: u64 = 48;

/// The LPV family technique.
pub struct LpvGi {
    variant: Variant,
    settings: LpvSettings,
    clpv: ClpvSettings,
    layouts: Vec<Layout>,
    gv_total: u32,
    iterations: u32,
    grids: wgpu::Buffer,
    grid_slots: wgpu::Buffer,
    lookup_grids: wgpu::Buffer,
    volumes: propagate::Volumes,
    rsm: rsm::RsmTargets,
    octree: Option<octree::OctreeBuffers>,
    output: lookup::Output,
    /// Pipelines and bind groups, built on the first frame (they bind the G-buffer and the
    /// scene's raster layouts, which the renderer hands over per frame).
    passes: Option<Passes>,
    /// The grids of the last frame.
    last_grids: Option<GpuGrids>,
    /// What each RSM layer showed in the last frame, to draw those that moved at half the side.
    moving: rsm::MovingLayers,
    /// Bounds to fit the volumes to where far outliers make the scene's own bounds useless
    /// (`Scene::gi_bounds_over_animation`); None: the scene's bounds of the frame.
    trimmed_bounds: Option<(Vec3, Vec3)>,
}

struct Passes {
    rsm: rsm::RsmPass,
    inject: inject::Inject,
    propagate: propagate::Propagate,
    octree: Option<octree::LpvOctree>,
    lookup: lookup::Lookup,
}

impl LpvGi {
    /// Creates the technique and all its GPU memory for `scene` and images of `width` x
    /// `height`.
    pub fn new(
        ctx: &GpuContext,
        variant: Variant,
        settings: &super::GiSettings,
        scene: &crate::scene::Scene,
        width: u32,
        height: u32,
    ) -> Result<LpvGi> {
        let owner = variant.name();
        validate(variant, settings)?;
        let s = settings.lpv.clone();
        let occlusion = if s.occlusion { FLAG_OCCLUSION } else { 0 };
        let (sides, iterations, inject_level0_only) = match variant {
            Variant::Uniform => (vec![s.size], s.iterations, false),
            Variant::Cascaded => {
                let c = &settings.clpv;
                (vec![c.size; c.cascades as usize], c.iterations, false)
            }
            Variant::Octree => {
                let o = &settings.olpv;
                let l = o.size.trailing_zeros() + 1;
                ((0..l).map(|i| o.size >> i).collect(), o.iterations, true)
            }
        };
        let (layouts, cells, gv_total) = layouts(&sides, |i| {
            occlusion
                | if inject_level0_only && i > 0 {
                    0
                } else {
                    FLAG_INJECT
                }
        });
        let limits = ctx.device.limits();
        // The largest buffers: a light volume (48 bytes per cell; the fixed-point sums' low and
        // high words are two buffers of that size) and one word of the geometry sums of both
        // sources (2 x 16 bytes per geometry cell).
        let largest = (cells as u64 * CELL_BYTES).max(gv_total as u64 * 32);
        if largest > limits.max_storage_buffer_binding_size || largest > limits.max_buffer_size {
            return Err(Error::InvalidArgument(format!(
                "{owner}: the volumes need a {} MiB buffer, more than the adapter allows \
                 ({} MiB); use fewer or smaller grids",
                largest >> 20,
                limits
                    .max_storage_buffer_binding_size
                    .min(limits.max_buffer_size)
                    >> 20
            )));
        }
        let layer_count = rsm::rsm_layer_count(
            &scene.lights,
            crate::frame::sky_light_count(scene),
            s.sky_rsms,
        );
        Ok(LpvGi {
            variant,
            clpv: settings.clpv.clone(),
            gv_total,
            iterations,
            grids: param_slots(ctx, owner, "grids", 2),
            grid_slots: param_slots(ctx, owner, "grid slots", sides.len() as u64),
            lookup_grids: param_slots(ctx, owner, "lookup grids", 2),
            volumes: propagate::Volumes::new(ctx, owner, cells, gv_total),
            rsm: rsm::RsmTargets::new(ctx, owner, layer_count, s.rsm_size),
            octree: (variant == Variant::Octree)
                .then(|| octree::OctreeBuffers::new(ctx, owner, settings.olpv.size, cells)),
            output: lookup::Output::new(ctx, owner, width, height),
            passes: None,
            last_grids: None,
            moving: rsm::MovingLayers::default(),
            trimmed_bounds: (scene.gi_bounds_at(0.0) != scene.bounds_at(0.0))
                .then(|| scene.gi_bounds_over_animation()),
            layouts,
            settings: s,
        })
    }

    /// The grids of this frame, placed in the world.
    fn place(&self, frame: &GiFrame) -> Vec<GpuGrid> {
        let bounds = match self.settings.bounds {
            Some([lo, hi]) => (Vec3::from(lo), Vec3::from(hi)),
            None => self
                .trimmed_bounds
                .unwrap_or_else(|| frame.scene.bounds_at(frame.instant.time)),
        };
        let placements: Vec<(Vec3, f32)> = match self.variant {
            Variant::Uniform | Variant::Octree => {
                let (origin, cell) = cascades::fit(bounds, self.layouts[0].n);
                (0..self.layouts.len())
                    .map(|i| (origin, cell * (1u32 << i) as f32))
                    .collect()
            }
            Variant::Cascaded => cascades::place(
                bounds,
                frame.view,
                self.layouts.len(),
                self.layouts[0].n,
                self.clpv.extent,
            ),
        };
        self.layouts
            .iter()
            .zip(placements)
            .map(|(l, (origin, cell))| GpuGrid {
                origin: origin.to_array(),
                cell,
                n: l.n,
                offset: l.offset,
                gv_offset: l.gv_offset,
                flags: l.flags,
            })
            .collect()
    }

    fn gpu_grids(&self, grids: &[GpuGrid], light_scale: f32) -> GpuGrids {
        let mut g = GpuGrids {
            count: grids.len() as u32,
            gv_total: self.gv_total,
            stride: self.settings.rsm_stride,
            camera_stride: inject::camera_stride(
                self.output.texture.width(),
                self.output.texture.height(),
            ),
            gain: self.settings.gain,
            damping: self.settings.damping,
            blend: 2.0,
            light_scale,
            half_layers: [0; 8],
            grids: [GpuGrid::default(); MAX_GRIDS],
        };
        let finest = grids.iter().map(|g| g.cell).fold(f32::INFINITY, f32::min);
        for (dst, src) in g.grids.iter_mut().zip(grids) {
            *dst = *src;
            dst.set_surfel_stride(finest);
        }
        g
    }

    /// `layers` with those whose content moved since the last frame at half the side
    /// ([`rsm::MovingLayers`]), with `rsm_moving_half`, an even stride and at most
    /// [`MAX_HALF_LAYERS`] layers (the mask's bits).
    fn halve_moving_layers(
        &mut self,
        frame: &GiFrame,
        layers: Vec<rsm::RsmLayer>,
    ) -> Vec<rsm::RsmLayer> {
        let s = &self.settings;
        let enabled = s.rsm_moving_half
            && s.rsm_stride.is_multiple_of(2)
            && self.rsm.size.is_multiple_of(2)
            && self.rsm.layers <= MAX_HALF_LAYERS;
        self.moving
            .halve(frame.scene_gpu, layers, self.rsm.size, enabled)
    }

    /// Reads the accumulation buffer of the last frame, all grids one after another (with 0
    /// iterations it holds exactly the injected light).
    pub fn read_accumulated(&self, ctx: &GpuContext) -> Result<Vec<sh::Cell>> {
        kernels::read_cells(ctx, &self.volumes.acc, 0, self.volumes.cells)
    }

    /// The grids and injection settings of the last frame (None before the first).
    pub fn last_grids(&self) -> Option<&GpuGrids> {
        self.last_grids.as_ref()
    }

    /// Reads the combined geometry volumes of the last frame (4 SH coefficients per cell, all
    /// grids one after another).
    pub fn read_geometry(&self, ctx: &GpuContext) -> Result<Vec<sh::Sh>> {
        let bytes = crate::gpu::read_buffer(ctx, &self.volumes.gv, 0, self.gv_total as u64 * 16)?;
        Ok(bytes
            .chunks_exact(16)
            .map(|c| {
                std::array::from_fn(|k| {
                    f32::from_le_bytes([c[4 * k], c[4 * k + 1], c[4 * k + 2], c[4 * k + 3]])
                })
            })
            .collect())
    }

    /// Reads the reflective shadow maps of the last frame, one image per layer.
    pub fn read_rsm(&self, ctx: &GpuContext) -> Result<Vec<rsm::RsmImage>> {
        (0..self.rsm.layers)
            .map(|layer| rsm::RsmImage::read(ctx, &self.rsm, layer))
            .collect()
    }

    /// The indirect-irradiance texture (`Rgba16Float`).
    pub fn indirect_texture(&self) -> &wgpu::Texture {
        &self.output.texture
    }

    /// The placed grids of the last frame's layout (side, offsets), in buffer order.
    pub fn layouts(&self) -> &[Layout] {
        &self.layouts
    }

    fn build(&self, ctx: &GpuContext, frame: &GiFrame) -> Result<Passes> {
        let octree = self
            .octree
            .as_ref()
            .map(|b| octree::LpvOctree::new(ctx, b, &self.volumes));
        let (volume, lookup_grids) = match &self.octree {
            Some(o) => (&o.merged, &self.lookup_grids),
            None => (&self.volumes.acc, &self.grids),
        };
        let inject_pass = format!("{} inject", self.variant.name());
        Ok(Passes {
            rsm: rsm::RsmPass::new(ctx, frame.scene_gpu, &self.rsm),
            inject: inject::Inject::new(
                ctx,
                &inject_pass,
                &self.grids,
                &self.rsm,
                &self.volumes,
                frame,
            )?,
            propagate: propagate::Propagate::new(ctx, &self.grid_slots, &self.volumes),
            octree,
            lookup: lookup::Lookup::new(ctx, lookup_grids, volume, &self.output, frame),
        })
    }
}

/// Accepted cells per side of the uniform LPV.
pub const LPV_SIZE: Bounds<u32> = Bounds::new("lpv size", 2, 128);
/// Accepted propagation iterations of the uniform LPV.
pub const LPV_ITERATIONS: Bounds<u32> = Bounds::new("lpv iterations", 0, 256);
/// Accepted cascade counts of the cascaded LPV.
pub const CLPV_CASCADES: Bounds<u32> = Bounds::new("clpv cascades", 1, MAX_GRIDS as u32);
/// Accepted cells per side of each cascade.
pub const CLPV_SIZE: Bounds<u32> = Bounds::new("clpv size", 2, 128);
/// Accepted propagation iterations per cascade.
pub const CLPV_ITERATIONS: Bounds<u32> = Bounds::new("clpv iterations", 0, 256);
/// Accepted level-0 sides of the octree LPV (powers of two within).
pub const OLPV_SIZE: Bounds<u32> = Bounds::new("olpv size", 2, 128);
/// Accepted propagation iterations per level of the octree LPV.
pub const OLPV_ITERATIONS: Bounds<u32> = Bounds::new("olpv iterations", 0, 256);
/// Accepted share of the directional transfer.
pub const DIRECTIONAL: Bounds<f32> = Bounds::new("lpv directional", 0.0, 1.0);

/// Checks the settings of the LPV `variant` (before any GPU work, so that a tool can check
/// every technique's settings before it runs the first).
pub fn validate(variant: Variant, settings: &super::GiSettings) -> Result<()> {
    let s = &settings.lpv;
    check(
        s.rsm_size >= 4 && s.rsm_size <= 4096,
        "lpv rsm_size",
        "4..=4096",
    )?;
    check(
        s.rsm_stride >= 1 && s.rsm_stride <= 16,
        "lpv rsm_stride",
        "1..=16",
    )?;
    check(
        s.sky_rsms >= 1 && s.sky_rsms <= crate::scene::Sky::MAX_DIRECTIONS,
        "lpv sky_rsms",
        "1..=64",
    )?;
    check(
        s.gain.is_finite() && s.gain >= 0.0,
        "lpv gain",
        "finite, >= 0",
    )?;
    check(
        s.damping.is_finite() && s.damping >= 0.0,
        "lpv damping",
        "finite, >= 0",
    )?;
    DIRECTIONAL.check(s.directional)?;
    if let Some([lo, hi]) = s.bounds {
        let (lo, hi) = (Vec3::from(lo), Vec3::from(hi));
        check(
            lo.is_finite() && hi.is_finite() && lo.cmplt(hi).all(),
            "lpv bounds",
            "[[x0, y0, z0], [x1, y1, z1]], finite, with x0 < x1, y0 < y1 and z0 < z1",
        )?;
    }
    match variant {
        Variant::Uniform => {
            LPV_SIZE.check(s.size)?;
            LPV_ITERATIONS.check(s.iterations)
        }
        Variant::Cascaded => {
            let c = &settings.clpv;
            CLPV_CASCADES.check(c.cascades)?;
            CLPV_SIZE.check(c.size)?;
            CLPV_ITERATIONS.check(c.iterations)?;
            check(
                c.extent.is_finite() && c.extent >= 0.0,
                "clpv extent",
                "finite, >= 0",
            )
        }
        Variant::Octree => {
            let o = &settings.olpv;
            check(
                OLPV_SIZE.contains(o.size) && o.size.is_power_of_two(),
                OLPV_SIZE.name,
                &format!("a power of two in {}", OLPV_SIZE.text()),
            )?;
            OLPV_ITERATIONS.check(o.iterations)
        }
    }
}

pub use rsm::{half_layer_mask, MAX_HALF_LAYERS};

impl GiTechnique for LpvGi {
    fn name(&self) -> &str {
        self.variant.name()
    }

    fn update(&mut self, ctx: &GpuContext, frame: &GiFrame, timer: &mut PassTimer) -> Result<()> {
        let name = self.variant.name();
        let placed = self.place(frame);
        let layers = rsm::rsm_layers(
            &frame.instant.lights,
            frame.sky_lights,
            frame.shadow_layers,
            self.rsm.size,
            self.settings.sky_rsms,
        );
        let layers = self.halve_moving_layers(frame, layers);
        let mut grids = self.gpu_grids(&placed, inject::light_scale(&layers));
        grids.half_layers = half_layer_mask(&layers, self.rsm.size);
        self.last_grids = Some(grids);
        ctx.queue
            .write_buffer(&self.grids, 0, bytemuck::bytes_of(&grids));
        ctx.queue.write_buffer(
            &self.grid_slots,
            0,
            &propagate::slot_data(&placed, self.settings.directional),
        );
        if self.variant == Variant::Octree {
            // The lookup reads the merged volume: one grid of level 0's placement.
            let mut merged = grids;
            merged.count = 1;
            merged.grids[0].offset = 0;
            ctx.queue
                .write_buffer(&self.lookup_grids, 0, bytemuck::bytes_of(&merged));
        }
        if self.passes.is_none() {
            self.passes = Some(self.build(ctx, frame)?);
        }
        let Some(p) = &self.passes else {
            return Ok(());
        };
        p.rsm.update(ctx, &self.rsm, &layers);
        p.rsm.record(
            ctx,
            timer,
            frame.scene_gpu,
            &self.rsm,
            &layers,
            &format!("{name} rsm"),
        )?;
        p.inject.record(
            timer,
            &format!("{name} inject"),
            &self.volumes,
            self.settings.rsm_stride,
        );
        if let Some(octree) = &p.octree {
            octree.record_downsample(timer, &self.volumes);
            octree.record_index(timer);
        }
        p.propagate.record(
            timer,
            &format!("{name} propagate"),
            &self.volumes,
            &self.layouts,
            self.iterations,
        )?;
        if let Some(octree) = &p.octree {
            octree.record_merge(timer);
        }
        p.lookup
            .record(ctx, timer, &format!("{name} lookup"), &self.output)?;
        Ok(())
    }

    fn indirect_view(&self) -> &wgpu::TextureView {
        &self.output.view
    }

    fn reference_transport(&self) -> crate::transport::Transport {
        // RSM VPLs propagated once: exactly one indirect bounce of the lights' light. The
        // RSMs see the lights only, so emissive surfaces light nothing.
        crate::transport::Transport {
            bounces: crate::transport::Bounces::Indirect(1),
            emissive: crate::transport::EmissiveSurfaces::Unlit,
        }
    }

    fn as_any(&self) -> Option<&dyn std::any::Any> {
        Some(self)
    }
}
