//! Voxel clipmap (Arnebäck 2017, chapter 4): `levels` dense volumes of equal resolution
//! `resolution`^3 around the camera, level `l` with voxels of `voxel_size * 2^l`, so each level
//! covers twice the extent of the one inside it.
//!
//! Addressing is toroidal: the voxel at integer world-voxel coordinates `g` of a level lives in
//! slot `g mod resolution`, so a level that follows the camera keeps every voxel it still
//! covers where it is; [`Clipmap::update`] revoxelises only the slabs that camera motion
//! exposes (at most three boxes per level), and a level is rebuilt whole only when it moves by
//! its full width. Each level is voxelized at its own resolution (per-level voxelization).
//!
//! Storage: one `array<u32>` of RGBA8 texels (averaged albedo, opacity 255 where any triangle
//! touches the voxel), level after level, and in the same layout the averaged normals and the
//! mean emission (RGB9E5, [`encode_emission`]): 12 bytes per voxel. [`Clipmap::inject`] adds
//! RGBA16F radiance (emission + reflected direct light, visibility by voxel shadow rays).
//! Moving objects: revoxelise the boxes that their old and new bounds touch
//! ([`Clipmap::boxes_touching`], [`Clipmap::revoxelise`]); the caller decides what moved.
//!
//! Options ([`ClipmapOptions`], [`Clipmap::with_options`]): `filtered` rebuilds the voxels of
//! every coarser level that lie wholly inside the next finer level from the 2x2x2 finer voxels
//! (opacity = covered fraction, premultiplied colour averaged) after each update, keeping
//! per-level voxelization only outside the finer level; `anisotropic` (implies `filtered`) adds
//! 6 directional values per voxel of levels 1 and up ([`Clipmap::aniso`]), composited front to
//! back from the finer level along each axis. Sampling with blending by distance to a level's
//! border and with directional values: [`super::clipmap_sample`].

use super::snap::{snap_triangles, SnapRegion};
use super::voxelize::{
    bind_buffers, dispatch, upload_pieces, upload_triangles, work_items, OVERLAP_WGSL,
};
use super::VoxelTriangle;
use crate::gpu::{read_buffer, GpuContext, PassTimer};
use crate::{Error, Result};
use glam::{IVec3, Vec3};

/// Ledger owner of the clipmap's buffers.
pub const OWNER: &str = "clipmap";
/// Scratch words per voxel of an update box (`ACCUM_WORDS` in `clipmap.wgsl`): albedo sums
/// (3), fragment count, normal sums (3), emission sums (3 x 64 bits).
const ACCUM_WORDS: u64 = 13;
/// Bytes of the accumulation scratch; larger update boxes are processed in z slices.
const ACCUM_BYTES: u64 = 64 << 20;
/// Fixed-point units per W/(m^2 sr) of the emission sums (`EMISSION_SCALE` in
/// `clipmap_emission.wgsl`).
pub const EMISSION_SCALE: f32 = 1024.0;
/// WGSL of the emission format (`emission_encode`, `emission_decode`, ...), put in front of
/// every clipmap kernel that reads or writes [`Clipmap::emission`].
pub const CLIPMAP_EMISSION_WGSL: &str = include_str!("clipmap_emission.wgsl");

/// Fixed-point value (x [`EMISSION_SCALE`], rounded half to even like WGSL `round`) of one
/// triangle's emission channel, clamped to `[0, 65504]` (`emission_fixed` in WGSL).
pub fn emission_fixed(e: f32) -> u32 {
    (e.clamp(0.0, 65504.0) * EMISSION_SCALE).round_ties_even() as u32
}

/// The RGB9E5 word (red bits 0-8, green 9-17, blue 18-26, exponent 27-31, value = mantissa x
/// 2^(exponent - 24)) of a fixed-point colour (x [`EMISSION_SCALE`]), as `emission_encode` in
/// `clipmap_emission.wgsl` computes it: the smallest shift that fits the largest channel in 9
/// bits after rounding, each channel rounded half up; values under 512 (0.5 W/(m^2 sr)) are
/// exact. Zero gives 0.
pub fn encode_emission(q: [u32; 3]) -> u32 {
    let m = q[0].max(q[1]).max(q[2]);
    if m == 0 {
        return 0;
    }
    let half = |s: u32| (1u64 << s) >> 1;
    let mut s = 0;
    while s < 17 && (m as u64 + half(s)) >> s > 511 {
        s += 1;
    }
    let v = q.map(|c| (((c as u64 + half(s)) >> s) as u32).min(511));
    v[0] | (v[1] << 9) | (v[2] << 18) | ((s + 14) << 27)
}

