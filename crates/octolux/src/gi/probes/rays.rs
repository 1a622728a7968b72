//! The structure the surfel rays run through (`rays` in `[settings.probes]`): the scene's
//! triangles in a BVH ([`super::bvh`], exact) or the scene's sparse voxel octree
//! ([`crate::voxel::svo`], walked with the VPL technique's integer walk; exact to a voxel).
//!
//! - **BVH**: a two-level BVH ([`super::bvh::SceneBvh`]) built on the CPU once: the static
//!   objects in world space, each animated object in its model space; every frame only the
//!   animated objects' transforms are uploaded (`place_bvh.wgsl`).
//! - **Voxels**: the octree's static part is built on the GPU once, its dynamic part is
//!   voxelized and rebuilt on the GPU every frame from the animated triangles
//!   (`place_voxels.wgsl`); the first occupied voxel along a ray becomes the surfel, with its
//!   fragments' mean albedo, emission and normal.
//!
//! docs/probes.md compares the two on the same scenes.

use super::bvh::{GpuInstance, SceneBvh};
use super::params::{probe_storage, ProbeParams};
use crate::gi::GiFrame;
use crate::gpu::{GpuContext, PassTimer};
use crate::voxel::objects_triangles;
use crate::voxel::svo::walk::{walk_bindings, SvoWalk};
use crate::voxel::svo::{Svo, SvoBuilder};
use crate::{Error, Result};

/// Which structure the surfel rays run through.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum RayBackend {
    /// The scene's triangles in a BVH: exact hits (default).
    Bvh,
    /// The scene's sparse voxel octree at `voxel_resolution`: hits exact to a voxel.
    Voxels,
}

impl std::str::FromStr for RayBackend {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "bvh" => Ok(RayBackend::Bvh),
            "voxels" => Ok(RayBackend::Voxels),
            other => Err(Error::InvalidArgument(format!(
                "probes rays '{other}': expected bvh or voxels"
            ))),
        }
    }
}

/// Root of an absent static BVH.
const NO_ROOT: u32 = u32::MAX;

/// The ray structure of a probe technique with its buffers.
pub(crate) enum Rays {
    Bvh(BvhRays),
    /// Boxed: the octree and its builder's pipelines are large.
    Voxels(Box<VoxelRays>),
}

/// The two-level BVH in storage buffers.
pub(crate) struct BvhRays {
    bvh: SceneBvh,
    nodes: wgpu::Buffer,
    tris: wgpu::Buffer,
    /// The animated objects' transforms (one placeholder instance without any).
    instances: wgpu::Buffer,
    /// The animated objects' root nodes.
    roots: Vec<u32>,
}

/// The scene's octree and its walk's parameters.
pub(crate) struct VoxelRays {
    svo: Svo,
    builder: SvoBuilder,
    walk: wgpu::Buffer,
    placeholder: wgpu::Buffer,
}

impl Rays {
    /// The structure `backend` for `scene` (octree of `resolution`^3 voxels); sets the static
    /// BVH's root in `params` (the animated objects' count follows every frame,
    /// [`Rays::sync_moving`]).
    pub fn new(
        ctx: &GpuContext,
        owner: &str,
        backend: RayBackend,
        resolution: u32,
        scene: &crate::scene::Scene,
        params: &mut ProbeParams,
    ) -> Result<Rays> {
        params.static_root = NO_ROOT;
        params.instance_count = 0;
        match backend {
            RayBackend::Bvh => {
                let bvh = SceneBvh::build(scene);
                let (nodes, tris, roots) = bvh.flatten();
                let upload = |label: &str, bytes: &[u8]| -> Result<wgpu::Buffer> {
                    let buffer = probe_storage(ctx, owner, label, bytes.len() as u64)?;
                    ctx.queue.write_buffer(&buffer, 0, bytes);
                    Ok(buffer)
                };
                if !bvh.still.nodes.is_empty() {
                    params.static_root = 0;
                }
                let instances = bvh.instances(scene, &scene.frame(0.0, 0), &roots)?;
                let instances = if instances.is_empty() {
                    vec![GpuInstance::default()]
                } else {
                    instances
                };
                Ok(Rays::Bvh(BvhRays {
                    nodes: upload("bvh nodes", bytemuck::cast_slice(&nodes))?,
                    tris: upload("bvh triangles", bytemuck::cast_slice(&tris))?,
                    instances: upload("bvh instances", bytemuck::cast_slice(&instances))?,
                    bvh,
                    roots,
                }))
            }
            RayBackend::Voxels => {
                let builder = SvoBuilder::new(ctx);
                let svo = builder.build_scene(ctx, scene, resolution, owner)?;
                // The walk starts at the probe: no offset along a normal.
                let walk = SvoWalk::new(&svo, 0.0)?;
                let usage = wgpu::BufferUsages::STORAGE;
                Ok(Rays::Voxels(Box::new(VoxelRays {
                    walk: ctx.create_buffer_init(
                        owner,
                        "voxel walk",
                        bytemuck::bytes_of(&walk),
                        usage,
                    ),
                    placeholder: ctx.create_buffer_init(owner, "placeholder", &[0; 16], usage),
                    svo,
                    builder,
                })))
            }
        }
    }

