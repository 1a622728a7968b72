//! The common sampling interface of the voxel structures: "filtered value and opacity at
//! position `p` with footprint `d`", as WGSL that later techniques paste in front of their own
//! shaders ([`SVO_SAMPLE_WGSL`], [`CLIPMAP_SAMPLE_WGSL`]), with the parameter blocks it reads
//! ([`SvoInfo`], [`ClipInfo`]) and CPU twins ([`svo_sample`], [`clip_sample`]) for tests.
//!
//! Both return premultiplied RGB and opacity; the RGB is albedo. For the clipmap,
//! `clip_radiance_sample` ([`CLIPMAP_RADIANCE_WGSL`], CPU twin [`clip_radiance_sample`]) returns
//! the injected radiance the same way. The octree's anisotropic values are sampled by
//! `svo_sample_aniso` ([`super::svo::aniso::SVO_ANISO_SAMPLE_WGSL`], CPU twin
//! [`svo_sample_aniso`]).
//!
//! - Octree: the level whose lattice spacing matches the footprint (quadrilinear between two
//!   levels), trilinear inside the brick of the node containing `p`; zero where no node exists.
//! - Clipmap: the finest level whose voxel is at least the footprint and which holds `p`'s
//!   whole trilinear neighbourhood; a level that does not contain `p` is never read.

use super::clipmap::ClipmapSettings;
use super::svo::{unpack_unorm8, SvoCpu};
use super::VoxelGrid;
use glam::{IVec3, UVec3, Vec3, Vec4};

/// WGSL: `svo_sample(p, footprint)`; the includer declares `svo_info`, `svo_child`,
/// `svo_bricks0..3`, `svo_brick_index` (see the file's header).
pub const SVO_SAMPLE_WGSL: &str = include_str!("svo/sample.wgsl");
/// WGSL: `clip_sample(p, footprint)`; the includer declares `clip_info`, `clip_voxels`.
pub const CLIPMAP_SAMPLE_WGSL: &str = include_str!("clipmap/sample.wgsl");
/// WGSL: `clip_radiance_sample(p, footprint)` over the injected radiance; goes after
/// [`CLIPMAP_SAMPLE_WGSL`]; the includer also declares `clip_radiance`.
pub const CLIPMAP_RADIANCE_WGSL: &str = include_str!("clipmap/radiance_sample.wgsl");

/// Parameter block `SvoInfo` of [`SVO_SAMPLE_WGSL`] (a read-only storage buffer).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct SvoInfo {
    /// Grid origin (xyz) and voxel size (w).
    pub origin: [f32; 4],
    /// Depth, resolution, bricks per pool buffer, unused.
    pub misc: [u32; 4],
}

impl SvoInfo {
    /// The block for an octree over `grid` whose brick pool holds `pool_bricks` bricks per
    /// buffer ([`super::svo::Svo::pool_bricks`]).
    pub fn new(grid: &VoxelGrid, pool_bricks: u32) -> SvoInfo {
        SvoInfo {
            origin: grid.origin.extend(grid.voxel_size).to_array(),
            misc: [grid.depth(), grid.resolution, pool_bricks.max(1), 0],
        }
    }
}

/// Parameter block `ClipInfo` of [`CLIPMAP_SAMPLE_WGSL`] (a read-only storage buffer).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ClipInfo {
    /// Finest voxel size (x).
    pub voxel: [f32; 4],
    /// Resolution, levels.
    pub misc: [u32; 4],
    /// First voxel of each level.
    pub origins: [[i32; 4]; 8],
}

impl ClipInfo {
    /// The block for a clipmap with these settings and level origins (levels without an
    /// origin are treated as empty by placing them far away).
    pub fn new(settings: &ClipmapSettings, origins: &[Option<IVec3>]) -> ClipInfo {
        let mut o = [[i32::MIN / 2; 4]; 8];
        for (slot, origin) in o.iter_mut().zip(origins) {
            if let Some(origin) = origin {
                *slot = origin.extend(0).to_array();
            }
        }
        ClipInfo {
            voxel: [settings.voxel_size, 0.0, 0.0, 0.0],
            misc: [settings.resolution, settings.levels, 0, 0],
            origins: o,
        }
    }
}

fn trilinear(f: Vec3, mut texel: impl FnMut(UVec3) -> Vec4) -> Vec4 {
    let mut sum = Vec4::ZERO;
    for k in 0..8u32 {
        let o = UVec3::new(k & 1, (k >> 1) & 1, (k >> 2) & 1);
        let w = Vec3::select(o.cmpeq(UVec3::ONE), f, Vec3::ONE - f);
        sum += w.x * w.y * w.z * texel(o);
    }
    sum
}