/// The fixed-point colour (x [`EMISSION_SCALE`]) of an RGB9E5 word (`emission_decode_fixed`).
pub fn decode_emission_fixed(w: u32) -> [u32; 3] {
    let e = w >> 27;
    [w & 511, (w >> 9) & 511, (w >> 18) & 511].map(|v| {
        if e >= 14 {
            v << (e - 14)
        } else {
            v >> (14 - e)
        }
    })
}

/// Emitted radiance, W/(m^2 sr), of an RGB9E5 word (`emission_decode`; exact in f32).
pub fn decode_emission(w: u32) -> Vec3 {
    let scale = f32::from_bits(((w >> 27) + 103) << 23);
    Vec3::new(
        (w & 511) as f32,
        ((w >> 9) & 511) as f32,
        ((w >> 18) & 511) as f32,
    ) * scale
}

/// Clipmap dimensions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClipmapSettings {
    /// Voxels per axis of every level (a power of two, 4..=512).
    pub resolution: u32,
    /// Number of levels (1..=8).
    pub levels: u32,
    /// Voxel edge of the finest level (m).
    pub voxel_size: f32,
}

impl ClipmapSettings {
    /// Checks the settings.
    pub fn validate(&self) -> Result<()> {
        if !(4..=512).contains(&self.resolution) || !self.resolution.is_power_of_two() {
            return Err(Error::InvalidArgument(format!(
                "clipmap resolution {}: must be a power of two from 4 to 512",
                self.resolution
            )));
        }
        if !(1..=8).contains(&self.levels) {
            return Err(Error::InvalidArgument(format!(
                "clipmap levels {}: must be 1 to 8",
                self.levels
            )));
        }
        if !(self.voxel_size.is_finite() && self.voxel_size > 0.0) {
            return Err(Error::InvalidArgument(format!(
                "clipmap voxel size {}: must be positive",
                self.voxel_size
            )));
        }
        Ok(())
    }

    /// Voxel edge of level `l`.
    pub fn level_voxel(&self, l: u32) -> f32 {
        self.voxel_size * (1u32 << l) as f32
    }

    /// First voxel (world-voxel coordinates of level `l`) of the level centred on `camera`.
    pub fn level_origin(&self, l: u32, camera: Vec3) -> IVec3 {
        (camera / self.level_voxel(l)).floor().as_ivec3() - IVec3::splat(self.resolution as i32 / 2)
    }
}

/// How the coarser levels are built (both off by default: per-level voxelization).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ClipmapOptions {
    /// Rebuild each coarser level's voxels inside the finer level from the finer voxels.
    pub filtered: bool,
    /// Keep 6 directional values per voxel of levels 1 and up (implies `filtered`): 24 more
    /// bytes per voxel of those levels.
    pub anisotropic: bool,
}

impl ClipmapOptions {
    /// Whether coarser levels are filtered from finer ones.
    pub fn filters(&self) -> bool {
        self.filtered || self.anisotropic
    }
}

/// The voxels of level `level` that lie wholly inside the finer level starting at `fine`
/// (world-voxel coordinates of level `level - 1`): `[ceil(fine / 2), floor((fine + res) / 2))`.
pub fn covered_box(level: u32, fine: IVec3, res: i32) -> UpdateBox {
    UpdateBox {
        level,
        lo: (fine + IVec3::ONE).div_euclid(IVec3::splat(2)),
        hi: (fine + IVec3::splat(res)).div_euclid(IVec3::splat(2)),
    }
}

/// `a` minus `b` (same level) as at most 6 disjoint boxes.
pub fn box_minus(a: UpdateBox, b: UpdateBox) -> Vec<UpdateBox> {
    let lo = a.lo.max(b.lo);
    let hi = a.hi.min(b.hi);
    if a.volume() == 0 {
        return Vec::new();
    }
    if (hi - lo).cmple(IVec3::ZERO).any() {
        return vec![a];
    }
    let mut out = Vec::new();
    let mut rest = a;
    for axis in 0..3 {
        if rest.lo[axis] < lo[axis] {
            let mut slab = rest;
            slab.hi[axis] = lo[axis];
            out.push(slab);
            rest.lo[axis] = lo[axis];
        }
        if rest.hi[axis] > hi[axis] {
            let mut slab = rest;
            slab.lo[axis] = hi[axis];
            out.push(slab);
            rest.hi[axis] = hi[axis];
        }
    }
    out
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct FilterParams {
    lo: [i32; 4],
    hi: [i32; 4],
    misc: [u32; 4],
}

/// One box of voxels `[lo, hi)` of one level that an update revoxelised.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct UpdateBox {
    /// Level.
    pub level: u32,
    /// First voxel (world-voxel coordinates of the level).
    pub lo: IVec3,
    /// One past the last voxel.
    pub hi: IVec3,
}

