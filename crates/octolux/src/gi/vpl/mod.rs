//! Many-lights VPL global illumination with visibility by sparse-voxel-octree ray marching
//! (`002`, Sun & Agu): `--gi vpl`.
//!
//! A frame, pass by pass (each a named, timed pass):
//! 1. `svo dyn ...` (animated scenes only): the octree's dynamic part is rebuilt from the
//!    animated objects at this frame's time ([`SvoBuilder::record_dynamic`]). The static
//!    objects' octree ([`crate::voxel::svo`]) is built once, when the technique is created.
//! 2. `vpl rsm`: reflective shadow maps of every light view (the LPV's RSM pass,
//!    [`crate::frame::rsm`]: spot and directional lights one, point lights six cube faces).
//! 3. `vpl generate`: N VPLs importance-sampled by reflected flux, each with physical flux
//!    ([`generate`]); with `bounces` 2 or 3, `vpl bounce` adds the next bounce's VPLs where
//!    rays from the previous bounce's VPLs hit the octree (`bounce.wgsl`).
//! 4. `vpl shade`: interleaved shading, each pixel with 1 / I^2 of the VPLs, visibility by a
//!    stackless walk of the octree (`voxel/svo/walk.wgsl`, `shade.wgsl`), VPLs that add
//!    little to a pixel tracing their ray only by Russian roulette (`roulette`); with sparse
//!    shading (default) one pixel per `sparse` x `sparse` block.
//! 5. `vpl merge`: geometry-aware I x I merge into the indirect irradiance image (the reduced
//!    image with sparse shading).
//! 6. `vpl upsample` (sparse shading): every pixel reconstructed from the shaded blocks
//!    around it on alike surfaces ([`crate::frame::sparse`]).

pub mod generate;

use crate::frame::rsm::{self, RsmLayer, RsmPass, RsmTargets};
use crate::frame::sparse::SparseImage;
use crate::gi::{GiFrame, GiTechnique};
use crate::gpu::pass::dispatch_groups;
use crate::gpu::pass::SLOT;
use crate::gpu::shader::library_shader;
use crate::gpu::{GpuContext, PassTimer};
use crate::voxel::objects_triangles;
use crate::voxel::svo::walk;
use crate::voxel::svo::{Svo, SvoBuilder};
use crate::Result;
use bytemuck::{Pod, Zeroable};

const OWNER: &str = "vpl";