    /// The module the placement pass (`place.wgsl`) imports as `gi/probes/rays` for this
    /// structure: its `surfel_hit` (and, through its imports, its bindings).
    pub fn place_module(&self) -> &'static str {
        match self {
            Rays::Bvh(_) => "gi/probes/place_bvh",
            Rays::Voxels(_) => "gi/probes/place_voxels",
        }
    }

    /// The placement pass's bindings of the ray structure: the BVH's at 2, 3 and 4, the
    /// octree walk's where `walk.wgsl` declares them.
    pub fn place_bindings(&self) -> Vec<(u32, wgpu::BindingResource<'_>)> {
        match self {
            Rays::Bvh(b) => (2..)
                .zip([&b.nodes, &b.tris, &b.instances])
                .map(|(i, b)| (i, b.as_entire_binding()))
                .collect(),
            Rays::Voxels(v) => walk_bindings(&v.walk, &v.svo, &v.placeholder).into(),
        }
    }

    /// What the placement counts of its rays' work (`count_ray_work` in place_bvh.wgsl and
    /// place_voxels.wgsl).
    pub fn work(&self) -> &'static [&'static str] {
        match self {
            Rays::Bvh(_) => &["BVH nodes", "triangles tested"],
            Rays::Voxels(_) => &["ray cells", "octree nodes"],
        }
    }

    /// How far a hit may lie outside the bounds of the triangles it stands for: nothing for
    /// the BVH; two voxels for the octree (a conservatively voxelised triangle marks voxels
    /// beyond its bounds, and a voxel hit lies anywhere in its voxel).
    pub fn hit_margin(&self) -> f32 {
        match self {
            Rays::Bvh(_) => 0.0,
            Rays::Voxels(v) => 2.0 * v.svo.grid().voxel_size,
        }
    }

    /// The octree the voxel rays walk (`None` for the BVH).
    pub fn svo(&self) -> Option<&Svo> {
        match self {
            Rays::Bvh(_) => None,
            Rays::Voxels(v) => Some(&v.svo),
        }
    }

    /// Brings the animated objects up to date with `frame`: their transforms go to the
    /// BVH's instances (the number of instances to `params`), or the octree's dynamic part is
    /// rebuilt by passes recorded into `timer`.
    pub fn sync_moving(
        &mut self,
        ctx: &GpuContext,
        frame: &GiFrame,
        timer: &mut PassTimer,
        params: &mut ProbeParams,
    ) -> Result<()> {
        match self {
            Rays::Voxels(v) => {
                let moving = objects_triangles(frame.scene, frame.instant, true);
                v.builder.record_dynamic(ctx, timer, &mut v.svo, &moving)?;
            }
            Rays::Bvh(b) => {
                let instances = b.bvh.instances(frame.scene, frame.instant, &b.roots)?;
                ctx.queue
                    .write_buffer(&b.instances, 0, bytemuck::cast_slice(&instances));
                params.instance_count = instances.len() as u32;
            }
        }
        Ok(())
    }
}