impl UpdateBox {
    /// Voxels in the box.
    pub fn volume(&self) -> u64 {
        let s = (self.hi - self.lo).max(IVec3::ZERO);
        s.x as u64 * s.y as u64 * s.z as u64
    }
}

/// The boxes of voxels in the level `[new, new + res)` that `[old, old + res)` did not cover:
/// one slab per axis the level moved along, each excluding the slabs before it (disjoint).
pub fn exposed_boxes(level: u32, old: Option<IVec3>, new: IVec3, res: i32) -> Vec<UpdateBox> {
    let whole = UpdateBox {
        level,
        lo: new,
        hi: new + IVec3::splat(res),
    };
    let Some(old) = old else {
        return vec![whole];
    };
    let delta = new - old;
    if delta.abs().max_element() >= res {
        return vec![whole];
    }
    let mut out = Vec::new();
    let mut rest = whole;
    for a in 0..3 {
        let d = delta[a];
        if d > 0 {
            let mut slab = rest;
            slab.lo[a] = old[a] + res;
            rest.hi[a] = old[a] + res;
            out.push(slab);
        } else if d < 0 {
            let mut slab = rest;
            slab.hi[a] = old[a];
            rest.lo[a] = old[a];
            out.push(slab);
        }
    }
    out
}

/// CPU cost and size of the last [`Clipmap::update`] or [`Clipmap::revoxelise`] (zero when it
/// revoxelised nothing). Times are wall-clock milliseconds on the calling thread; GPU times
/// are the passes in the [`PassTimer`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct UpdateStats {
    /// Boxes revoxelised, after splitting into z slices that fit the accumulation scratch.
    pub parts: u32,
    /// Triangles snapped (summed over the parts).
    pub triangles_snapped: u64,
    /// Triangle pieces uploaded.
    pub pieces: u64,
    /// Work items uploaded.
    pub work_items: u64,
    /// Bytes written to the GPU (triangles, pieces, work items, parameters).
    pub upload_bytes: u64,
    /// Finding, snapping and splitting triangles and making work items.
    pub snap_ms: f64,
    /// Creating or writing GPU buffers.
    pub upload_ms: f64,
    /// Creating bind groups and recording the passes.
    pub record_ms: f64,
}

impl UpdateStats {
    /// All CPU time of the update.
    pub fn cpu_ms(&self) -> f64 {
        self.snap_ms + self.upload_ms + self.record_ms
    }
}

/// A voxel clipmap on the GPU.
pub struct Clipmap {
    /// Dimensions.
    pub settings: ClipmapSettings,
    /// Per level, the first voxel it covers (world-voxel coordinates), once updated.
    pub origins: Vec<Option<IVec3>>,
    /// The voxels: `levels * resolution^3` RGBA8 words, level after level, toroidal.
    pub voxels: wgpu::Buffer,
    /// Averaged unit normal per voxel (snorm8 x3), same layout as `voxels`.
    pub normals: wgpu::Buffer,
    /// Mean emitted radiance per voxel (RGB9E5 words, [`decode_emission`]), same layout as
    /// `voxels`; on filtered levels premultiplied by coverage like the albedo.
    pub emission: wgpu::Buffer,
    /// Injected radiance (RGBA16F: radiance, opacity; 2 words per voxel slot), once
    /// [`Clipmap::inject`] has run.
    pub radiance: Option<wgpu::Buffer>,
    /// How coarser levels are built.
    pub options: ClipmapOptions,
    /// With [`ClipmapOptions::anisotropic`]: per voxel slot of levels 1 and up (level after
    /// level from level 1, toroidal), 6 RGBA8 words, for travel along +x, -x, +y, -y, +z, -z.
    pub aniso: Option<wgpu::Buffer>,
    filter: wgpu::ComputePipeline,
    replicate: wgpu::ComputePipeline,
    no_aniso: wgpu::Buffer,
    inject: Option<wgpu::ComputePipeline>,
    accum: wgpu::Buffer,
    written: wgpu::Buffer,
    accumulate: wgpu::ComputePipeline,
    resolve: wgpu::ComputePipeline,
    stats: UpdateStats,
}

impl Clipmap {
    /// Allocates an empty clipmap with per-level voxelization.
    pub fn new(ctx: &GpuContext, settings: ClipmapSettings) -> Result<Clipmap> {
        Self::with_options(ctx, settings, ClipmapOptions::default())
    }