/// Settings of VPL GI. Scene files: `[settings.vpl]`.
#[derive(Clone, Debug, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct VplSettings {
    /// Number of VPLs, 1..=65536 (default 1024; 002 uses 512, 1024 and 2048).
    pub count: u32,
    /// Interleave factor I: the image is split into I x I sub-images, each shading 1 / I^2
    /// of the VPLs, then merged over I x I windows (1..=8, default 4 as in 002).
    pub interleave: u32,
    /// Distance clamp of eq. 2 in voxels of the octree: B = (clamp x voxel edge)^2 (default 2:
    /// closer than two voxels the octree cannot tell the VPL's surface from the receiver's,
    /// so the 1/r^2 singularity is cut there; docs/vpl.md measures the bias). Each VPL's own
    /// disk ([`vpl_clamp`]) bounds it too, whichever is larger.
    pub clamp: f32,
    /// Voxels per side of the octree, a power of two in 4..=1024 (default 128, as 002's
    /// Cornell box).
    pub resolution: u32,
    /// RSM side in texels, a power of two in 16..=2048 (default 256).
    pub rsm_size: u32,
    /// Shadow-segment ends move this many voxels along their normals before the octree walk
    /// (default 1.75, just over a voxel diagonal; 0..=8).
    pub end_offset: f32,
    /// A VPL whose mean contribution to a pixel is at most this (W/m^2) is skipped before
    /// its shadow ray (default 0: only VPLs with G = 0 or no flux).
    pub cull: f32,
    /// Russian roulette on shadow rays, 0..=16 (default 2; 0: off): a VPL whose unoccluded
    /// contribution to a pixel is below `roulette` x the mean contribution of the pixel's
    /// VPLs in its shading dispatch (its subset, at most 64 VPLs) traces its ray with
    /// probability contribution / threshold and is weighted by its inverse: the expected
    /// image is unchanged, and rays that could only add little are mostly not traced
    /// (docs/vpl.md measures rays and error).
    pub roulette: f32,
    /// Geometry-aware merge of the sub-images (default true; false shows the raw interleave).
    pub filter: bool,
    /// Sparse shading: one shaded pixel per `sparse` x `sparse` block, the others
    /// reconstructed from the shaded ones around them on alike surfaces (`frame::sparse`);
    /// 1..=16 (1: every pixel), or 0 (default) for [`VplSettings::sparse_factor`]'s choice from
    /// the image height. The shadow rays, the pass's cost, fall by sparse^2 (docs/vpl.md
    /// measures the error).
    pub sparse: u32,
    /// Merge: least cosine between a neighbour's normal and the pixel's (default 0.9).
    pub normal_min: f32,
    /// Merge: largest distance of a neighbour to the pixel's tangent plane, as a fraction of
    /// the pixel's distance to the camera (default 0.02).
    pub plane_tol: f32,
    /// Light bounces carried by VPLs, 1..=3 (default 1): with 2 or 3, every VPL of the
    /// previous bounce spawns one VPL where a cosine-distributed ray through the octree hits
    /// (`bounce.wgsl`), so N VPLs per bounce are shaded.
    pub bounces: u32,
    /// Sky lights that get an RSM (default 8), as `[settings.lpv] sky_rsms`.
    pub sky_rsms: u32,
    /// The RSM layers whose light or objects moved since the last frame drawn at half the side
    /// (a quarter of the texels, in exactly the frames that draw a layer anew), as
    /// `[settings.lpv] rsm_moving_half`; those that hold still keep the whole (default true).
    pub rsm_moving_half: bool,
}

impl Default for VplSettings {
    fn default() -> Self {
        VplSettings {
            count: 1024,
            interleave: 4,
            clamp: 2.0,
            resolution: 128,
            rsm_size: 256,
            end_offset: 1.75,
            cull: 0.0,
            roulette: 2.0,
            filter: true,
            sparse: 0,
            normal_min: 0.9,
            plane_tol: 0.02,
            bounces: 1,
            sky_rsms: 8,
            rsm_moving_half: true,
        }
    }
}

/// [`crate::gi::bounds::require`] for `vpl`'s settings, which messages name `vpl <field>`.
fn check(ok: bool, what: &str, range: &str) -> Result<()> {
    crate::gi::bounds::require(ok, &format!("vpl {what}"), range)
}

impl VplSettings {
    /// Checks every field's range.
    pub fn validate(&self) -> Result<()> {
        check((1..=65536).contains(&self.count), "count", "1..=65536")?;
        check((1..=8).contains(&self.interleave), "interleave", "1..=8")?;
        check(
            self.sparse <= 16,
            "sparse",
            "0 (chosen from the image height) or 1..=16",
        )?;
        check(
            self.clamp.is_finite() && self.clamp >= 0.0,
            "clamp",
            "finite, >= 0",
        )?;
        check(
            self.resolution.is_power_of_two() && (4..=1024).contains(&self.resolution),
            "resolution",
            "a power of two in 4..=1024",
        )?;
        check(
            self.rsm_size.is_power_of_two() && (16..=2048).contains(&self.rsm_size),
            "rsm_size",
            "a power of two in 16..=2048",
        )?;
        check(
            (0.0..=8.0).contains(&self.end_offset),
            "end_offset",
            "0..=8",
        )?;
        check(
            self.cull.is_finite() && self.cull >= 0.0,
            "cull",
            "finite, >= 0",
        )?;
        check((0.0..=16.0).contains(&self.roulette), "roulette", "0..=16")?;
        check(
            (-1.0..=1.0).contains(&self.normal_min),
            "normal_min",
            "-1..=1",
        )?;
        check(
            self.plane_tol.is_finite() && self.plane_tol >= 0.0,
            "plane_tol",
            "finite, >= 0",
        )?;
        check((1..=3).contains(&self.bounces), "bounces", "1..=3")?;
        check(
            (1..=crate::scene::Sky::MAX_DIRECTIONS).contains(&self.sky_rsms),
            "sky_rsms",
            "1..=64",
        )
    }
}

