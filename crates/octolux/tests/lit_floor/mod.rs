//! Shared by the clipmap light-injection tests (`voxel`, `vct_cone`): a floor at y = 0.3003
//! facing +y under a point light at (0.5, 0.8, 0.5), in a clipmap of 2 levels of 32^3 whose
//! level 0 spans the unit box, lit through `Clipmap::inject`.

use glam::Vec3;
use octolux::gpu::{GpuContext, PassTimer};
use octolux::scene::{Light, LightKind};
use octolux::voxel::clipmap::{Clipmap, ClipmapSettings};
use octolux::voxel::VoxelTriangle;

/// The two triangles of the square `lo..hi` (x and z) at height `y`, facing +y.
pub fn quad(y: f32, lo: f32, hi: f32, albedo: [u8; 3]) -> Vec<VoxelTriangle> {
    let (a, b) = (Vec3::new(lo, y, lo), Vec3::new(lo, y, hi));
    let (c, d) = (Vec3::new(hi, y, hi), Vec3::new(hi, y, lo));
    [[a, b, c], [a, c, d]]
        .map(|positions| VoxelTriangle {
            positions,
            albedo,
            normal: (positions[1] - positions[0])
                .cross(positions[2] - positions[0])
                .normalize(),
            emission: Vec3::ZERO,
        })
        .to_vec()
}

/// The floor (albedo 200, 150, 100 of 255) from 0.05 to 0.95.
pub fn floor() -> Vec<VoxelTriangle> {
    quad(0.3003, 0.05, 0.95, [200, 150, 100])
}

/// The point light above the floor: 1 W/sr, white.
pub fn light() -> Light {
    Light {
        name: "point".into(),
        kind: LightKind::Point,
        color: Vec3::ONE,
        intensity: 1.0,
        position: Vec3::new(0.5, 0.8, 0.5),
        direction: Vec3::NEG_Y,
        animation: None,
    }
}

/// The clipmap's settings: 2 levels of 32^3, finest voxel 1/32 m.
pub const SETTINGS: ClipmapSettings = ClipmapSettings {
    resolution: 32,
    levels: 2,
    voxel_size: 1.0 / 32.0,
};

/// `tris` voxelised around (0.5, 0.5, 0.5) and lit by [`light`].
pub fn lit_clipmap(ctx: &GpuContext, tris: &[VoxelTriangle]) -> Clipmap {
    let mut clipmap = Clipmap::new(ctx, SETTINGS).unwrap();
    let mut timer = PassTimer::new(ctx);
    clipmap
        .update(ctx, &mut timer, tris, Vec3::splat(0.5))
        .unwrap();
    clipmap
        .inject(ctx, &mut timer, std::slice::from_ref(&light()), 512)
        .unwrap();
    timer.finish_frame().unwrap();
    clipmap
}