    /// Allocates an empty clipmap built as `options` say.
    pub fn with_options(
        ctx: &GpuContext,
        settings: ClipmapSettings,
        options: ClipmapOptions,
    ) -> Result<Clipmap> {
        settings.validate()?;
        let res = settings.resolution as u64;
        let bytes = settings.levels as u64 * res * res * res * 4;
        if bytes > ctx.device.limits().max_storage_buffer_binding_size {
            return Err(Error::InvalidArgument(format!(
                "a clipmap of {} levels of {}^3 needs {bytes} bytes, more than this GPU can \
                 bind",
                settings.levels, settings.resolution
            )));
        }
        let usage = wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_SRC
            | wgpu::BufferUsages::COPY_DST;
        let voxels = ctx.create_buffer(
            OWNER,
            &wgpu::BufferDescriptor {
                label: Some("voxels"),
                size: bytes,
                usage,
                mapped_at_creation: false,
            },
        );
        let normals = ctx.create_buffer(
            OWNER,
            &wgpu::BufferDescriptor {
                label: Some("normals"),
                size: bytes,
                usage,
                mapped_at_creation: false,
            },
        );
        let emission = ctx.create_buffer(
            OWNER,
            &wgpu::BufferDescriptor {
                label: Some("emission"),
                size: bytes,
                usage,
                mapped_at_creation: false,
            },
        );
        let accum_voxels = (ACCUM_BYTES / (ACCUM_WORDS * 4))
            .min(res * res * res)
            .max(res * res);
        let accum = ctx.create_buffer(
            OWNER,
            &wgpu::BufferDescriptor {
                label: Some("accumulation scratch"),
                size: accum_voxels * ACCUM_WORDS * 4,
                usage,
                mapped_at_creation: false,
            },
        );
        let written = ctx.create_buffer(
            OWNER,
            &wgpu::BufferDescriptor {
                label: Some("written counter"),
                size: 16,
                usage,
                mapped_at_creation: false,
            },
        );
        let aniso_bytes = (settings.levels as u64 - 1) * res * res * res * 24;
        if options.anisotropic && aniso_bytes > ctx.device.limits().max_storage_buffer_binding_size
        {
            return Err(Error::InvalidArgument(format!(
                "anisotropic voxels for {} levels of {}^3 need {aniso_bytes} bytes, more than \
                 this GPU can bind",
                settings.levels, settings.resolution
            )));
        }
        let aniso = (options.anisotropic && aniso_bytes > 0).then(|| {
            ctx.create_buffer(
                OWNER,
                &wgpu::BufferDescriptor {
                    label: Some("anisotropic voxels"),
                    size: aniso_bytes,
                    usage,
                    mapped_at_creation: false,
                },
            )
        });
        let no_aniso = ctx.create_buffer(
            OWNER,
            &wgpu::BufferDescriptor {
                label: Some("no anisotropic voxels"),
                size: 16,
                usage,
                mapped_at_creation: false,
            },
        );
        let source = format!(
            "{OVERLAP_WGSL}\n{CLIPMAP_EMISSION_WGSL}\n{}",
            include_str!("clipmap.wgsl")
        );
        let module = ctx.shader("clipmap", &source);
        let source = format!(
            "{OVERLAP_WGSL}\n{CLIPMAP_EMISSION_WGSL}\n{}",
            include_str!("clipmap_filter.wgsl")
        );
        let filter_module = ctx.shader("clipmap filter", &source);
        Ok(Clipmap {
            settings,
            origins: vec![None; settings.levels as usize],
            voxels,
            normals,
            emission,
            radiance: None,
            options,
            aniso,
            filter: ctx.compute_pipeline("clipmap filter", &filter_module, "filter_level"),
            replicate: ctx.compute_pipeline("clipmap replicate", &filter_module, "replicate"),
            no_aniso,
            inject: None,
            accum,
            written,
            accumulate: ctx.compute_pipeline("clipmap accumulate", &module, "accumulate"),
            resolve: ctx.compute_pipeline("clipmap resolve", &module, "resolve"),
            stats: UpdateStats::default(),
        })
    }

    /// Bytes the clipmap keeps on the GPU: albedo/opacity, normals and emission (4 + 4 + 4
    /// bytes per voxel),
    /// with anisotropic voxels 24 bytes per voxel of levels 1 and up, and, once light has been
    /// injected, radiance (8 bytes per voxel). The accumulation scratch is reported separately
    /// in the ledger.
    pub fn bytes(&self) -> u64 {
        self.voxels.size()
            + self.normals.size()
            + self.emission.size()
            + self.aniso.as_ref().map_or(0, |a| a.size())
            + self.radiance.as_ref().map_or(0, |r| r.size())
    }