/// CPU twin of `svo_sample_level`: level `d` at grid position `g` (voxel units).
pub fn svo_sample_level(svo: &SvoCpu, depth: u32, g: Vec3, d: u32) -> Vec4 {
    let x = g / (1u32 << (depth - 1 - d)) as f32;
    let size = 1u32 << d;
    if x.cmplt(Vec3::ZERO).any() || x.cmpgt(Vec3::splat(2.0 * size as f32)).any() {
        return Vec4::ZERO;
    }
    let c = (x * 0.5).as_uvec3().min(UVec3::splat(size - 1));
    let mut node = 0u32;
    for l in 0..d {
        let first = svo.child[node as usize];
        if first == 0 {
            return Vec4::ZERO;
        }
        let s = d - 1 - l;
        node = first + ((c.x >> s) & 1) + (((c.y >> s) & 1) << 1) + (((c.z >> s) & 1) << 2);
    }
    let b = svo.brick_of[node as usize];
    if b == 0 {
        return Vec4::ZERO;
    }
    let local = (x - 2.0 * c.as_vec3()).clamp(Vec3::ZERO, Vec3::splat(2.0));
    let i0 = local.as_uvec3().min(UVec3::ONE);
    let f = local - i0.as_vec3();
    let brick = &svo.bricks[b as usize - 1];
    trilinear(f, |o| {
        let t = i0 + o;
        brick[(t.x + 3 * t.y + 9 * t.z) as usize]
    })
}

/// CPU twin of `svo_sample`.
pub fn svo_sample(svo: &SvoCpu, grid: &VoxelGrid, p: Vec3, footprint: f32) -> Vec4 {
    let depth = grid.depth();
    let g = (p - grid.origin) / grid.voxel_size;
    let lod = (footprint / grid.voxel_size)
        .max(1.0)
        .log2()
        .clamp(0.0, (depth - 1) as f32);
    let fine = depth - 1 - lod.floor() as u32;
    let t = lod - lod.floor();
    let a = svo_sample_level(svo, depth, g, fine);
    if t <= 0.0 || fine == 0 {
        return a;
    }
    a.lerp(svo_sample_level(svo, depth, g, fine - 1), t)
}

/// Brick index + 1 of the node of level `d` at node coordinates `c` (0 where no node exists
/// or it has no brick), found by walking down from the root.
pub fn svo_node_brick(svo: &SvoCpu, c: IVec3, d: u32) -> u32 {
    let size = 1i32 << d;
    if c.cmplt(IVec3::ZERO).any() || c.cmpge(IVec3::splat(size)).any() {
        return 0;
    }
    let c = c.as_uvec3();
    let mut node = 0u32;
    for l in 0..d {
        let first = svo.child[node as usize];
        if first == 0 {
            return 0;
        }
        let s = d - 1 - l;
        node = first + ((c.x >> s) & 1) + (((c.y >> s) & 1) << 1) + (((c.z >> s) & 1) << 2);
    }
    svo.brick_of[node as usize]
}

/// CPU twin of `svo_node_cell` + the per-node value: node-centred trilinear interpolation of
/// `value(brick index + 1)` over the nodes of level `d` around grid position `g` (voxels);
/// zero where no node or brick exists.
fn svo_node_level(svo: &SvoCpu, depth: u32, g: Vec3, d: u32, value: impl Fn(u32) -> Vec4) -> Vec4 {
    let x = g / (1u32 << (depth - d)) as f32 - Vec3::splat(0.5);
    if x.cmplt(Vec3::splat(-1.0)).any() || x.cmpgt(Vec3::splat((1u32 << d) as f32)).any() {
        return Vec4::ZERO;
    }
    let i0 = x.floor().as_ivec3();
    let f = x - x.floor();
    trilinear(f, |o| match svo_node_brick(svo, i0 + o.as_ivec3(), d) {
        0 => Vec4::ZERO,
        b => value(b),
    })
}

/// CPU twin of `svo_faces`: the faces (+x, -x, +y, -y, +z, -z = 0..5) a cone travelling along
/// `dir` enters a node through, and their weights |dir| normalised to sum to one.
fn svo_faces(dir: Vec3) -> ([usize; 3], Vec3) {
    let a = dir.abs();
    let faces = [
        if dir.x >= 0.0 { 0 } else { 1 },
        if dir.y >= 0.0 { 2 } else { 3 },
        if dir.z >= 0.0 { 4 } else { 5 },
    ];
    (faces, a / (a.x + a.y + a.z).max(1e-20))
}

