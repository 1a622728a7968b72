//! Voxel scene representations that cone tracing, VPL visibility and probe placement stand on
//! (Arnebäck 2017, chapters 3 and 4):
//!
//! - [`voxelize`]: a conservative compute-shader voxelizer (no geometry shaders), producing a
//!   voxel fragment list or filling a dense region directly. Triangles are snapped to a
//!   fixed-point lattice on the CPU and tested against the voxels in integer arithmetic
//!   ([`voxelize::snap`]), so every adapter marks exactly the voxels the CPU reference marks.
//!   Deterministic: every accumulation is an integer atomic sum.
//! - [`svo`]: a sparse voxel octree built level by level on the GPU (flag, subdivide/allocate
//!   with an atomic counter, neighbour links) with a 3x3x3 corner-sampled brick pool, neighbour
//!   transfer and bottom-up mipmapping; [`svo::dynamic`] gives it a static part built once and
//!   a dynamic part rebuilt every frame.
//! - [`svo::aniso`]: optional anisotropic (6-direction) values per octree node, built bottom-up
//!   from the leaf sums, and their directional sampling.
//! - [`clipmap`]: nested levels of equal resolution and doubling extent around the camera with
//!   toroidal addressing; camera motion revoxelises only the exposed slabs.
//! - [`sample`]: the common "filtered value at `p` with footprint `d`" interface of both
//!   structures, as WGSL (the modules `voxel/svo/sample`, `voxel/clipmap/sample`) and as a CPU
//!   twin for tests.
//! - [`cpu`]: CPU reference implementations the tests compare the GPU with.
//! - [`debug`]: a ray-marched view of the stored albedo.
//!
//! What is stored: premultiplied albedo and opacity (RGBA) in both structures, and per voxel
//! the mean emission (the octree's leaf sums, the clipmap's RGB9E5 words). Both inject emission
//! plus reflected direct light into voxel radiance: the octree with visibility from the
//! renderer's shadow maps ([`svo::SvoBuilder::inject`]), the clipmap with voxel shadow rays
//! ([`clipmap::Clipmap::inject`]). See `docs/voxels.md` for what is not done yet.
//!
//! Parameter blocks (levels, boxes, counts, grid and clipmap descriptions) are read-only
//! storage buffers (`var<storage, read>`), never uniform buffers: Mesa's lavapipe specialises a
//! compute shader on the values of a small uniform block that decides its branches or loop
//! bounds, compiling a new variant every time the pipeline is bound and keeping every variant
//! until the pipeline is destroyed. The octree's update and injection and the clipmap's
//! update and injection run every frame, one dispatch per level or box, so a uniform block
//! there costs a compile per dispatch and memory that grows without bound
//! (`tests/voxel_growth.rs`). Slots bound at offsets stay 256 bytes apart, the largest
//! `min_storage_buffer_offset_alignment` wgpu allows.

pub mod clipmap;
pub mod cpu;
pub mod debug;
pub mod facing;
pub mod pairs;
pub mod sample;
pub mod svo;
pub mod voxelize;

use crate::scene::{AlphaMode, Scene, SceneFrame};
use crate::{Error, Result};
use glam::{Vec2, Vec3, Vec4};

/// Largest grid edge accepted by the voxel structures (1024^3 voxels).
pub const MAX_RESOLUTION: u32 = 1024;

/// A cubic voxel grid: `resolution`^3 voxels of edge `voxel_size` starting at `origin`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VoxelGrid {
    /// World position of the corner of voxel (0, 0, 0).
    pub origin: Vec3,
    /// Edge length of one voxel (m).
    pub voxel_size: f32,
    /// Voxels per axis.
    pub resolution: u32,
}

impl VoxelGrid {
    /// A grid, checking that the resolution is a power of two in `2..=MAX_RESOLUTION` and the
    /// voxel size is positive and finite.
    pub fn new(origin: Vec3, voxel_size: f32, resolution: u32) -> Result<VoxelGrid> {
        check_resolution(resolution)?;
        if !(voxel_size.is_finite() && voxel_size > 0.0 && origin.is_finite()) {
            return Err(Error::InvalidArgument(format!(
                "voxel grid: voxel size {voxel_size} and origin {origin} must be finite, size > 0"
            )));
        }
        Ok(VoxelGrid {
            origin,
            voxel_size,
            resolution,
        })
    }

