//! Voxel cone tracing (`003`) on the sparse voxel octree (`vct-svo`) and on the clipmap
//! (`vct-clipmap`).
//!
//! [`cone`] holds the marcher in WGSL (the module `gi/vct/cone`) and its CPU twin
//! ([`march_cone`]), written against one sampling function, `vct_sample(p, footprint, dir) ->
//! vec4<f32>` (premultiplied radiance and opacity filtered over `footprint` metres, seen
//! travelling along `dir`), imported from the module `gi/vct/structure`, which each technique composes in
//! with the module of the structure it traces: the octree's or the clipmap's radiance sampler
//! (`svo_trace.wgsl`, `clipmap_trace.wgsl`). [`gather`] holds the diffuse gather's cone set
//! and weights; `tracer.rs` the passes both techniques share (gather, sparse reconstruction,
//! specular cone) and `bounce_list.rs` the list of voxels their bounce gathers visit, so the
//! two differ only in the structure they bring up to date and sample.

mod bounce_list;
mod clipmap_bounce;
mod clipmap_gi;
pub mod clipmap_tail;
pub mod cone;
pub mod gather;
mod settings;
mod svo_gi;
mod tracer;

pub use clipmap_gi::VctClipmap;
pub use settings::{
    ClipmapInjection, DiffuseCones, VctSettings, VctStructure, BOUNCE_FRAMES, INJECT_STEPS, LEVELS,
    SPARSE, START, STEP,
};
pub use svo_gi::{VctSvo, FACING_STORAGE_BUFFERS};

pub use cone::{march_cone, ConeMarch, ConeParams};
pub use gather::{cone_set_wgsl, diffuse_cone_dir, gather_irradiance};

/// The transport a cone tracer computes: every bounce with `multi_bounce`, else one. Voxels
/// store emission with the reflected direct light, so emissive surfaces light the scene through
/// the cones, one bounce behind the lights.
fn cone_transport(multi_bounce: bool) -> crate::transport::Transport {
    crate::transport::Transport {
        bounces: if multi_bounce {
            crate::transport::Bounces::Unlimited
        } else {
            crate::transport::Bounces::Indirect(1)
        },
        emissive: crate::transport::EmissiveSurfaces::OneBounceFewer,
    }
}