/// CPU twin of `svo_aniso_level`: node-centred trilinear sample of level `d`'s directional
/// values `aniso` (per brick, [`super::svo::aniso::SvoAnisoValues::read_back`]) at grid
/// position `g` (voxels), seen travelling along `dir`.
pub fn svo_aniso_level(
    svo: &SvoCpu,
    aniso: &[[u32; 6]],
    depth: u32,
    g: Vec3,
    d: u32,
    dir: Vec3,
) -> Vec4 {
    let (faces, w) = svo_faces(dir);
    svo_node_level(svo, depth, g, d, |b| {
        let v = &aniso[b as usize - 1];
        (0..3).map(|a| w[a] * unpack_unorm8(v[faces[a]])).sum()
    })
}

/// CPU twin of `svo_radiance_aniso` ([`super::svo::aniso_radiance::SVO_RADIANCE_ANISO_WGSL`]):
/// the anisotropic radiance `values` (per brick,
/// [`super::svo::aniso_radiance::SvoAnisoRadiance::read_back`]) of the level whose node size
/// matches `footprint` (two finest voxels or more; the finest level below), quadrilinear
/// between two levels, seen travelling along `dir`.
pub fn svo_radiance_aniso(
    svo: &SvoCpu,
    values: &[[Vec4; 6]],
    grid: &VoxelGrid,
    p: Vec3,
    footprint: f32,
    dir: Vec3,
) -> Vec4 {
    let depth = grid.depth();
    let g = (p - grid.origin) / grid.voxel_size;
    let (faces, w) = svo_faces(dir);
    let level = |d: u32| {
        svo_node_level(svo, depth, g, d, |b| {
            let v = &values[b as usize - 1];
            (0..3).map(|a| w[a] * v[faces[a]]).sum()
        })
    };
    node_levels(grid, footprint, level)
}

/// CPU twin of `svo_node_lod`'s level choice at two finest voxels and more: `level(d)` of the
/// level whose node size matches `footprint` (the finest below two voxels), quadrilinear
/// towards the next coarser one.
fn node_levels(grid: &VoxelGrid, footprint: f32, level: impl Fn(u32) -> Vec4) -> Vec4 {
    let depth = grid.depth();
    let s = (footprint / grid.voxel_size).max(1.0).log2();
    let lod = (s - 1.0).clamp(0.0, (depth - 1) as f32);
    let fine = depth - 1 - lod.floor() as u32;
    let t = lod - lod.floor();
    let a = level(fine);
    if t <= 0.0 || fine == 0 {
        return a;
    }
    a.lerp(level(fine - 1), t)
}

/// CPU twin of `svo_sample_aniso` ([`super::svo::aniso::SVO_ANISO_SAMPLE_WGSL`]): the
/// directional values of the level whose node size matches `footprint` (quadrilinear between
/// two levels), seen travelling along `dir`; below two voxels a blend from the isotropic
/// [`svo_sample`] (one voxel) to the finest directional level (two voxels).
pub fn svo_sample_aniso(
    svo: &SvoCpu,
    aniso: &[[u32; 6]],
    grid: &VoxelGrid,
    p: Vec3,
    footprint: f32,
    dir: Vec3,
) -> Vec4 {
    let depth = grid.depth();
    let g = (p - grid.origin) / grid.voxel_size;
    let level = |d: u32| svo_aniso_level(svo, aniso, depth, g, d, dir);
    let s = (footprint / grid.voxel_size).max(1.0).log2();
    if s < 1.0 {
        let iso = svo_sample(svo, grid, p, footprint);
        if s <= 0.0 {
            return iso;
        }
        return iso.lerp(level(depth - 1), s);
    }
    node_levels(grid, footprint, level)
}

fn clip_voxel(voxels: &[u32], res: u32, l: u32, g: IVec3) -> Vec4 {
    let r = res as i32;
    let m = g.rem_euclid(IVec3::splat(r)).as_uvec3();
    let w = voxels[(l * res * res * res + m.x + res * (m.y + res * m.z)) as usize];
    Vec4::new(
        (w & 255) as f32 / 255.0,
        ((w >> 8) & 255) as f32 / 255.0,
        ((w >> 16) & 255) as f32 / 255.0,
        (w >> 24) as f32 / 255.0,
    )
}

