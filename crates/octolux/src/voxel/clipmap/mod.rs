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
//! The scene stays resident ([`Clipmap::set_scene`]: triangles uploaded once, their bounds
//! indexed on the CPU by [`crate::voxel::clipmap::index`]), so a per-frame [`Clipmap::follow`] snaps
//! and uploads only the triangles near the boxes it revoxelises, into scratch buffers kept
//! across updates. Moving objects: [`Clipmap::replace_triangles`] replaces an object's own
//! triangles and queues the boxes around its old and new bounds for the next update; or
//! revoxelise boxes explicitly ([`Clipmap::boxes_touching`], [`Clipmap::revoxelise`]). The
//! caller decides what moved.
//!
//! Options ([`ClipmapOptions`], [`Clipmap::with_options`]): `filtered` rebuilds the voxels of
//! every coarser level that lie wholly inside the next finer level from the 2x2x2 finer voxels
//! (opacity = covered fraction, premultiplied colour averaged) after each update, keeping
//! per-level voxelization only outside the finer level; `anisotropic` (implies `filtered`) adds
//! 6 directional values per voxel of levels 1 and up ([`Clipmap::aniso`]), composited front to
//! back from the finer level along each axis. Sampling with blending by distance to a level's
//! border and with directional values: [`crate::voxel::clipmap::sample`].

pub mod cpu;
pub mod index;
pub mod sample;

use crate::gpu::pass::{bind_buffers, dispatch_1d};
use crate::gpu::shader::library_shader;
use crate::gpu::{read_buffer, GpuContext, PassTimer};
use crate::voxel::clipmap::index::TriangleIndex;
use crate::voxel::clipmap::sample::CLIP_BINDINGS;
use crate::voxel::voxelize::snap::{snap_triangle, GpuPiece, Piece, SnapRegion};
use crate::voxel::voxelize::{upload_triangles, work_items, VoxParams};
use crate::voxel::VoxelTriangle;
use crate::{Error, Result};
use bytemuck::Zeroable;
use glam::{DVec3, IVec3, Vec3};
use rayon::prelude::*;

/// Ledger owner of the clipmap's buffers.
pub const OWNER: &str = "clipmap";
/// Scratch words per voxel of an update box (`ACCUM_WORDS` in `clipmap/update.wgsl`): albedo sums
/// (3), fragment count, normal sums (3), emission sums (3 x 64 bits).
const ACCUM_WORDS: u64 = 13;
/// Bytes of the accumulation scratch; larger update boxes are processed in z slices.
const ACCUM_BYTES: u64 = 64 << 20;
/// Largest scratch buffer (triangle pieces, work items, box parameters) a clipmap keeps
/// between updates; an update that needs more (a first build, a jump) uses buffers of its own.
pub const SCRATCH_KEEP: u64 = 4 << 20;

/// Initial size of each kept scratch buffer, allocated with the clipmap so that the usual
/// per-frame updates (a camera step, a moving object) never change the memory ledger.
const SCRATCH_START: u64 = 64 << 10;

/// Ledger names of the kept scratch buffers: triangle pieces, work items, box parameters.
const SCRATCH_NAMES: [&str; 3] = ["triangle pieces", "work items", "box params"];
/// Bytes between the parameter blocks of an update's boxes (storage binding offsets stay 256
/// bytes apart, the largest `min_storage_buffer_offset_alignment` wgpu allows).
const PARAM_STRIDE: u64 = 256;
/// Light injections recorded before one submission (each writes its parameters to its own
/// slot).
const INJECT_SLOTS: u64 = 4;
/// Bytes of one `InjectLight` (`clipmap/inject.wgsl`).
const INJECT_LIGHT_BYTES: u64 = 48;
/// Lights per 768-byte step of the light buffer's slots (offsets stay 256-byte aligned).
const INJECT_LIGHT_ALIGN: u64 = 16;
/// Pieces (48 bytes) per 768-byte alignment step of a box's block of pieces.
const PIECE_ALIGN: u64 = 16;
/// Work items (8 bytes) per 256-byte alignment step of a box's block of work items.
const ITEM_ALIGN: u64 = 32;
/// Fixed-point units per W/(m^2 sr) of the emission sums (`EMISSION_SCALE` in
/// `clipmap/emission.wgsl`).
pub const EMISSION_SCALE: f32 = 1024.0;

/// Fixed-point value (x [`EMISSION_SCALE`], rounded half to even like WGSL `round`) of one
/// triangle's emission channel, clamped to `[0, 65504]` (`emission_fixed` in WGSL).
pub fn emission_fixed(e: f32) -> u32 {
    (e.clamp(0.0, 65504.0) * EMISSION_SCALE).round_ties_even() as u32
}