/// Rows the reduced image of automatic sparse shading keeps at least.
const SPARSE_ROWS: u32 = 135;

impl VplSettings {
    /// The sparse factor for images `height` pixels high: the setting, or where it is 0 the
    /// largest factor up to 16 that leaves at least 135 shaded rows (1 at 160x90 and 320x180,
    /// 2 at 640x360, 5 at 1280x720, 8 at 1920x1080, 16 at 3840x2160). Indirect light varies
    /// over a fraction of the image, not over pixels: at 640x360 shading one pixel per 2 x 2
    /// block errs no more than shading every pixel, at 1920x1080 one per 8 x 8 no more than
    /// per 4 x 4 (docs/vpl.md), and the shadow rays fall with the square of the factor. Above
    /// 1080 rows the shaded blocks keep their share of the screen, so the shading costs what
    /// it costs at 1080p (with 8 at most it took 3.45x its 1080p time at 2160p on an H200).
    pub fn sparse_factor(&self, height: u32) -> u32 {
        match self.sparse {
            0 => (height / SPARSE_ROWS).clamp(1, 16),
            f => f,
        }
    }
}

/// `ShadeParams` of `shade.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct ShadeParams {
    count: u32,
    interleave: u32,
    clamp_b: f32,
    cull: f32,
    normal_min: f32,
    plane_tol: f32,
    filter: u32,
    sparse: u32,
    lanes: u32,
    roulette: f32,
}

/// The geometry term of eq. 2-4 (as `vpl_g` in `shade.wgsl`): receiver at `p` with normal
/// `n`, VPL at `pv` with normal `nv`, squared distance clamped at `b` ([`vpl_clamp`]).
pub fn geometry_term(p: glam::Vec3, n: glam::Vec3, pv: glam::Vec3, nv: glam::Vec3, b: f32) -> f32 {
    let d = p - pv;
    let r2 = d.length_squared();
    if r2 <= 0.0 {
        return 0.0;
    }
    let w = d / r2.sqrt();
    n.dot(-w).max(0.0) * nv.dot(w).max(0.0) / b.max(r2)
}

/// The bound `b` of a VPL's squared distance in [`geometry_term`] (as in `vpl_g`): the clamp
/// `clamp_b` = (`clamp` x voxel edge)^2, where the octree cannot tell the VPL's surface from the
/// receiver's, or the squared radius of a disk of the VPL's `area`, whichever is larger. A
/// VPL stands for a patch of surface, not a point: closer than its radius the patch's
/// irradiance stays finite (a disk's on its axis is M r^2 / (r^2 + d^2), no more than its
/// radiosity M), where a point's 1 / d^2 spikes.
pub fn vpl_clamp(clamp_b: f32, area: f32) -> f32 {
    clamp_b.max(area * std::f32::consts::FRAC_1_PI)
}

/// VPL global illumination.
pub struct VplGi {
    settings: VplSettings,
    svo: Svo,
    /// The octree's pipelines, kept for the dynamic part's updates.
    builder: SvoBuilder,
    /// Whether the scene has animated objects (the octree then has a dynamic part).
    animated: bool,
    placeholder: wgpu::Buffer,
    octree: walk::SvoWalk,
    octree_params: wgpu::Buffer,
    rsm: RsmTargets,
    shade_params: wgpu::Buffer,
    /// Per pixel of the reduced image, the sum of its VPL subset (`vec4<f32>`).
    raw: wgpu::Buffer,
    /// Sparse shading's reduced image and reconstruction (None: every pixel shaded).
    sparse: Option<SparseImage>,
    /// One 256-byte slot per shading dispatch holding its first chunk.
    chunks: wgpu::Buffer,
    texture: wgpu::Texture,
    view: wgpu::TextureView,
    passes: Option<Passes>,
    /// What each RSM layer showed in the last frame, to draw those that moved at half the side.
    moving: rsm::MovingLayers,
    /// The layers the last frame drew at half the side.
    half_layers: [u32; 8],
}

