//! Helpers the integration tests share: the GPU context, a small deterministic random number
//! generator and a voxel triangle builder. (Each test file uses some of them.)
#![allow(dead_code)]

use glam::Vec3;
use octolux::gpu::{GpuContext, GpuOptions};
use octolux::voxel::VoxelTriangle;

/// The process's shared GPU context (any adapter; lavapipe without a GPU).
pub fn context() -> GpuContext {
    GpuContext::shared(&GpuOptions::default()).expect("a GPU adapter (install mesa-vulkan-drivers)")
}

/// A voxel triangle of `albedo` without emission, its normal from the winding.
pub fn tri(a: Vec3, b: Vec3, c: Vec3, albedo: [u8; 3]) -> VoxelTriangle {
    VoxelTriangle {
        positions: [a, b, c],
        albedo,
        normal: (b - a).cross(c - a).normalize_or(Vec3::Y),
        emission: Vec3::ZERO,
    }
}

/// A xorshift generator: the same sequence for the same seed on every machine.
pub struct Rng(pub u64);

impl Rng {
    /// A number in [0, 1) with 24 bits.
    pub fn next(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }

    /// A point of the box [lo, hi)^3.
    pub fn vec(&mut self, lo: f32, hi: f32) -> Vec3 {
        Vec3::new(self.next(), self.next(), self.next()) * (hi - lo) + Vec3::splat(lo)
    }

    /// A unit vector (rejection sampling in the unit ball).
    pub fn unit(&mut self) -> Vec3 {
        loop {
            let v = Vec3::new(self.next(), self.next(), self.next()) * 2.0 - 1.0;
            if v.length_squared() > 0.01 && v.length_squared() <= 1.0 {
                return v.normalize();
            }
        }
    }
}