/// The RGB9E5 word (red bits 0-8, green 9-17, blue 18-26, exponent 27-31, value = mantissa x
/// 2^(exponent - 24)) of a fixed-point colour (x [`EMISSION_SCALE`]), as `emission_encode` in
/// `clipmap/emission.wgsl` computes it: the smallest shift that fits the largest channel in 9
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
    /// Finding (index queries), snapping and splitting triangles, making work items and
    /// packing them for upload; with [`Clipmap::update`] or [`Clipmap::revoxelise`] also the
    /// comparison of the given triangles with the scene.
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

/// CPU twin of the injections' store (`inject_common.wgsl`): the outgoing radiance of a voxel
/// slot with RGBA8 word `voxel` (albedo, premultiplied by coverage on filtered levels, and
/// opacity) and RGB9E5 `emission` under `irradiance` W/m^2 (direct, plus with multiple bounces
/// the indirect irradiance of [`Clipmap::set_bounce`]): emission + albedo / pi x irradiance;
/// zero for an empty slot. The GPU stores it as f16.
pub fn injected_radiance(voxel: u32, emission: u32, irradiance: Vec3) -> Vec3 {
    if voxel >> 24 == 0 {
        return Vec3::ZERO;
    }
    let albedo = Vec3::new(
        (voxel & 255) as f32,
        ((voxel >> 8) & 255) as f32,
        ((voxel >> 16) & 255) as f32,
    ) / 255.0;
    decode_emission(emission) + albedo / std::f32::consts::PI * irradiance
}

/// A voxel clipmap on the GPU.
pub struct Clipmap {
    /// Ledger owner of its buffers.
    owner: &'static str,
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
    /// The injection from the renderer's shadow maps, made at its first use.
    inject_shadow: Option<wgpu::ComputePipeline>,
    /// The injection's parameters and sampling block in [`INJECT_SLOTS`] slots (writes land at
    /// the submission, so each injection recorded before one takes the next slot), the
    /// voxel-ray injection's lights (a slot of `inject_light_room` lights each), the timer
    /// submission and slots used so far, and the bind groups per injection and slot.
    inject_params: [wgpu::Buffer; 2],
    inject_lights: wgpu::Buffer,
    inject_light_room: u64,
    inject_used: (u64, u64),
    inject_groups: Vec<crate::gpu::pass::KeptBindGroup>,
    accum: wgpu::Buffer,
    written: wgpu::Buffer,
    accumulate: wgpu::ComputePipeline,
    resolve: wgpu::ComputePipeline,
    stats: UpdateStats,
    /// Statistics of the work done since the last revoxelisation (scene uploads).
    acc: UpdateStats,
    scene: Vec<VoxelTriangle>,
    has_scene: bool,
    index: TriangleIndex,
    /// The scene's triangles on the GPU (at least one element).
    triangles: wgpu::Buffer,
    /// Kept scratch: triangle pieces, work items, box parameters.
    scratch: [Option<wgpu::Buffer>; 3],
    /// The timer submission the kept scratch was last written for, and the bytes of each
    /// used since: writes land at the next submission, so later updates recorded before it
    /// take the space after them instead of overwriting data earlier passes still read.
    scratch_use: (Option<u64>, [u64; 3]),
    /// Boxes queued by [`Clipmap::replace_triangles`].
    pending: Vec<UpdateBox>,
    /// Every box the last revoxelisation rewrote (camera motion and moving objects).
    revoxelised: Vec<UpdateBox>,
    /// Indirect irradiance per voxel slot that the injection adds to the direct irradiance
    /// (multiple bounces; [`Clipmap::set_bounce`]).
    bounce: Option<wgpu::Buffer>,
}

/// A whole buffer as a binding range.
fn whole(b: &wgpu::Buffer) -> (&wgpu::Buffer, u64, u64) {
    (b, 0, b.size())
}

/// A bind group of buffer ranges `(binding, (buffer, offset, size))`.
fn bind_ranges(
    ctx: &GpuContext,
    pipeline: &wgpu::ComputePipeline,
    buffers: &[(u32, (&wgpu::Buffer, u64, u64))],
) -> wgpu::BindGroup {
    let entries: Vec<wgpu::BindGroupEntry> = buffers
        .iter()
        .map(|&(binding, (buffer, offset, size))| wgpu::BindGroupEntry {
            binding,
            resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                buffer,
                offset,
                size: wgpu::BufferSize::new(size),
            }),
        })
        .collect();
    ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &pipeline.get_bind_group_layout(0),
        entries: &entries,
    })
}