struct Passes {
    rsm: RsmPass,
    generate: generate::Generate,
    shade: wgpu::ComputePipeline,
    merge: wgpu::ComputePipeline,
    /// One per shading dispatch.
    shade_groups: Vec<wgpu::BindGroup>,
    bounce: wgpu::ComputePipeline,
    /// One per bounce after the first.
    bounce_groups: Vec<wgpu::BindGroup>,
    merge_group: wgpu::BindGroup,
}

/// What `vpl shade` counts (`WORK_*` in `shade.wgsl`).
const SHADE_WORK: &[&str] = &[
    "pixels",
    "VPL pairs",
    "shadow rays",
    "ray cells",
    "octree nodes",
];

/// VPLs of a subset summed together before their sum is added to the pixel's (`CHUNK` in
/// `shade.wgsl`).
const CHUNK: u32 = 8;

/// VPLs in each pixel's subset (the last subsets may hold one fewer).
fn subset_size(settings: &VplSettings) -> u32 {
    (settings.count * settings.bounces).div_ceil(settings.interleave * settings.interleave)
}

/// Lanes per pixel of a `shade` dispatch, one per VPL: the subset rounded up to a power of two,
/// 8 to 64 (a workgroup's 64 lanes hold 64 / lanes pixels).
fn shade_lanes(settings: &VplSettings) -> u32 {
    subset_size(settings).next_power_of_two().clamp(CHUNK, 64)
}

/// Shading dispatches per frame: [`shade_lanes`] VPLs of every subset each (one at the
/// defaults, 64 VPLs per subset).
fn shade_dispatches(settings: &VplSettings) -> u32 {
    subset_size(settings).div_ceil(shade_lanes(settings))
}

impl VplGi {
    /// The technique for `scene` at `width` x `height`; builds the scene's octree.
    pub fn new(
        ctx: &GpuContext,
        settings: &VplSettings,
        scene: &crate::scene::Scene,
        width: u32,
        height: u32,
    ) -> Result<VplGi> {
        settings.validate()?;
        let builder = SvoBuilder::new(ctx);
        let svo = builder.build_scene(ctx, scene, settings.resolution, OWNER)?;
        let animated = svo.has_dynamic();
        let octree = walk::SvoWalk::new(&svo, settings.end_offset)?;
        let usage = wgpu::BufferUsages::STORAGE;
        let octree_params =
            ctx.create_buffer_init(OWNER, "octree walk", bytemuck::bytes_of(&octree), usage);
        let b = settings.clamp * svo.grid().voxel_size;
        let shade = ShadeParams {
            count: settings.count * settings.bounces,
            interleave: settings.interleave,
            clamp_b: b * b,
            cull: settings.cull,
            normal_min: settings.normal_min,
            plane_tol: settings.plane_tol,
            filter: settings.filter as u32,
            sparse: settings.sparse_factor(height),
            lanes: shade_lanes(settings),
            roulette: settings.roulette,
        };
        let shade_params =
            ctx.create_buffer_init(OWNER, "shade params", bytemuck::bytes_of(&shade), usage);
        let layers = rsm::rsm_layer_count(
            &scene.lights,
            crate::frame::sky_light_count(scene),
            settings.sky_rsms,
        );
        let f = settings.sparse_factor(height);
        let sparse = (f > 1).then(|| SparseImage::new(ctx, OWNER, f, width, height));
        let (rw, rh) = (width.div_ceil(f), height.div_ceil(f));
        let raw = ctx.create_buffer(
            OWNER,
            &wgpu::BufferDescriptor {
                label: Some("interleaved irradiance"),
                size: rw as u64 * rh as u64 * 16,
                usage: wgpu::BufferUsages::STORAGE,
                mapped_at_creation: false,
            },
        );
        // Each dispatch's first chunk.
        let mut slots = vec![0u8; shade_dispatches(settings) as usize * SLOT as usize];
        for d in 0..shade_dispatches(settings) {
            let first = d * shade_lanes(settings) / CHUNK;
            slots[d as usize * SLOT as usize..][..4].copy_from_slice(&first.to_le_bytes());
        }
        let chunks = ctx.create_buffer_init(OWNER, "shading chunks", &slots, usage);
        let (texture, view) = crate::gi::indirect_target(ctx, OWNER, width, height);
        Ok(VplGi {
            rsm: RsmTargets::new(ctx, OWNER, layers, settings.rsm_size),
            settings: settings.clone(),
            svo,
            builder,
            animated,
            placeholder: ctx.create_buffer_init(OWNER, "placeholder", &[0; 16], usage),
            octree,
            octree_params,
            shade_params,
            raw,
            chunks,
            sparse,
            texture,
            view,
            passes: None,
            moving: rsm::MovingLayers::default(),
            half_layers: [0; 8],
        })
    }