    /// Brings every level to the camera position `camera`, revoxelising only the voxels the
    /// levels did not cover before (everything on the first call). Passes are recorded into
    /// `timer` as `clipmap L<l>`. Returns the boxes revoxelised.
    pub fn update(
        &mut self,
        ctx: &GpuContext,
        timer: &mut PassTimer,
        tris: &[VoxelTriangle],
        camera: Vec3,
    ) -> Result<Vec<UpdateBox>> {
        if !camera.is_finite() {
            return Err(Error::InvalidArgument(format!("camera position {camera}")));
        }
        let res = self.settings.resolution as i32;
        let mut boxes = Vec::new();
        let old = self.origins.clone();
        for l in 0..self.settings.levels {
            let new = self.settings.level_origin(l, camera);
            boxes.extend(exposed_boxes(l, self.origins[l as usize], new, res));
            self.origins[l as usize] = Some(new);
        }
        if self.options.filters() {
            // Voxels the finer level no longer covers get voxelized on their own again.
            for l in 1..self.settings.levels as usize {
                let (Some(was), Some(now), Some(here)) = (old[l - 1], self.origins[l - 1], old[l])
                else {
                    continue;
                };
                let level = UpdateBox {
                    level: l as u32,
                    lo: here.max(self.origins[l].unwrap_or(here)),
                    hi: (here + IVec3::splat(res))
                        .min(self.origins[l].unwrap_or(here) + IVec3::splat(res)),
                };
                let left = covered_box(l as u32, was, res);
                let clipped = UpdateBox {
                    lo: left.lo.max(level.lo),
                    hi: left.hi.min(level.hi),
                    ..left
                };
                if (clipped.hi - clipped.lo).cmple(IVec3::ZERO).any() {
                    continue;
                }
                boxes.extend(box_minus(clipped, covered_box(l as u32, now, res)));
            }
        }
        self.revoxelise(ctx, timer, tris, &boxes)?;
        Ok(boxes)
    }

    /// The boxes of every level that cover the world-space box `[lo, hi]` (with one voxel of
    /// margin, since touching counts), clipped to each level's current extent. For a moving
    /// object, revoxelise the boxes of its old and of its new bounds.
    pub fn boxes_touching(&self, lo: Vec3, hi: Vec3) -> Vec<UpdateBox> {
        let res = IVec3::splat(self.settings.resolution as i32);
        let mut out = Vec::new();
        if !(lo.is_finite() && hi.is_finite()) {
            return out;
        }
        for (l, origin) in self.origins.iter().enumerate() {
            let Some(origin) = *origin else { continue };
            let v = self.settings.level_voxel(l as u32);
            let first = ((lo / v).floor().as_ivec3() - IVec3::ONE).max(origin);
            let end = ((hi / v).floor().as_ivec3() + IVec3::splat(2)).min(origin + res);
            let b = UpdateBox {
                level: l as u32,
                lo: first,
                hi: end,
            };
            if (end - first).cmpgt(IVec3::ZERO).all() {
                out.push(b);
            }
        }
        out
    }