/// Whether two triangles are the same bit for bit (so that a NaN equals itself).
fn same_triangle(a: &VoxelTriangle, b: &VoxelTriangle) -> bool {
    let bits = |t: &VoxelTriangle| {
        let mut w = [0u32; 16];
        for (i, p) in t.positions.iter().enumerate() {
            w[3 * i] = p.x.to_bits();
            w[3 * i + 1] = p.y.to_bits();
            w[3 * i + 2] = p.z.to_bits();
        }
        w[9] = t.albedo[0] as u32 | (t.albedo[1] as u32) << 8 | (t.albedo[2] as u32) << 16;
        w[10..13].copy_from_slice(&t.normal.to_array().map(f32::to_bits));
        w[13..16].copy_from_slice(&t.emission.to_array().map(f32::to_bits));
        w
    };
    bits(a) == bits(b)
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
        Self::with_owner(ctx, settings, options, OWNER)
    }

    /// [`Clipmap::with_options`] with its memory recorded in the ledger under `owner` (a
    /// technique that owns the clipmap) instead of `clipmap`.
    pub fn with_owner(
        ctx: &GpuContext,
        settings: ClipmapSettings,
        options: ClipmapOptions,
        owner: &'static str,
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
            owner,
            &wgpu::BufferDescriptor {
                label: Some("voxels"),
                size: bytes,
                usage,
                mapped_at_creation: false,
            },
        );
        let normals = ctx.create_buffer(
            owner,
            &wgpu::BufferDescriptor {
                label: Some("normals"),
                size: bytes,
                usage,
                mapped_at_creation: false,
            },
        );
        let emission = ctx.create_buffer(
            owner,
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
            owner,
            &wgpu::BufferDescriptor {
                label: Some("accumulation scratch"),
                size: accum_voxels * ACCUM_WORDS * 4,
                usage,
                mapped_at_creation: false,
            },
        );
        let written = ctx.create_buffer(
            owner,
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
                owner,
                &wgpu::BufferDescriptor {
                    label: Some("anisotropic voxels"),
                    size: aniso_bytes,
                    usage,
                    mapped_at_creation: false,
                },
            )
        });
        let no_aniso = ctx.create_buffer(
            owner,
            &wgpu::BufferDescriptor {
                label: Some("no anisotropic voxels"),
                size: 16,
                usage,
                mapped_at_creation: false,
            },
        );
        let source = library_shader("voxel/clipmap/update", &[]);
        let module = ctx.shader("clipmap", &source);
        let source = library_shader("voxel/clipmap/filter", &[]);
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
            inject_shadow: None,
            inject_params: inject_param_buffers(ctx, owner),
            inject_lights: inject_light_buffer(ctx, owner, INJECT_LIGHT_ALIGN),
            inject_light_room: INJECT_LIGHT_ALIGN,
            inject_used: (u64::MAX, 0),
            inject_groups: (0..2 * INJECT_SLOTS).map(|_| Default::default()).collect(),
            accum,
            written,
            accumulate: ctx.compute_pipeline("clipmap accumulate", &module, "accumulate"),
            resolve: ctx.compute_pipeline("clipmap resolve", &module, "resolve"),
            stats: UpdateStats::default(),
            acc: UpdateStats::default(),
            scene: Vec::new(),
            has_scene: false,
            index: TriangleIndex::default(),
            triangles: upload_triangles(ctx, owner, &[]),
            scratch: SCRATCH_NAMES.map(|name| {
                Some(ctx.create_buffer(
                    owner,
                    &wgpu::BufferDescriptor {
                        label: Some(name),
                        size: SCRATCH_START,
                        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                        mapped_at_creation: false,
                    },
                ))
            }),
            scratch_use: (None, [0; 3]),
            pending: Vec::new(),
            revoxelised: Vec::new(),
            bounce: None,
            owner,
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
    ///
    /// `tris` becomes the clipmap's scene ([`Clipmap::set_scene`]) when it differs from it; a
    /// scene that differs in a few triangles only has those replaced (as
    /// [`Clipmap::replace_triangles`] does, but without revoxelising the regions they left and
    /// entered). Comparing costs one pass over `tris`; [`Clipmap::follow`] skips it.
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
        self.sync_scene(ctx, tris);
        self.follow(ctx, timer, camera)
    }

    /// [`Clipmap::update`] with the clipmap's own scene ([`Clipmap::set_scene`],
    /// [`Clipmap::replace_triangles`]): the per-frame call for a moving camera. Also
    /// revoxelises the boxes that [`Clipmap::replace_triangles`] queued since the last
    /// revoxelisation (clipped to the levels' new extents). Returns the boxes revoxelised for
    /// the camera's motion.
    pub fn follow(
        &mut self,
        ctx: &GpuContext,
        timer: &mut PassTimer,
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
        self.revoxelise_boxes(ctx, timer, &boxes)?;
        Ok(boxes)
    }

    /// Makes `tris` the clipmap's scene: uploads them once into a GPU buffer that stays
    /// resident (ledger: `clipmap / triangles`, 64 bytes per triangle) and indexes their bounds
    /// on the CPU ([`crate::voxel::clipmap::index`]), so that an update snaps and uploads only the
    /// triangles near the boxes it revoxelises. Voxels already built are left as they are
    /// until revoxelised; pending boxes of [`Clipmap::replace_triangles`] are dropped.
    pub fn set_scene(&mut self, ctx: &GpuContext, tris: &[VoxelTriangle]) {
        let clock = std::time::Instant::now();
        self.scene = tris.to_vec();
        self.index = TriangleIndex::new(tris);
        // A new buffer, so that passes recorded earlier keep reading the triangles they saw.
        self.triangles = upload_triangles(ctx, self.owner, tris);
        self.pending.clear();
        self.has_scene = true;
        self.acc.upload_bytes += tris.len() as u64 * 64;
        self.acc.upload_ms += clock.elapsed().as_secs_f64() * 1e3;
    }

    /// The clipmap's scene ([`Clipmap::set_scene`]).
    pub fn scene(&self) -> &[VoxelTriangle] {
        &self.scene
    }

    /// Moving objects: replaces triangles `first..first + tris.len()` of the clipmap's scene
    /// (an object's own triangles, in the same order and number) with `tris`, uploading only
    /// those, and queues for revoxelisation the boxes of every level around their old and
    /// their new bounds ([`Clipmap::boxes_touching`]). The next [`Clipmap::follow`],
    /// [`Clipmap::update`] or [`Clipmap::revoxelise`] revoxelises them, so a frame with a
    /// moving camera and moving objects needs one revoxelisation. Returns the boxes queued.
    ///
    /// The triangles' attributes (albedo, normal, emission) are written to the resident buffer
    /// with [`wgpu::Queue::write_buffer`], which takes effect at the next submission: passes
    /// recorded but not yet submitted read the new attributes (their positions are in the
    /// snapped pieces and stay as they were).
    pub fn replace_triangles(
        &mut self,
        ctx: &GpuContext,
        first: usize,
        tris: &[VoxelTriangle],
    ) -> Result<Vec<UpdateBox>> {
        if first
            .checked_add(tris.len())
            .is_none_or(|end| end > self.scene.len())
        {
            return Err(Error::InvalidArgument(format!(
                "replacing triangles {first}..{} of a clipmap scene of {}",
                first.saturating_add(tris.len()),
                self.scene.len()
            )));
        }
        let union = |tris: &[VoxelTriangle]| {
            let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
            for t in tris {
                if t.positions.iter().all(|p| p.is_finite()) {
                    for p in t.positions {
                        lo = lo.min(p);
                        hi = hi.max(p);
                    }
                }
            }
            (lo, hi)
        };
        let (old_lo, old_hi) = union(&self.scene[first..first + tris.len()]);
        let (new_lo, new_hi) = union(tris);
        self.replace_range(ctx, first, tris);
        let mut boxes = Vec::new();
        for (lo, hi) in [(old_lo, old_hi), (new_lo, new_hi)] {
            if lo.cmple(hi).all() {
                boxes.extend(self.boxes_touching(lo, hi));
            }
        }
        self.pending.extend_from_slice(&boxes);
        Ok(boxes)
    }

    /// Writes triangles `first..` of the scene on the CPU, in the index and on the GPU.
    fn replace_range(&mut self, ctx: &GpuContext, first: usize, tris: &[VoxelTriangle]) {
        if tris.is_empty() {
            return;
        }
        let clock = std::time::Instant::now();
        self.scene[first..first + tris.len()].copy_from_slice(tris);
        self.index.replace(first, tris);
        let gpu: Vec<crate::voxel::GpuTriangle> = tris.iter().map(VoxelTriangle::to_gpu).collect();
        ctx.queue.write_buffer(
            &self.triangles,
            first as u64 * 64,
            bytemuck::cast_slice(&gpu),
        );
        self.acc.upload_bytes += tris.len() as u64 * 64;
        self.acc.upload_ms += clock.elapsed().as_secs_f64() * 1e3;
    }

    /// Makes `tris` the scene: nothing when it is the scene already, the differing range when
    /// that is at most a quarter of it, else [`Clipmap::set_scene`].
    fn sync_scene(&mut self, ctx: &GpuContext, tris: &[VoxelTriangle]) {
        if self.has_scene && tris.len() == self.scene.len() {
            let clock = std::time::Instant::now();
            let same = |(a, b): (&VoxelTriangle, &VoxelTriangle)| same_triangle(a, b);
            let first = self.scene.iter().zip(tris).position(|p| !same(p));
            self.acc.snap_ms += clock.elapsed().as_secs_f64() * 1e3;
            let Some(first) = first else {
                return;
            };
            let last = tris.len()
                - 1
                - self
                    .scene
                    .iter()
                    .rev()
                    .zip(tris.iter().rev())
                    .position(|p| !same(p))
                    .unwrap_or(0);
            if last + 1 - first <= tris.len() / 4 {
                self.replace_range(ctx, first, &tris[first..=last]);
                return;
            }
        }
        self.set_scene(ctx, tris);
    }

    /// The boxes of every level that cover the world-space box `[lo, hi]` (with one voxel of
    /// margin, since touching counts), clipped to each level's current extent. For a moving
    /// object, revoxelise the boxes of its old and of its new bounds (or use
    /// [`Clipmap::replace_triangles`], which does).
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
    /// region a moving object left and entered ([`Clipmap::boxes_touching`]), with `tris` as
    /// the scene (see [`Clipmap::update`]), and the boxes [`Clipmap::replace_triangles`]
    /// queued. A filtered clipmap then rebuilds every coarser level's voxels inside the finer
    /// level, finest first.
    ///
    /// An update writes its triangle pieces, work items and box parameters into scratch
    /// buffers kept across updates (ledger: `clipmap / triangle pieces`, `work items`, `box
    /// params`; grown on demand up to [`SCRATCH_KEEP`] bytes each, larger updates such as a
    /// first build use buffers of their own) with [`wgpu::Queue::write_buffer`], which takes
    /// effect at the next submission. Several updates recorded into one frame (`timer`) use
    /// successive regions, so none overwrites data an earlier one's passes still read.
    pub fn revoxelise(
        &mut self,
        ctx: &GpuContext,
        timer: &mut PassTimer,
        tris: &[VoxelTriangle],
        boxes: &[UpdateBox],
    ) -> Result<()> {
        self.sync_scene(ctx, tris);
        self.revoxelise_boxes(ctx, timer, boxes)
    }

    /// A scratch region of `bytes` for `which`, and its offset: in the kept buffer after what
    /// updates since the last submission of `timer` took (a new, larger kept buffer when that
    /// does not fit, up to [`SCRATCH_KEEP`]); a buffer of this update's own above (in the
    /// ledger as `... (one update)` until the next update).
    fn scratch(
        &mut self,
        ctx: &GpuContext,
        timer: &PassTimer,
        which: usize,
        bytes: u64,
    ) -> (wgpu::Buffer, u64) {
        const ONE_OFF: [&str; 3] = [
            "triangle pieces (one update)",
            "work items (one update)",
            "box params (one update)",
        ];
        let bytes = bytes.max(256).next_multiple_of(256);
        let desc = |size| wgpu::BufferDescriptor {
            label: Some(SCRATCH_NAMES[which]),
            size,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        };
        // Recorded while it lives (until the next update).
        let one_off = ONE_OFF[which];
        if bytes > SCRATCH_KEEP {
            let buffer = ctx.create_buffer(
                self.owner,
                &wgpu::BufferDescriptor {
                    label: Some(one_off),
                    ..desc(bytes)
                },
            );
            return (buffer, 0);
        }
        ctx.ledger.forget(self.owner, one_off);
        if self.scratch_use.0 != Some(timer.submissions()) {
            self.scratch_use = (Some(timer.submissions()), [0; 3]);
        }
        let used = self.scratch_use.1[which];
        match &self.scratch[which] {
            Some(b) if b.size() >= used + bytes => {
                self.scratch_use.1[which] = used + bytes;
                (b.clone(), used)
            }
            _ => {
                // A new buffer (the old one lives on while recorded passes use it), with room
                // for growth: a quarter more, within the cap, and never smaller than the old
                // one (which was too small only for this submission's updates together).
                let old = self.scratch[which].as_ref().map_or(0, |b| b.size());
                let size = (bytes + bytes / 4)
                    .next_multiple_of(256)
                    .min(SCRATCH_KEEP)
                    .max(old);
                let buffer = ctx.create_buffer(self.owner, &desc(size));
                self.scratch[which] = Some(buffer.clone());
                self.scratch_use.1[which] = bytes;
                (buffer, 0)
            }
        }
    }

    fn revoxelise_boxes(
        &mut self,
        ctx: &GpuContext,
        timer: &mut PassTimer,
        boxes: &[UpdateBox],
    ) -> Result<()> {
        let res = self.settings.resolution as u64;
        let resi = res as i32;
        // Boxes queued by moving objects, clipped to the levels' current extents.
        let mut all = boxes.to_vec();
        for b in std::mem::take(&mut self.pending) {
            let Some(o) = self.origins[b.level as usize] else {
                continue;
            };
            let c = UpdateBox {
                level: b.level,
                lo: b.lo.max(o),
                hi: b.hi.min(o + IVec3::splat(resi)),
            };
            if (c.hi - c.lo).cmpgt(IVec3::ZERO).all() {
                all.push(c);
            }
        }
        self.revoxelised.clone_from(&all);
        let boxes = &all[..];
        let mut stats = std::mem::take(&mut self.acc);
        if boxes.is_empty() {
            self.stats = stats;
            return Ok(());
        }
        let slice = (res * res).max(1);
        let max_depth = (self.accum.size() / (ACCUM_WORDS * 4) / slice).max(1) as i32;
        let mut parts = Vec::new();
        for b in boxes {
            let mut z = b.lo.z;
            while z < b.hi.z {
                let part = UpdateBox {
                    level: b.level,
                    lo: IVec3::new(b.lo.x, b.lo.y, z),
                    hi: IVec3::new(b.hi.x, b.hi.y, (z + max_depth).min(b.hi.z)),
                };
                z = part.hi.z;
                if part.volume() > 0 {
                    parts.push(part);
                }
            }
        }
        // Find (index), snap and split the triangles near each part, in parallel; pieces come
        // triangle after triangle in increasing order, as snapping all triangles gives them.
        let clock = std::time::Instant::now();
        let (scene, index, settings) = (&self.scene, &self.index, &self.settings);
        let snapped: Vec<(Vec<Piece>, Vec<[u32; 2]>, usize)> = parts
            .par_iter()
            .map(|part| {
                let region = SnapRegion {
                    origin: Vec3::ZERO,
                    voxel_size: settings.level_voxel(part.level),
                    lo: part.lo,
                    hi: part.hi,
                };
                // A voxel of margin (snapping drops whatever keeps 2/64 voxel away), widened
                // for the rounding of the bounds to f32.
                let v = region.voxel_size as f64;
                let (lo, hi) = (part.lo.as_dvec3() * v, part.hi.as_dvec3() * v);
                let margin = DVec3::splat(v) + lo.abs().max(hi.abs()) * 1e-6;
                let mut ids = Vec::new();
                index.query((lo - margin).as_vec3(), (hi + margin).as_vec3(), &mut ids);
                let mut pieces = Vec::new();
                for &t in &ids {
                    snap_triangle(&region, scene[t as usize].positions, t, &mut pieces);
                }
                let items = work_items(&pieces, region.size());
                (pieces, items, ids.len())
            })
            .collect();
        // One block per part in each scratch buffer, at offsets a storage binding accepts.
        let mut layout = Vec::with_capacity(parts.len());
        let (mut n_pieces, mut n_items) = (0u64, 0u64);
        for (pieces, items, _) in &snapped {
            layout.push((n_pieces, n_items));
            n_pieces += (pieces.len().max(1) as u64).next_multiple_of(PIECE_ALIGN);
            n_items += (items.len().max(1) as u64).next_multiple_of(ITEM_ALIGN);
        }
        let mut gpu_pieces = vec![GpuPiece::zeroed(); n_pieces as usize];
        let mut gpu_items = vec![[0u32; 2]; n_items as usize];
        let mut gpu_params = vec![0u8; parts.len() * PARAM_STRIDE as usize];
        for (i, (part, (pieces, items, candidates))) in parts.iter().zip(&snapped).enumerate() {
            let (p0, i0) = layout[i];
            for (k, p) in pieces.iter().enumerate() {
                gpu_pieces[p0 as usize + k] = p.to_gpu();
            }
            gpu_items[i0 as usize..i0 as usize + items.len()].copy_from_slice(items);
            let params = VoxParams {
                lo: part.lo.extend(0).to_array(),
                hi: part.hi.extend(0).to_array(),
                misc: [
                    items.len() as u32,
                    (part.level as u64 * res * res * res) as u32,
                    res as u32,
                    0,
                ],
            };
            let at = i * PARAM_STRIDE as usize;
            gpu_params[at..at + std::mem::size_of::<VoxParams>()]
                .copy_from_slice(bytemuck::bytes_of(&params));
            stats.parts += 1;
            stats.triangles_snapped += *candidates as u64;
            stats.pieces += pieces.len() as u64;
            stats.work_items += items.len() as u64;
        }
        stats.snap_ms += clock.elapsed().as_secs_f64() * 1e3;
        let clock = std::time::Instant::now();
        let piece_bytes: &[u8] = bytemuck::cast_slice(&gpu_pieces);
        let item_bytes: &[u8] = bytemuck::cast_slice(&gpu_items);
        let (pieces_buffer, pieces_at) = self.scratch(ctx, timer, 0, piece_bytes.len() as u64);
        let (items_buffer, items_at) = self.scratch(ctx, timer, 1, item_bytes.len() as u64);
        let (params_buffer, params_at) = self.scratch(ctx, timer, 2, gpu_params.len() as u64);
        ctx.queue
            .write_buffer(&pieces_buffer, pieces_at, piece_bytes);
        ctx.queue.write_buffer(&items_buffer, items_at, item_bytes);
        ctx.queue
            .write_buffer(&params_buffer, params_at, &gpu_params);
        stats.upload_bytes += (piece_bytes.len() + item_bytes.len() + gpu_params.len()) as u64;
        stats.upload_ms += clock.elapsed().as_secs_f64() * 1e3;
        let clock = std::time::Instant::now();
        let piece_size = std::mem::size_of::<GpuPiece>() as u64;
        for (i, (part, (pieces, items, _))) in parts.iter().zip(&snapped).enumerate() {
            let (p0, i0) = layout[i];
            let params = (
                &params_buffer,
                params_at + i as u64 * PARAM_STRIDE,
                PARAM_STRIDE,
            );
            let name = format!("clipmap L{}", part.level);
            let group = bind_ranges(
                ctx,
                &self.accumulate,
                &[
                    (0, params),
                    (1, whole(&self.triangles)),
                    (
                        2,
                        (
                            &items_buffer,
                            items_at + i0 * 8,
                            items.len().max(1) as u64 * 8,
                        ),
                    ),
                    (3, whole(&self.accum)),
                    (
                        8,
                        (
                            &pieces_buffer,
                            pieces_at + p0 * piece_size,
                            pieces.len().max(1) as u64 * piece_size,
                        ),
                    ),
                ],
            );
            dispatch_1d(
                timer,
                &format!("{name} voxelize"),
                &self.accumulate,
                &group,
                items.len() as u32,
            );
            let group = bind_ranges(
                ctx,
                &self.resolve,
                &[
                    (0, params),
                    (3, whole(&self.accum)),
                    (4, whole(&self.voxels)),
                    (5, whole(&self.written)),
                    (6, whole(&self.normals)),
                    (7, whole(&self.emission)),
                ],
            );
            dispatch_1d(
                timer,
                &format!("{name} resolve"),
                &self.resolve,
                &group,
                part.volume() as u32,
            );
        }
        if self.options.filters() {
            self.filter_levels(ctx, timer, boxes);
        }
        stats.record_ms += clock.elapsed().as_secs_f64() * 1e3;
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
            self.owner,
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
        dispatch_1d(timer, name, pipeline, &group, b.volume() as u32);
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

    /// Every box (of its level, inside the level's extent) that the last [`Clipmap::update`],
    /// [`Clipmap::follow`] or [`Clipmap::revoxelise`] rewrote: the camera's exposed slabs and
    /// the regions moving objects left and entered. Whatever a caller keeps per voxel slot is
    /// stale there (a wrapped slot now holds another voxel, or the voxel changed).
    pub fn last_revoxelised(&self) -> &[UpdateBox] {
        &self.revoxelised
    }

    /// Multiple bounces: from now on both injections add `bounce` (per voxel slot, layout of
    /// [`Clipmap::voxels`], RGBA16F indirect irradiance in W/m^2, alpha unused; at least 8
    /// bytes per slot) to each voxel's direct irradiance, so its outgoing radiance is
    /// emission + albedo / pi x (direct + indirect). `None` stops it.
    pub fn set_bounce(&mut self, bounce: Option<wgpu::Buffer>) -> Result<()> {
        let res = self.settings.resolution as u64;
        let needed = self.settings.levels as u64 * res * res * res * 8;
        if let Some(b) = &bounce {
            if b.size() < needed {
                return Err(Error::InvalidArgument(format!(
                    "clipmap bounce buffer of {} bytes, {needed} needed",
                    b.size()
                )));
            }
        }
        self.bounce = bounce;
        Ok(())
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
        let room = (gpu.len() as u64).div_ceil(INJECT_LIGHT_ALIGN) * INJECT_LIGHT_ALIGN;
        if room > self.inject_light_room {
            self.inject_light_room = room;
            self.inject_lights = inject_light_buffer(ctx, self.owner, room);
        }
        let slot = self.inject_slot(timer)?;
        let slot_bytes = self.inject_light_room * INJECT_LIGHT_BYTES;
        ctx.queue.write_buffer(
            &self.inject_lights,
            slot * slot_bytes,
            bytemuck::cast_slice(&gpu),
        );
        let lights_buffer = self.inject_lights.clone();
        let lights_binding = wgpu::BindingResource::Buffer(wgpu::BufferBinding {
            buffer: &lights_buffer,
            offset: slot * slot_bytes,
            size: wgpu::BufferSize::new(gpu.len() as u64 * INJECT_LIGHT_BYTES),
        });
        let pipeline = match &self.inject {
            Some(p) => p.clone(),
            None => {
                let source = library_shader("voxel/clipmap/inject", &[]);
                let module = ctx.shader("clipmap inject", &source);
                let p = ctx.compute_pipeline("clipmap inject", &module, "inject");
                self.inject = Some(p.clone());
                p
            }
        };
        let params = [count, max_steps.clamp(1, 4096)];
        let lights_binding = [(3, lights_binding)];
        self.inject_with(ctx, timer, (0, slot), &pipeline, params, &lights_binding);
        Ok(())
    }

    /// Injects light as [`Clipmap::inject`] does, with visibility from the renderer's shadow
    /// maps instead of voxel shadow rays: the first `light_count` lights of `lights` (the
    /// renderer's light buffer, `array<Light>` of `frame/lights.wgsl`) and its shadow maps
    /// (`shadows`, [`crate::frame::ShadowMaps::lookup`]), looked up with the deferred lighting's PCF half a voxel off each voxel's centre along its normal.
    /// Every voxel costs one lookup per light instead of a march per light. The pass is
    /// `clipmap inject (shadow maps)`.
    pub fn inject_shadow_maps(
        &mut self,
        ctx: &GpuContext,
        timer: &mut PassTimer,
        lights: &wgpu::Buffer,
        light_count: u32,
        shadows: crate::frame::ShadowLookup<'_>,
    ) -> Result<()> {
        let needed = light_count as u64 * crate::frame::LIGHT_BYTES;
        if lights.size() < needed {
            return Err(Error::InvalidArgument(format!(
                "clipmap injection: {light_count} lights need a light buffer of {needed} \
                 bytes, it has {}",
                lights.size()
            )));
        }
        let pipeline = match &self.inject_shadow {
            Some(made) => made.clone(),
            None => {
                let label = "clipmap inject (shadow maps)";
                let source = library_shader("voxel/clipmap/inject_shadow", &[]);
                let module = ctx.shader(label, &source);
                let p = ctx.compute_pipeline(label, &module, "inject_shadow");
                self.inject_shadow = Some(p.clone());
                p
            }
        };
        let slot = self.inject_slot(timer)?;
        let lights = crate::frame::light_bindings(lights, shadows);
        self.inject_with(ctx, timer, (1, slot), &pipeline, [light_count, 0], &lights);
        Ok(())
    }

    /// The parameter slot of an injection recorded now: the next one of this submission.
    fn inject_slot(&mut self, timer: &PassTimer) -> Result<u64> {
        let submission = timer.submissions();
        let next = match self.inject_used {
            (s, used) if s == submission => used,
            _ => 0,
        };
        if next >= INJECT_SLOTS {
            return Err(Error::InvalidArgument(format!(
                "clipmap: more than {INJECT_SLOTS} light injections recorded before one \
                 submission (finish the frame between them)"
            )));
        }
        self.inject_used = (submission, next + 1);
        Ok(next)
    }

    /// One injection dispatch over every voxel slot: `kind` (0 voxel rays, 1 shadow maps)
    /// and `slot` choose the kept bind group and the parameter slot, `params` are the light
    /// count and the march's step limit, `extra` the variant's own bindings (its lights).
    fn inject_with(
        &mut self,
        ctx: &GpuContext,
        timer: &mut PassTimer,
        (kind, slot): (u64, u64),
        pipeline: &wgpu::ComputePipeline,
        params: [u32; 2],
        extra: &[(u32, wgpu::BindingResource)],
    ) {
        let name = ["clipmap inject", "clipmap inject (shadow maps)"][kind as usize];
        let res = self.settings.resolution as u64;
        let slots = (self.settings.levels as u64 * res * res * res) as u32;
        let params = [params[0], params[1], slots, self.bounce.is_some() as u32];
        let info = crate::voxel::clipmap::sample::ClipInfo::new(&self.settings, &self.origins);
        let [params_buffer, info_buffer] = &self.inject_params;
        let offset = slot * crate::gpu::pass::SLOT;
        ctx.queue
            .write_buffer(params_buffer, offset, bytemuck::cast_slice(&params));
        ctx.queue
            .write_buffer(info_buffer, offset, bytemuck::bytes_of(&info));
        let at = |buffer, size: usize| crate::gpu::pass::slot(buffer, slot, size as u64);
        let radiance = match self.radiance.take() {
            Some(r) => r,
            None => ctx.create_buffer(
                self.owner,
                &wgpu::BufferDescriptor {
                    label: Some("radiance"),
                    size: slots as u64 * 8,
                    usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                    mapped_at_creation: false,
                },
            ),
        };
        let mut entries: Vec<(u32, wgpu::BindingResource)> = [
            (2, &self.normals),
            (4, &radiance),
            (6, &self.emission),
            (10, self.bounce.as_ref().unwrap_or(&self.no_aniso)),
        ]
        .map(|(binding, buffer)| (binding, buffer.as_entire_binding()))
        .into();
        entries.extend([
            (5, at(params_buffer, std::mem::size_of_val(&params))),
            (CLIP_BINDINGS, at(info_buffer, std::mem::size_of_val(&info))),
            (CLIP_BINDINGS + 1, self.voxels.as_entire_binding()),
        ]);
        entries.extend(extra.iter().cloned());
        let kept = &self.inject_groups[(kind * INJECT_SLOTS + slot) as usize];
        let group = kept.get(ctx, name, pipeline, &entries);
        dispatch_1d(timer, name, pipeline, &group, slots);
        self.radiance = Some(radiance);
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
                let a = crate::gpu::pack::unpack_half2(w[0]);
                let b = crate::gpu::pack::unpack_half2(w[1]);
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

/// The injection's parameter buffers: the `InjectParams` block and the clipmap's `ClipInfo`,
/// [`INJECT_SLOTS`] slots of [`crate::gpu::pass::SLOT`] bytes each.
fn inject_param_buffers(ctx: &GpuContext, owner: &str) -> [wgpu::Buffer; 2] {
    ["inject params", "inject info"].map(|label| {
        ctx.create_buffer(
            owner,
            &wgpu::BufferDescriptor {
                label: Some(label),
                size: INJECT_SLOTS * crate::gpu::pass::SLOT,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            },
        )
    })
}

/// The voxel-ray injection's light buffer: [`INJECT_SLOTS`] slots of `room` lights.
fn inject_light_buffer(ctx: &GpuContext, owner: &str, room: u64) -> wgpu::Buffer {
    ctx.create_buffer(
        owner,
        &wgpu::BufferDescriptor {
            label: Some("inject lights"),
            size: INJECT_SLOTS * room * INJECT_LIGHT_BYTES,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        },
    )
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