    /// The octree the shadow rays walk.
    pub fn svo(&self) -> &Svo {
        &self.svo
    }

    /// The walk's parameters.
    pub fn octree(&self) -> &walk::SvoWalk {
        &self.octree
    }

    /// The VPLs of the last frame, `count` per bounce, bounce after bounce.
    pub fn read_vpls(&self, ctx: &GpuContext) -> Result<Vec<generate::Vpl>> {
        let Some(p) = &self.passes else {
            return Ok(Vec::new());
        };
        let bytes = crate::gpu::read_buffer(
            ctx,
            &p.generate.vpls,
            0,
            (self.settings.count * self.settings.bounces) as u64 * generate::VPL_BYTES,
        )?;
        Ok(generate::decode(&bytes))
    }

    /// Per RSM layer, whether the last frame drew it at half the side (in the corner of its
    /// targets; the rest holds an earlier frame's texels).
    pub fn half_layers(&self) -> Vec<bool> {
        (0..self.rsm.layers)
            .map(|l| l < 256 && self.half_layers[l as usize / 32] & (1 << (l % 32)) != 0)
            .collect()
    }

    /// The reflective shadow maps of the last frame, one image per layer.
    pub fn read_rsm(&self, ctx: &GpuContext) -> Result<Vec<rsm::RsmImage>> {
        (0..self.rsm.layers)
            .map(|layer| rsm::RsmImage::read(ctx, &self.rsm, layer))
            .collect()
    }

    /// The indirect-irradiance texture (`Rgba16Float`).
    pub fn indirect_texture(&self) -> &wgpu::Texture {
        &self.texture
    }