    /// Revoxelises the given boxes (each inside its level's current extent), for example the
    /// region a moving object left and entered ([`Clipmap::boxes_touching`]). A filtered
    /// clipmap then rebuilds every coarser level's voxels inside the finer level, finest first.
    pub fn revoxelise(
        &mut self,
        ctx: &GpuContext,
        timer: &mut PassTimer,
        tris: &[VoxelTriangle],
        boxes: &[UpdateBox],
    ) -> Result<()> {
        let mut stats = UpdateStats::default();
        self.stats = stats;
        if boxes.is_empty() {
            return Ok(());
        }
        let clock = std::time::Instant::now();
        let triangles = upload_triangles(ctx, OWNER, tris);
        stats.upload_bytes += tris.len().max(1) as u64 * 64;
        stats.upload_ms += clock.elapsed().as_secs_f64() * 1e3;
        let res = self.settings.resolution as u64;
        let slice = (res * res).max(1);
        let max_depth = (self.accum.size() / (ACCUM_WORDS * 4) / slice).max(1) as i32;
        let mut item_bytes = 0u64;
        for b in boxes {
            let mut z = b.lo.z;
            while z < b.hi.z {
                let part = UpdateBox {
                    level: b.level,
                    lo: IVec3::new(b.lo.x, b.lo.y, z),
                    hi: IVec3::new(b.hi.x, b.hi.y, (z + max_depth).min(b.hi.z)),
                };
                z = part.hi.z;
                if part.volume() == 0 {
                    continue;
                }
                let region = SnapRegion {
                    origin: Vec3::ZERO,
                    voxel_size: self.settings.level_voxel(part.level),
                    lo: part.lo,
                    hi: part.hi,
                };
                let clock = std::time::Instant::now();
                let pieces = snap_triangles(&region, tris);
                let items = work_items(&pieces, region.size());
                stats.snap_ms += clock.elapsed().as_secs_f64() * 1e3;
                stats.parts += 1;
                stats.triangles_snapped += tris.len() as u64;
                stats.pieces += pieces.len() as u64;
                stats.work_items += items.len() as u64;
                stats.upload_bytes += 48 + items.len() as u64 * 8 + pieces.len() as u64 * 48;
                let clock = std::time::Instant::now();
                item_bytes = item_bytes.max(items.len() as u64 * 8 + pieces.len() as u64 * 48);
                let params = super::voxelize::VoxParams {
                    lo: part.lo.extend(0).to_array(),
                    hi: part.hi.extend(0).to_array(),
                    misc: [
                        items.len() as u32,
                        (part.level as u64 * res * res * res) as u32,
                        res as u32,
                        0,
                    ],
                };
                let params_buffer = ctx.create_buffer_init(
                    OWNER,
                    "box params",
                    bytemuck::bytes_of(&params),
                    wgpu::BufferUsages::STORAGE,
                );
                let items_buffer = ctx.create_buffer_init(
                    OWNER,
                    "work items",
                    bytemuck::cast_slice(&items),
                    wgpu::BufferUsages::STORAGE,
                );
                let pieces_buffer = upload_pieces(ctx, OWNER, &pieces);
                stats.upload_ms += clock.elapsed().as_secs_f64() * 1e3;
                let clock = std::time::Instant::now();
                let name = format!("clipmap L{}", part.level);
                let group = bind_buffers(
                    ctx,
                    &self.accumulate,
                    &[
                        (0, &params_buffer),
                        (1, &triangles),
                        (2, &items_buffer),
                        (3, &self.accum),
                        (8, &pieces_buffer),
                    ],
                );
                dispatch(
                    timer,
                    &format!("{name} voxelize"),
                    &self.accumulate,
                    &group,
                    items.len() as u32,
                );
                let group = bind_buffers(
                    ctx,
                    &self.resolve,
                    &[
                        (0, &params_buffer),
                        (3, &self.accum),
                        (4, &self.voxels),
                        (5, &self.written),
                        (6, &self.normals),
                        (7, &self.emission),
                    ],
                );
                dispatch(
                    timer,
                    &format!("{name} resolve"),
                    &self.resolve,
                    &group,
                    part.volume() as u32,
                );
                stats.record_ms += clock.elapsed().as_secs_f64() * 1e3;
            }
        }
        ctx.ledger.record(OWNER, "work items", item_bytes);
        ctx.ledger.record(OWNER, "triangle pieces", 0);
        if self.options.filters() {
            let clock = std::time::Instant::now();
            self.filter_levels(ctx, timer, boxes);
            stats.record_ms += clock.elapsed().as_secs_f64() * 1e3;
        }
        self.stats = stats;
        Ok(())
    }

    fn filter_pass(
        &self,
        ctx: &GpuContext,
        timer: &mut PassTimer,
        pipeline: &wgpu::ComputePipeline,
        name: &str,
        b: &UpdateBox,
    ) {
        if b.volume() == 0 {
            return;
        }
        let params = FilterParams {
            lo: b.lo.extend(0).to_array(),
            hi: b.hi.extend(0).to_array(),
            misc: [
                b.level,
                self.settings.resolution,
                self.aniso.is_some() as u32,
                0,
            ],
        };
        let params_buffer = ctx.create_buffer_init(
            OWNER,
            "filter params",
            bytemuck::bytes_of(&params),
            wgpu::BufferUsages::STORAGE,
        );
        let aniso = self.aniso.as_ref().unwrap_or(&self.no_aniso);
        let mut buffers = vec![(0, &params_buffer), (1, &self.voxels), (3, aniso)];
        // `replicate` has no normals or emission binding.
        if std::ptr::eq(pipeline, &self.filter) {
            buffers.push((2, &self.normals));
            buffers.push((4, &self.emission));
        }
        let group = bind_buffers(ctx, pipeline, &buffers);
        dispatch(timer, name, pipeline, &group, b.volume() as u32);
    }

    /// Directional values of the revoxelised coarse boxes (a copy of the isotropic value),
    /// then each coarser level's voxels inside the finer level from the finer voxels.
    fn filter_levels(&self, ctx: &GpuContext, timer: &mut PassTimer, boxes: &[UpdateBox]) {
        let res = self.settings.resolution as i32;
        if self.aniso.is_some() {
            for b in boxes.iter().filter(|b| b.level > 0) {
                let name = format!("clipmap L{} replicate", b.level);
                self.filter_pass(ctx, timer, &self.replicate, &name, b);
            }
        }
        for l in 1..self.settings.levels {
            let (Some(fine), Some(_)) = (self.origins[l as usize - 1], self.origins[l as usize])
            else {
                continue;
            };
            let name = format!("clipmap L{l} filter");
            self.filter_pass(ctx, timer, &self.filter, &name, &covered_box(l, fine, res));
        }
    }

