//! The library's integration tests, one module per subject, built as one binary: one crate to
//! compile and link instead of one per file. The
//! tests that measure the process itself (its allocations, its memory from frame to frame) or
//! bound a load's time stay binaries of their own (`Cargo.toml`).

mod common;
mod floor_flux;
mod lit_floor;

mod embed;
mod energy;
mod gpu_renderer;
mod layering;
mod lpv;
mod materials;
mod metrics;
mod mitsuba;
mod probe_leaks;
mod probes;
mod probes_history;
mod probes_octree_twins;
mod probes_twins;
mod probes_voxel_rays;
mod reference;
mod reference_vs_gpu;
mod scene_files;
mod shadow_edges;
mod shipped_scenes;
mod sky;
mod technique_switch;
mod unseen_rooms;
mod vct;
mod vct_animated;
mod vct_cone;
mod voxel;
mod voxel_clipmap;
mod voxel_clipmap_perf;
mod voxel_svo_aniso;
mod voxel_svo_dynamic;
mod voxel_svo_light;
mod vpl;
mod work_counts;