    fn build(&self, ctx: &GpuContext, frame: &GiFrame) -> Result<Passes> {
        let module = ctx.shader(
            "vpl shade",
            &library_shader("gi/vpl/shade", &[ctx.work_feature()]),
        );
        let shade_work = crate::gpu::work::entry(ctx, "vpl shade", SHADE_WORK)?;
        let shade = ctx.compute_pipeline("vpl shade", &module, "shade");
        let merge = ctx.compute_pipeline("vpl merge", &module, "merge");
        let walk = walk::walk_bindings(&self.octree_params, &self.svo, &self.placeholder);
        let (count, bounces) = (self.settings.count, self.settings.bounces);
        let generate = generate::Generate::new(ctx, OWNER, &self.rsm, count, count * bounces);
        let bounce_module = ctx.shader("vpl bounce", &library_shader("gi/vpl/bounce", &[]));
        let bounce = ctx.compute_pipeline("vpl bounce", &bounce_module, "bounce");
        let bounce_groups = (1..bounces)
            .map(|b| {
                let params: [u32; 4] = [count, (b - 1) * count, 0, 0];
                let params = ctx.create_buffer_init(
                    OWNER,
                    "bounce params",
                    bytemuck::bytes_of(&params),
                    wgpu::BufferUsages::STORAGE,
                );
                let mut entries = vec![
                    (5, generate.vpls.as_entire_binding()),
                    (6, params.as_entire_binding()),
                ];
                entries.extend(walk.clone());
                crate::gpu::pass::bind(ctx, &bounce, &entries)
            })
            .collect();
        let tex = wgpu::BindingResource::TextureView;
        let shade_group = |c: u32| {
            let mut entries = vec![
                (
                    13,
                    wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                        buffer: &self.chunks,
                        offset: c as u64 * SLOT,
                        size: wgpu::BufferSize::new(4),
                    }),
                ),
                (0, frame.camera_uniform.as_entire_binding()),
                (4, tex(frame.gbuffer.depth_view)),
                (5, tex(frame.gbuffer.normal_view)),
                (6, generate.vpls.as_entire_binding()),
                (7, self.shade_params.as_entire_binding()),
                (8, self.raw.as_entire_binding()),
            ];
            entries.extend(walk.clone());
            entries.extend(shade_work.clone());
            crate::gpu::pass::bind(ctx, &shade, &entries)
        };
        let shade_groups = (0..shade_dispatches(&self.settings))
            .map(shade_group)
            .collect();
        let merge_group = crate::gpu::pass::bind(
            ctx,
            &merge,
            &[
                (0, frame.camera_uniform.as_entire_binding()),
                (4, tex(frame.gbuffer.depth_view)),
                (5, tex(frame.gbuffer.normal_view)),
                (7, self.shade_params.as_entire_binding()),
                (9, self.raw.as_entire_binding()),
                (
                    10,
                    tex(self.sparse.as_ref().map_or(&self.view, |s| s.view())),
                ),
            ],
        );
        Ok(Passes {
            rsm: RsmPass::new(ctx, frame.scene_gpu, &self.rsm),
            generate,
            shade,
            merge,
            shade_groups,
            bounce,
            bounce_groups,
            merge_group,
        })
    }
}

impl GiTechnique for VplGi {
    fn name(&self) -> &str {
        "vpl"
    }