fn clip_contains(info: &ClipInfo, p: Vec3, l: u32) -> bool {
    let g = p / (info.voxel[0] * (1u32 << l) as f32) - 0.5;
    let o = info.origins[l as usize];
    let lo = Vec3::new(o[0] as f32, o[1] as f32, o[2] as f32);
    g.cmpge(lo).all() && g.cmplt(lo + Vec3::splat(info.misc[0] as f32 - 1.0)).all()
}

fn clip_sample_level(
    info: &ClipInfo,
    p: Vec3,
    l: u32,
    fetch: &impl Fn(u32, IVec3) -> Vec4,
) -> Vec4 {
    let g = p / (info.voxel[0] * (1u32 << l) as f32) - 0.5;
    let i0 = g.floor().as_ivec3();
    let f = g - g.floor();
    trilinear(f, |o| fetch(l, i0 + o.as_ivec3()))
}

/// CPU twin of `clip_sample`, over voxels read back with
/// [`super::clipmap::Clipmap::read_voxels`].
pub fn clip_sample(info: &ClipInfo, voxels: &[u32], p: Vec3, footprint: f32) -> Vec4 {
    clip_sample_with(info, p, footprint, &|l, g| {
        clip_voxel(voxels, info.misc[0], l, g)
    })
}

/// CPU twin of `clip_radiance_sample`, over radiance read back with
/// [`super::clipmap::Clipmap::read_radiance`].
pub fn clip_radiance_sample(info: &ClipInfo, radiance: &[Vec4], p: Vec3, footprint: f32) -> Vec4 {
    let res = info.misc[0];
    clip_sample_with(info, p, footprint, &|l, g| {
        let m = g.rem_euclid(IVec3::splat(res as i32)).as_uvec3();
        radiance[(l * res * res * res + m.x + res * (m.y + res * m.z)) as usize]
    })
}

fn clip_sample_with(
    info: &ClipInfo,
    p: Vec3,
    footprint: f32,
    fetch: &impl Fn(u32, IVec3) -> Vec4,
) -> Vec4 {
    let levels = info.misc[1];
    let lod = (footprint / info.voxel[0])
        .max(1.0)
        .log2()
        .clamp(0.0, (levels - 1) as f32);
    let mut l = lod.floor() as u32;
    while l < levels && !clip_contains(info, p, l) {
        l += 1;
    }
    if l >= levels {
        return Vec4::ZERO;
    }
    let a = clip_sample_level(info, p, l, fetch);
    let t = lod - lod.floor();
    if t <= 0.0 || l as f32 > lod.floor() || l + 1 >= levels || !clip_contains(info, p, l + 1) {
        return a;
    }
    a.lerp(clip_sample_level(info, p, l + 1, fetch), t)
}

/// Runs a `probe` kernel (`source`, one invocation per point, 64 wide) that samples a voxel
/// structure at `points` travelling along `dirs`: `fixed` are the structure's bindings, and the
/// points, directions and an output of one `vec4<f32>` per point follow at the next three
/// bindings. Returns the samples (GPU side of the CPU-twin tests).
pub(crate) fn run_directional_probe(
    ctx: &crate::gpu::GpuContext,
    owner: &str,
    source: &str,
    fixed: &[(u32, &wgpu::Buffer)],
    points: &[Vec4],
    dirs: &[Vec4],
) -> crate::Result<Vec<Vec4>> {
    let module = ctx.shader(owner, source);
    let pipeline = ctx.compute_pipeline(owner, &module, "probe");
    let storage = wgpu::BufferUsages::STORAGE;
    let input = ctx.create_buffer_init(owner, "points", bytemuck::cast_slice(points), storage);
    let dir_buffer =
        ctx.create_buffer_init(owner, "directions", bytemuck::cast_slice(dirs), storage);
    let n = points.len() as u64;
    let out = ctx.create_buffer(
        owner,
        &wgpu::BufferDescriptor {
            label: Some("samples"),
            size: (n * 16).max(16),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        },
    );
    let next = fixed.len() as u32;
    let mut buffers = fixed.to_vec();
    buffers.extend([(next, &input), (next + 1, &dir_buffer), (next + 2, &out)]);
    let group = super::voxelize::bind_buffers(ctx, &pipeline, &buffers);
    let mut timer = crate::gpu::PassTimer::new(ctx);
    timer.pass(owner, |encoder, stamps| {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(owner),
            timestamp_writes: stamps.compute(),
        });
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &group, &[]);
        pass.dispatch_workgroups((n as u32).div_ceil(64), 1, 1);
    });
    timer.finish_frame()?;
    let bytes = crate::gpu::read_buffer(ctx, &out, 0, n * 16)?;
    Ok(bytemuck::cast_slice::<u8, Vec4>(&bytes).to_vec())
}
