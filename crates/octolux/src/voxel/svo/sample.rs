//! Sampling the octree: the WGSL module `voxel/svo/sample` (`svo_sample(p, footprint)`; its
//! siblings `radiance_sample`, `sample_aniso` and `radiance_sample_aniso` sample the other
//! payloads) with its parameter block ([`SvoInfo`]), the bind-group entries of its bindings
//! ([`svo_bindings`] and the functions after it) and CPU twins ([`svo_sample`]; the
//! anisotropic values' [`svo_sample_aniso`] and [`svo_radiance_aniso`]).
//!
//! The level whose lattice spacing matches the footprint (quadrilinear between two levels),
//! trilinear inside the brick of the node containing `p`; zero where no node exists.

use super::{Svo, SvoCpu};
use crate::gpu::pack::unpack_unorm8;
use crate::voxel::sample::trilinear;
use crate::voxel::VoxelGrid;
use glam::{IVec3, UVec3, Vec3, Vec4};

/// First binding (group 0) of the octree's samplers: `svo_info`, `svo_child`,
/// `svo_brick_index`, then the albedo pool `svo_bricks0..3` ([`svo_bindings`],
/// [`svo_albedo_bindings`]).
pub const SVO_BINDINGS: u32 = 50;
/// The radiance sampler's `svo_radiance0..3` ([`svo_radiance_bindings`]).
pub const SVO_RADIANCE_BINDINGS: u32 = 57;
/// The anisotropic albedo sampler's values (`svo_aniso`).
pub const SVO_ANISO_BINDING: u32 = 61;
/// The anisotropic radiance sampler's values (`svo_aniso_radiance`).
pub const SVO_ANISO_RADIANCE_BINDING: u32 = 62;
/// The facing sampler's `svo_facing0..3` ([`svo_facing_bindings`]).
pub const SVO_FACING_BINDINGS: u32 = 68;

/// The entries every octree sampler reads: `info` (an [`SvoInfo`] block), `svo`'s child links
/// and brick of each node.
pub fn svo_bindings<'a>(
    info: &'a wgpu::Buffer,
    svo: &'a Svo,
) -> [(u32, wgpu::BindingResource<'a>); 3] {
    let buffers = [info, &svo.child, &svo.brick_plus_one];
    std::array::from_fn(|i| (SVO_BINDINGS + i as u32, buffers[i].as_entire_binding()))
}

/// The albedo pool's four buffers, for `svo_sample`.
pub fn svo_albedo_bindings(svo: &Svo) -> [(u32, wgpu::BindingResource<'_>); 4] {
    std::array::from_fn(|i| {
        (
            SVO_BINDINGS + 3 + i as u32,
            svo.bricks[i].as_entire_binding(),
        )
    })
}

/// The injected radiance's four buffers, for `svo_radiance_sample`.
pub fn svo_radiance_bindings(svo: &Svo) -> [(u32, wgpu::BindingResource<'_>); 4] {
    std::array::from_fn(|i| {
        (
            SVO_RADIANCE_BINDINGS + i as u32,
            svo.radiance[i].as_entire_binding(),
        )
    })
}

/// The facing pool's 4 buffers at [`SVO_FACING_BINDINGS`].., for `svo_radiance_facing_sample`
/// (`voxel/svo/radiance_sample.wgsl`); `None` for an octree built without facing
/// ([`crate::voxel::svo::SvoBuilder::with_facing`]).
pub fn svo_facing_bindings(svo: &Svo) -> Option<[(u32, wgpu::BindingResource<'_>); 4]> {
    let facing = svo.facing.as_ref()?;
    Some(std::array::from_fn(|i| {
        (
            SVO_FACING_BINDINGS + i as u32,
            facing[i].as_entire_binding(),
        )
    }))
}

/// Parameter block `SvoInfo` of `voxel/svo/sample.wgsl` (a read-only storage buffer): the
/// octree's grid and brick pool.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct SvoInfo {
    /// The grid's origin (metres).
    pub origin: [f32; 3],
    /// The grid's voxel size (metres).
    pub voxel_size: f32,
    /// Levels of the octree.
    pub depth: u32,
    /// Voxels per axis of the grid.
    pub resolution: u32,
    /// Bricks per pool buffer.
    pub pool_bricks: u32,
    pub _pad: u32,
}

impl SvoInfo {
    /// The block for an octree over `grid` whose brick pool holds `pool_bricks` bricks per
    /// buffer ([`super::Svo::pool_bricks`]).
    pub fn new(grid: &VoxelGrid, pool_bricks: u32) -> SvoInfo {
        SvoInfo {
            origin: grid.origin.to_array(),
            voxel_size: grid.voxel_size,
            depth: grid.depth(),
            resolution: grid.resolution,
            pool_bricks: pool_bricks.max(1),
            _pad: 0,
        }
    }
}

/// CPU twin of one level of `svo_sample` (`svo_locate_levels`, `svo_sample_cell`): level `d`
/// at grid position `g` (voxel units).
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
/// values `aniso` (per brick, [`super::aniso::SvoAnisoValues::read_back`]) at grid
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

/// CPU twin of `svo_radiance_aniso` (`voxel/svo/radiance_sample_aniso.wgsl`):
/// the anisotropic radiance `values` (per brick,
/// [`super::aniso_radiance::SvoAnisoRadiance::read_back`]) of the level whose node size
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

/// CPU twin of `svo_sample_aniso` (`voxel/svo/sample_aniso.wgsl`): the
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