    fn update(&mut self, ctx: &GpuContext, frame: &GiFrame, timer: &mut PassTimer) -> Result<()> {
        if self.passes.is_none() {
            self.passes = Some(self.build(ctx, frame)?);
        }
        if self.animated {
            let moving = objects_triangles(frame.scene, frame.instant, true);
            self.builder
                .record_dynamic(ctx, timer, &mut self.svo, &moving)?;
        }
        let Some(p) = &self.passes else {
            return Ok(());
        };
        let layers: Vec<RsmLayer> = rsm::rsm_layers(
            &frame.instant.lights,
            frame.sky_lights,
            frame.shadow_layers,
            self.rsm.size,
            self.settings.sky_rsms,
        );
        let halve = self.settings.rsm_moving_half
            && self.rsm.size >= 2
            && self.rsm.layers <= rsm::MAX_HALF_LAYERS;
        let layers = self
            .moving
            .halve(frame.scene_gpu, layers, self.rsm.size, halve);
        self.half_layers = rsm::half_layer_mask(&layers, self.rsm.size);
        p.generate.set_half_layers(ctx, self.half_layers);
        p.rsm.update(ctx, &self.rsm, &layers);
        p.rsm
            .record(ctx, timer, frame.scene_gpu, &self.rsm, &layers, "vpl rsm")?;
        p.generate.record(timer, "vpl generate");
        if !p.bounce_groups.is_empty() {
            let n = self.settings.count;
            timer.pass("vpl bounce", |encoder, stamps| {
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("vpl bounce"),
                    timestamp_writes: stamps.compute(),
                });
                pass.set_pipeline(&p.bounce);
                for group in &p.bounce_groups {
                    pass.set_bind_group(0, group, &[]);
                    pass.dispatch_workgroups(n.div_ceil(64), 1, 1);
                }
            });
        }
        let f = self.sparse.as_ref().map_or(1, |s| s.factor());
        let (w, h) = (
            self.texture.width().div_ceil(f),
            self.texture.height().div_ceil(f),
        );
        let m = self.settings.interleave;
        timer.pass("vpl shade", |encoder, stamps| {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("vpl shade"),
                timestamp_writes: stamps.compute(),
            });
            pass.set_pipeline(&p.shade);
            // Workgroups of 64 / lanes pixels of a sub-image's row x a lane per VPL.
            let pixels = 64 / shade_lanes(&self.settings);
            for group in &p.shade_groups {
                pass.set_bind_group(0, group, &[]);
                pass.dispatch_workgroups(w.div_ceil(m).div_ceil(pixels), h.div_ceil(m), m * m);
            }
        });
        dispatch_groups(
            timer,
            "vpl merge",
            &p.merge,
            &p.merge_group,
            [w.div_ceil(8), h.div_ceil(8), 1],
        );
        if let Some(sparse) = &self.sparse {
            sparse.record(
                ctx,
                timer,
                "vpl upsample",
                frame.camera_uniform,
                frame.gbuffer,
                &self.view,
            )?;
        }
        Ok(())
    }

    fn indirect_view(&self) -> &wgpu::TextureView {
        &self.view
    }

    fn reference_transport(&self) -> crate::transport::Transport {
        // VPLs come from the lights' RSMs only, so emissive surfaces light nothing.
        crate::transport::Transport {
            bounces: crate::transport::Bounces::Indirect(self.settings.bounces),
            emissive: crate::transport::EmissiveSurfaces::Unlit,
        }
    }

    fn other_ledger_owners(&self) -> &[&'static str] {
        &[crate::voxel::svo::OWNER]
    }

    fn as_any(&self) -> Option<&dyn std::any::Any> {
        Some(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_automatic_sparse_factor_keeps_the_shaded_rows_of_1080p_above_it() {
        let s = VplSettings::default();
        let factors = [90, 180, 360, 720, 1080, 1440, 2160].map(|h| s.sparse_factor(h));
        assert_eq!(factors, [1, 1, 2, 5, 8, 10, 16]);
        // 2160p shades the rows 1080p shades: its shading follows the screen's share.
        assert_eq!(2160 / s.sparse_factor(2160), 1080 / s.sparse_factor(1080));
        let set = VplSettings {
            sparse: 3,
            ..VplSettings::default()
        };
        assert_eq!(set.sparse_factor(2160), 3, "a set factor is kept");
    }

    #[test]
    fn shade_dispatches_cover_every_vpl_of_a_subset_once_in_whole_chunks() {
        for count in [1, 7, 8, 100, 300, 1024, 4096, 65536] {
            for interleave in 1..=8 {
                let settings = VplSettings {
                    count,
                    interleave,
                    ..VplSettings::default()
                };
                let (subset, lanes) = (subset_size(&settings), shade_lanes(&settings));
                let dispatches = shade_dispatches(&settings);
                assert!(
                    [8, 16, 32, 64].contains(&lanes),
                    "{count} / {interleave}: {lanes}"
                );
                assert_eq!(lanes % CHUNK, 0);
                // Every VPL of the largest subset in a dispatch, no dispatch without one.
                assert!(dispatches * lanes >= subset && (dispatches - 1) * lanes < subset);
                // A subset that fits one workgroup's lanes is one dispatch with few idle lanes.
                if subset <= 64 {
                    assert_eq!(dispatches, 1);
                    assert!(lanes == CHUNK || lanes < 2 * subset, "{subset}: {lanes}");
                }
            }
        }
    }
}