    /// The cube grid of `resolution`^3 voxels enclosing `bounds` with a margin of one voxel
    /// on every side, so geometry never touches the grid's outer faces.
    pub fn enclosing(bounds: (Vec3, Vec3), resolution: u32) -> Result<VoxelGrid> {
        check_resolution(resolution)?;
        let (lo, hi) = bounds;
        let extent = (hi - lo).max_element().max(1e-3);
        let voxel_size = extent / (resolution as f32 - 2.0);
        let centre = (lo + hi) * 0.5;
        Self::new(
            centre - Vec3::splat(voxel_size * resolution as f32 * 0.5),
            voxel_size,
            resolution,
        )
    }

    /// Octree depth: levels `0..depth()`, the finest holding nodes of 2x2x2 voxels.
    pub fn depth(&self) -> u32 {
        self.resolution.trailing_zeros()
    }

    /// World position to grid coordinates (voxel units).
    pub fn to_grid(&self, p: Vec3) -> Vec3 {
        (p - self.origin) / self.voxel_size
    }
}

/// Checks a voxel resolution: a power of two in `2..=MAX_RESOLUTION`.
pub fn check_resolution(resolution: u32) -> Result<()> {
    if !(2..=MAX_RESOLUTION).contains(&resolution) || !resolution.is_power_of_two() {
        return Err(Error::InvalidArgument(format!(
            "voxel resolution {resolution}: must be a power of two from 2 to {MAX_RESOLUTION}"
        )));
    }
    Ok(())
}

/// One triangle as the voxelizer reads it: world positions and per-triangle surface data.
/// Albedo is quantised to 8 bits here so that the GPU and the CPU reference average the same
/// integers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VoxelTriangle {
    /// World positions.
    pub positions: [Vec3; 3],
    /// Linear albedo x 255 (material factor x mean texture colour over the triangle).
    pub albedo: [u8; 3],
    /// Unit geometric normal.
    pub normal: Vec3,
    /// Emitted radiance, W/(m^2 sr).
    pub emission: Vec3,
}

/// GPU layout of [`VoxelTriangle`] (`Tri` in `voxelize/overlap.wgsl`): the surface data the
/// voxel kernels add to the voxels a triangle covers. Its position reaches them as the
/// snapped pieces of [`voxelize::snap`], never as floats.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuTriangle {
    /// Emitted radiance, W/(m^2 sr).
    pub emission: [f32; 3],
    /// Linear albedo x 255 as RGBA8, red in the low byte, alpha 255
    /// ([`VoxelTriangle::albedo_bits`]).
    pub albedo: u32,
    /// Unit geometric normal x 127 as three snorm8 bytes, x in the low byte.
    pub normal: u32,
    /// Padding to the WGSL struct's 16-byte alignment.
    pub _pad: [u32; 3],
}

impl VoxelTriangle {
    /// Packed RGBA8 albedo (alpha 255), red in the low byte.
    pub fn albedo_bits(&self) -> u32 {
        self.albedo[0] as u32
            | (self.albedo[1] as u32) << 8
            | (self.albedo[2] as u32) << 16
            | 255 << 24
    }

    /// The GPU layout.
    pub fn to_gpu(&self) -> GpuTriangle {
        let n = self.normal.clamp(Vec3::splat(-1.0), Vec3::splat(1.0)) * 127.0;
        let normal = (n.x.round() as i32 as u32 & 255)
            | (n.y.round() as i32 as u32 & 255) << 8
            | (n.z.round() as i32 as u32 & 255) << 16;
        GpuTriangle {
            emission: self.emission.to_array(),
            albedo: self.albedo_bits(),
            normal,
            _pad: [0; 3],
        }
    }
}

/// The scene's triangles at one frame with their voxel surface data. Albedo is the material
/// factor times the texture averaged over seven points of the triangle (vertices, edge
/// midpoints and centroid): one colour per triangle, which is what the voxelizer stores.
/// Alpha-masked triangles whose coverage (texture alpha x opacity) averaged over the same
/// points is below the cutoff are holes, and clear materials are left out altogether, so the
/// voxels block light where the rasterised passes and the reference do (at triangle rather
/// than texel resolution).
pub fn scene_triangles(scene: &Scene, frame: &SceneFrame) -> Vec<VoxelTriangle> {
    scene
        .world_triangles(frame)
        .iter()
        .filter_map(|t| voxel_triangle(scene, t))
        .collect()
}

