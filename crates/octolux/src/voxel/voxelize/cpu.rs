//! The voxelizer on the CPU: the same conservative coverage as the GPU kernels (through the
//! same snapped pieces), the averaged voxel values, and the voxels' packed words. The dynamic
//! octree builds its small objects with it every frame; the tests compare the GPU with it.

use super::snap::{piece_voxels, snap_triangles, SnapRegion};
use crate::voxel::pairs::pack_u8;
use crate::voxel::{VoxelGrid, VoxelTriangle};
use glam::{IVec3, Vec3, Vec4};
use std::collections::BTreeMap;

/// Grid coordinates of `p` in `f32` (for tests that sample the geometry; the voxelizer snaps in
/// `f64`, [`super::snap`]).
pub fn to_grid(p: Vec3, grid: &VoxelGrid) -> Vec3 {
    let inv = 1.0 / grid.voxel_size;
    Vec3::new(
        (p.x - grid.origin.x) * inv,
        (p.y - grid.origin.y) * inv,
        (p.z - grid.origin.z) * inv,
    )
}

/// The voxel fragment list the GPU voxelizer produces, in the same order: per snapped piece
/// of each triangle ([`snap_triangles`]), the touched voxels of its cell range in z, y, x loop
/// order, by the same integer test ([`super::snap::PieceTest`]).
pub fn voxelize(grid: &VoxelGrid, tris: &[VoxelTriangle]) -> Vec<([u32; 3], u32)> {
    let region = SnapRegion {
        origin: grid.origin,
        voxel_size: grid.voxel_size,
        lo: IVec3::ZERO,
        hi: IVec3::splat(grid.resolution as i32),
    };
    snap_triangles(&region, tris)
        .iter()
        .flat_map(|p| {
            piece_voxels(p, region.size())
                .into_iter()
                .map(move |v| (v.as_uvec3().to_array(), p.triangle))
        })
        .collect()
}

/// Premultiplied albedo and opacity of every occupied voxel: the mean of the albedo of the
/// fragments in it (as the GPU computes it: integer sums, then one division), opacity 1.
pub fn voxel_values(
    fragments: &[([u32; 3], u32)],
    tris: &[VoxelTriangle],
) -> BTreeMap<[u32; 3], Vec4> {
    let mut sums: BTreeMap<[u32; 3], [u32; 4]> = BTreeMap::new();
    for &(v, t) in fragments {
        let s = sums.entry(v).or_default();
        let albedo = tris[t as usize].albedo;
        for (i, a) in albedo.iter().enumerate() {
            s[i] += *a as u32;
        }
        s[3] += 1;
    }
    sums.into_iter().map(|(v, s)| (v, voxel_value(s))).collect()
}

/// One voxel's value from its integer sums (r, g, b, count), as the GPU computes it.
pub fn voxel_value(s: [u32; 4]) -> Vec4 {
    if s[3] == 0 {
        return Vec4::ZERO;
    }
    let n = s[3] as f32;
    Vec4::new(
        s[0] as f32 / n / 255.0,
        s[1] as f32 / n / 255.0,
        s[2] as f32 / n / 255.0,
        1.0,
    )
}

/// Per occupied voxel, its RGBA8 word: the rounded integer mean of its fragments' albedo,
/// alpha 255 (`leaf_voxel` in `svo/aniso.wgsl`, which reads the octree's leaf sums).
pub fn voxel_words(
    fragments: &[([u32; 3], u32)],
    tris: &[VoxelTriangle],
) -> BTreeMap<[u32; 3], u32> {
    let mut sums: BTreeMap<[u32; 3], [u32; 4]> = BTreeMap::new();
    for &(v, t) in fragments {
        let s = sums.entry(v).or_default();
        for (sum, a) in s.iter_mut().zip(tris[t as usize].albedo) {
            *sum += a as u32;
        }
        s[3] += 1;
    }
    sums.into_iter()
        .map(|(v, s)| {
            let half = s[3] / 2;
            let rgb = [0, 1, 2].map(|i| (s[i] + half) / s[3]);
            (v, pack_u8([rgb[0], rgb[1], rgb[2], 255]))
        })
        .collect()
}