    /// CPU cost and size of the last [`Clipmap::update`] or [`Clipmap::revoxelise`].
    pub fn last_update_stats(&self) -> UpdateStats {
        self.stats
    }

    /// Reads the directional values back ([`Clipmap::aniso`]; empty without them). Blocks.
    pub fn read_aniso(&self, ctx: &GpuContext) -> Result<Vec<u32>> {
        let Some(aniso) = &self.aniso else {
            return Ok(Vec::new());
        };
        let bytes = read_buffer(ctx, aniso, 0, aniso.size())?;
        Ok(bytemuck::cast_slice(&bytes).to_vec())
    }

    /// Injects light: every occupied voxel gets outgoing radiance emission + albedo / pi x the
    /// irradiance from `lights` (point, spot, directional), with visibility found by marching
    /// the clipmap's own opacity towards each light (at most `max_steps` samples, half a voxel
    /// of the voxel's level apart, per ray). Writes [`Clipmap::radiance`]; the pass is `clipmap inject`.
    pub fn inject(
        &mut self,
        ctx: &GpuContext,
        timer: &mut PassTimer,
        lights: &[crate::scene::Light],
        max_steps: u32,
    ) -> Result<()> {
        let mut gpu: Vec<[f32; 12]> = lights
            .iter()
            .map(|l| {
                let (kind, inner, outer) = match l.kind {
                    crate::scene::LightKind::Point => (0.0, 1.0, -1.0),
                    crate::scene::LightKind::Spot {
                        inner_angle,
                        outer_angle,
                    } => (1.0, inner_angle.cos(), outer_angle.cos()),
                    crate::scene::LightKind::Directional => (2.0, 1.0, -1.0),
                };
                let e = l.radiant();
                [
                    l.position.x,
                    l.position.y,
                    l.position.z,
                    kind,
                    l.direction.x,
                    l.direction.y,
                    l.direction.z,
                    inner,
                    e.x,
                    e.y,
                    e.z,
                    outer,
                ]
            })
            .collect();
        let count = gpu.len() as u32;
        if gpu.is_empty() {
            gpu.push([0.0; 12]);
        }
        let lights_buffer = ctx.create_buffer_init(
            OWNER,
            "inject lights",
            bytemuck::cast_slice(&gpu),
            wgpu::BufferUsages::STORAGE,
        );
        let res = self.settings.resolution as u64;
        let slots = (self.settings.levels as u64 * res * res * res) as u32;
        let params = ctx.create_buffer_init(
            OWNER,
            "inject params",
            bytemuck::cast_slice(&[count, max_steps.clamp(1, 4096), slots, 0]),
            wgpu::BufferUsages::STORAGE,
        );
        let info = ctx.create_buffer_init(
            OWNER,
            "inject info",
            bytemuck::bytes_of(&super::sample::ClipInfo::new(&self.settings, &self.origins)),
            wgpu::BufferUsages::STORAGE,
        );
        let radiance = match self.radiance.take() {
            Some(r) => r,
            None => ctx.create_buffer(
                OWNER,
                &wgpu::BufferDescriptor {
                    label: Some("radiance"),
                    size: slots as u64 * 8,
                    usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                    mapped_at_creation: false,
                },
            ),
        };
        let pipeline = match &self.inject {
            Some(p) => p.clone(),
            None => {
                let source = format!(
                    "{}\n{CLIPMAP_EMISSION_WGSL}\n{}",
                    super::sample::CLIPMAP_SAMPLE_WGSL,
                    include_str!("inject.wgsl")
                );
                let module = ctx.shader("clipmap inject", &source);
                let p = ctx.compute_pipeline("clipmap inject", &module, "inject");
                self.inject = Some(p.clone());
                p
            }
        };
        let group = bind_buffers(
            ctx,
            &pipeline,
            &[
                (0, &info),
                (1, &self.voxels),
                (2, &self.normals),
                (3, &lights_buffer),
                (4, &radiance),
                (5, &params),
                (6, &self.emission),
            ],
        );
        dispatch(timer, "clipmap inject", &pipeline, &group, slots);
        self.radiance = Some(radiance);
        Ok(())
    }

    /// Reads the injected radiance back: per voxel slot (layout of `voxels`), RGB radiance
    /// and opacity. Empty before [`Clipmap::inject`]. Blocks.
    pub fn read_radiance(&self, ctx: &GpuContext) -> Result<Vec<glam::Vec4>> {
        let Some(radiance) = &self.radiance else {
            return Ok(Vec::new());
        };
        let bytes = read_buffer(ctx, radiance, 0, radiance.size())?;
        let words: &[u32] = bytemuck::cast_slice(&bytes);
        Ok(words
            .chunks_exact(2)
            .map(|w| {
                let a = super::svo::unpack_half2(w[0]);
                let b = super::svo::unpack_half2(w[1]);
                glam::Vec4::new(a[0], a[1], b[0], b[1])
            })
            .collect())
    }