/// The voxel triangle of one world triangle, None for a clear or masked-out one.
fn voxel_triangle(scene: &Scene, t: &crate::scene::WorldTriangle) -> Option<VoxelTriangle> {
    let material = scene.materials.get(t.material as usize);
    if material.is_some_and(|m| m.is_clear()) {
        return None;
    }
    let (factor, emission, texture) = match material {
        Some(m) => (
            m.base_color,
            m.emission,
            m.base_color_texture
                .and_then(|i| scene.textures.get(i as usize)),
        ),
        None => (Vec3::splat(0.8), Vec3::ZERO, None),
    };
    let tex = match texture {
        Some(tex) => {
            let [a, b, c] = t.uvs;
            let points: [Vec2; 7] = [
                a,
                b,
                c,
                (a + b) * 0.5,
                (b + c) * 0.5,
                (c + a) * 0.5,
                (a + b + c) / 3.0,
            ];
            points.iter().map(|&uv| tex.sample(uv)).sum::<Vec4>() / 7.0
        }
        None => Vec4::ONE,
    };
    if let Some(m) = material {
        if let AlphaMode::Mask(cutoff) = m.alpha_mode {
            if tex.w * m.opacity < cutoff {
                return None;
            }
        }
    }
    let albedo = (factor * tex.truncate()).clamp(Vec3::ZERO, Vec3::ONE) * 255.0;
    let [p0, p1, p2] = t.positions;
    // The face's normal, turned to the side its vertex normals (the shading) face: a mesh
    // whose winding disagrees with its normals, or one mirrored by its transform, would
    // otherwise light and gather its voxels from behind.
    let face = (p1 - p0).cross(p2 - p0);
    let shading = t.normals[0] + t.normals[1] + t.normals[2];
    let normal = if face.dot(shading) < 0.0 { -face } else { face }.normalize_or(t.normals[0]);
    Some(VoxelTriangle {
        positions: t.positions,
        albedo: [
            albedo.x.round() as u8,
            albedo.y.round() as u8,
            albedo.z.round() as u8,
        ],
        normal,
        emission,
    })
}

/// The voxel triangles of `frame`, split into those of objects without animation (static:
/// an octree's static part, built once) and those of animated objects (moving: its dynamic
/// part, [`svo::SvoBuilder::record_dynamic`] every frame).
pub fn scene_triangles_split(
    scene: &Scene,
    frame: &SceneFrame,
) -> (Vec<VoxelTriangle>, Vec<VoxelTriangle>) {
    (
        objects_triangles(scene, frame, false),
        objects_triangles(scene, frame, true),
    )
}

/// The voxel triangles of the animated objects (`animated`) or of the others, in scene order.
pub fn objects_triangles(scene: &Scene, frame: &SceneFrame, animated: bool) -> Vec<VoxelTriangle> {
    scene
        .world_triangles_where(frame, |o| o.animation.is_some() == animated)
        .iter()
        .filter_map(|t| voxel_triangle(scene, t))
        .collect()
}

/// The voxel triangles of object `index` alone, placed by `frame`'s transform of it.
pub fn object_triangles(scene: &Scene, frame: &SceneFrame, index: usize) -> Vec<VoxelTriangle> {
    let Some(object) = scene.objects.get(index) else {
        return Vec::new();
    };
    scene
        .world_triangles_where(frame, |o| std::ptr::eq(o, object))
        .iter()
        .filter_map(|t| voxel_triangle(scene, t))
        .collect()
}

/// Packs voxel coordinates (each < 1024) into one word, 10 bits per axis.
pub fn pack_coord(x: u32, y: u32, z: u32) -> u32 {
    (x & 1023) | (y & 1023) << 10 | (z & 1023) << 20
}

/// Inverse of [`pack_coord`].
pub fn unpack_coord(c: u32) -> [u32; 3] {
    [c & 1023, (c >> 10) & 1023, (c >> 20) & 1023]
}