/// A surfel as the voxel rays place it (CPU twin of `voxel_closest` in `voxel_rays.wgsl`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VoxelSurfel {
    /// The first occupied voxel along the walk.
    pub voxel: glam::IVec3,
    /// Distance along the ray: where it meets the plane through the voxel's centre with the
    /// voxel's normal, kept within the voxel (where it enters without a normal).
    pub t: f32,
    /// The voxel's unit mean normal, zero where its fragments' normals cancel.
    pub normal: glam::Vec3,
    /// Mean albedo x255, rounded.
    pub albedo: [u32; 3],
    /// Mean emission.
    pub emission: glam::Vec3,
}

/// The lattice ends of the walk for the ray `o + t d`, t in [0, `t_max`], clipped to the
/// octree's grid (CPU twin of `voxel_ray`; the float rounding of the ends may differ from a
/// GPU's by one lattice step), or `None` where the ray misses the grid.
pub fn voxel_ray(
    walk: &SvoWalk,
    o: glam::Vec3,
    d: glam::Vec3,
    t_max: f32,
) -> Option<(glam::IVec3, glam::IVec3)> {
    let lo = glam::Vec3::from(walk.origin);
    let hi = lo + glam::Vec3::splat((1u32 << walk.depth) as f32 * walk.voxel);
    let (t0, t1) = ray_span_box(o, d, lo, hi);
    let t1 = t1.min(t_max);
    (t0 <= t1).then(|| {
        (
            walk.fixed_point(o + d * t0, glam::Vec3::ZERO),
            walk.fixed_point(o + d * t1, glam::Vec3::ZERO),
        )
    })
}

/// The ray `o + t d`, t >= 0, through the box `lo..hi`: (t_in, t_out).
fn ray_span_box(o: glam::Vec3, d: glam::Vec3, lo: glam::Vec3, hi: glam::Vec3) -> (f32, f32) {
    let inv = glam::Vec3::select(d.cmpeq(glam::Vec3::ZERO), glam::Vec3::splat(1e-30), d).recip();
    let (a, b) = ((lo - o) * inv, (hi - o) * inv);
    (a.min(b).max_element().max(0.0), a.max(b).min_element())
}

/// The surfel of the ray `o + t d` whose walk runs from lattice point `a` to `b` through
/// `tree` (CPU twin of `voxel_closest`), or `None` where it meets no occupied voxel.
pub fn voxel_surfel(
    tree: &crate::voxel::svo::walk::SvoWalkCpu,
    o: glam::Vec3,
    d: glam::Vec3,
    a: glam::IVec3,
    b: glam::IVec3,
) -> Option<VoxelSurfel> {
    let voxel = tree.walk(a, b).0?;
    let s = tree.voxel_sums(voxel);
    let count = s[3];
    if count == 0 {
        return None;
    }
    let c = count as f32;
    let sums = |i: usize| glam::Vec3::new(s[i] as f32, s[i + 1] as f32, s[i + 2] as f32);
    let n = glam::Vec3::new(s[7] as i32 as f32, s[8] as i32 as f32, s[9] as i32 as f32);
    let normal = if n.length_squared() > 0.01 * c * c * 127.0 * 127.0 {
        n.normalize()
    } else {
        glam::Vec3::ZERO
    };
    let size = tree.params.voxel;
    let lo = glam::Vec3::from(tree.params.origin) + voxel.as_vec3() * size;
    let (t_in, t_out) = ray_span_box(o, d, lo, lo + glam::Vec3::splat(size));
    let facing = d.dot(normal);
    let t = if facing.abs() > 1e-3 {
        (lo + glam::Vec3::splat(0.5 * size) - o).dot(normal) / facing
    } else {
        t_in
    };
    Some(VoxelSurfel {
        voxel,
        t: t.clamp(t_in, t_in.max(t_out)),
        normal,
        albedo: std::array::from_fn(|i| (s[i] + count / 2) / count),
        emission: sums(4) / (c * crate::voxel::clipmap::EMISSION_SCALE),
    })
}