    /// Voxels written by all updates so far (read from the GPU counter). Blocks.
    pub fn voxels_written(&self, ctx: &GpuContext) -> Result<u32> {
        let bytes = read_buffer(ctx, &self.written, 0, 4)?;
        Ok(bytemuck::cast_slice::<u8, u32>(&bytes)[0])
    }

    /// Reads all voxels back (RGBA8 words, level after level, toroidal order). Blocks.
    pub fn read_voxels(&self, ctx: &GpuContext) -> Result<Vec<u32>> {
        let bytes = read_buffer(ctx, &self.voxels, 0, self.voxels.size())?;
        Ok(bytemuck::cast_slice(&bytes).to_vec())
    }

    /// Reads the emission back (RGB9E5 words, [`decode_emission`], layout of `voxels`). Blocks.
    pub fn read_emission(&self, ctx: &GpuContext) -> Result<Vec<u32>> {
        let bytes = read_buffer(ctx, &self.emission, 0, self.emission.size())?;
        Ok(bytemuck::cast_slice(&bytes).to_vec())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exposed_boxes_are_the_new_minus_the_old_region() {
        let res = 8;
        let old = IVec3::new(3, -2, 5);
        for delta in [
            IVec3::new(2, 0, 0),
            IVec3::new(-3, 1, 0),
            IVec3::new(1, -1, 7),
            IVec3::new(0, 0, 0),
            IVec3::new(9, 0, 0),
        ] {
            let new = old + delta;
            let boxes = exposed_boxes(0, Some(old), new, res);
            let inside = |p: IVec3, o: IVec3| p.cmpge(o).all() && p.cmplt(o + res).all();
            for z in new.z..new.z + res {
                for y in new.y..new.y + res {
                    for x in new.x..new.x + res {
                        let p = IVec3::new(x, y, z);
                        let hits = boxes
                            .iter()
                            .filter(|b| p.cmpge(b.lo).all() && p.cmplt(b.hi).all())
                            .count();
                        let exposed = !inside(p, old) || delta.abs().max_element() >= res;
                        assert_eq!(hits, exposed as usize, "{p} for delta {delta}");
                    }
                }
            }
        }
        assert_eq!(exposed_boxes(2, None, old, res).len(), 1);
    }

    #[test]
    fn emission_format_is_exact_below_512_and_rounds_to_9_bits_above() {
        assert_eq!(encode_emission([0; 3]), 0);
        assert_eq!(decode_emission(0), Vec3::ZERO);
        let mut rng = 0x9e3779b97f4a7c15u64;
        let mut next = |bits: u32| {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            (rng >> (64 - bits)) as u32
        };
        for i in 0..20000 {
            let bits = 1 + i % 27;
            let q = [next(bits), next(bits), next(bits)].map(|v| v.min(511 << 17));
            let w = encode_emission(q);
            let back = decode_emission_fixed(w);
            let m = q[0].max(q[1]).max(q[2]);
            // The float decoding is the fixed-point one / 1024, exactly.
            let f = decode_emission(w);
            for c in 0..3 {
                assert_eq!(f[c], back[c] as f32 / EMISSION_SCALE, "{q:?}");
                if m < 512 {
                    assert_eq!(back[c], q[c], "{q:?}");
                } else {
                    // Half a step of 9 bits under the largest channel's exponent: under
                    // 1/511 of the largest channel.
                    let err = (back[c] as i64 - q[c] as i64).unsigned_abs();
                    assert!(err as f64 <= m as f64 / 511.0, "{q:?} -> {back:?}");
                }
            }
            // Re-encoding a decoded word gives the same word (filtering is stable).
            assert_eq!(encode_emission(back), w);
        }
        assert_eq!(emission_fixed(-1.0), 0);
        assert_eq!(emission_fixed(1.5), 1536);
        assert_eq!(
            decode_emission(encode_emission([emission_fixed(1e9); 3])).x,
            65408.0
        );
    }

    #[test]
    fn bad_settings_are_rejected() {
        let ok = ClipmapSettings {
            resolution: 64,
            levels: 4,
            voxel_size: 0.1,
        };
        assert!(ok.validate().is_ok());
        for bad in [
            ClipmapSettings {
                resolution: 48,
                ..ok
            },
            ClipmapSettings {
                resolution: 1024,
                ..ok
            },
            ClipmapSettings { levels: 0, ..ok },
            ClipmapSettings { levels: 9, ..ok },
            ClipmapSettings {
                voxel_size: f32::NAN,
                ..ok
            },
        ] {
            assert!(matches!(bad.validate(), Err(Error::InvalidArgument(_))));
        }
    }
}
