//! The CPU twins of the voxel kernels, gathered in one place for the tests: each is written
//! for clarity beside the structure it mirrors ([`super::voxelize::cpu`], [`super::svo::cpu`],
//! [`super::clipmap::cpu`]).

pub use super::clipmap::cpu::{
    clipmap_aniso, clipmap_emission, clipmap_filter, clipmap_filter_emission, clipmap_voxels,
};
pub use super::svo::cpu::{
    build_octree, lattices, neighbourhood, svo_aniso, svo_aniso_radiance, CpuLevel, Lattice,
};
pub use super::voxelize::cpu::{to_grid, voxel_value, voxel_values, voxel_words, voxelize};
