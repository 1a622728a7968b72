//! `vct-clipmap`: voxel cone tracing on the clipmap (`003` §3.2, §4): per frame the clipmap
//! follows the camera (and revoxelises around moving objects), direct light (plus, with
//! multiple bounces, the indirect light the voxels gathered last frame) is injected into its
//! voxels, and every pixel gathers through six cones.

use super::bounce_list::{bounce_spread, BounceList};
use super::clipmap_tail::{tail_levels, ClipmapTail};
use super::cone::ConeParams;
use super::tracer::{ConeTracer, TraceStructure};
use super::{ClipmapInjection, VctSettings, VctStructure};
use crate::gi::{GiFrame, GiTechnique};
use crate::gpu::pass::{dispatch_1d, KeptBindGroup};
use crate::gpu::{GpuContext, PassTimer};
use crate::voxel::clipmap::sample::{
    clip_bindings, ClipInfo, CLIP_BINDINGS, CLIP_RADIANCE_BINDING,
};
use crate::voxel::clipmap::UpdateBox;
use crate::voxel::clipmap::{Clipmap, ClipmapOptions, ClipmapSettings};
use crate::voxel::{objects_triangles, scene_triangles_split, VoxelTriangle};
use crate::{Error, Result};

const OWNER: &str = "vct-clipmap";

/// Voxel cone tracing on the clipmap.
pub struct VctClipmap {
    settings: VctSettings,
    /// Made at the first frame, sized from the camera's distance to the scene.
    clipmap: Option<Clipmap>,
    bounds: (glam::Vec3, glam::Vec3),
    /// Triangles of animated objects start here in the clipmap's scene.
    dynamic_from: usize,
    scene_set: bool,
    tracer: ConeTracer,
    info: wgpu::Buffer,
    /// Coarser copies of the coarsest level, for wide cones.
    tail: ClipmapTail,
    /// Multiple bounces (`multi_bounce`).
    bounce: Option<ClipmapBounce>,
}

/// Multiple bounces on the clipmap: the indirect irradiance every voxel slot gathered last
/// frame (RGBA16F per slot, layout of the clipmap's voxels), the gather over the listed
/// voxels (`clipmap_bounce.wgsl`: the list, its indirect dispatch, the gather) and the pass
/// that clears the revoxelised boxes.
struct ClipmapBounce {
    irradiance: wgpu::Buffer,
    /// The voxels that gather this frame.
    list: BounceList,
    gather: wgpu::ComputePipeline,
    clear: wgpu::ComputePipeline,
    params: wgpu::Buffer,
    /// The boxes a frame clears, one `BounceBox` per [`BOX_STRIDE`] (grown when a frame has
    /// more than it holds), and the clear's bind group per box and the gather's, kept while
    /// their resources are.
    boxes: wgpu::Buffer,
    clear_groups: Vec<KeptBindGroup>,
    gather_group: KeptBindGroup,
    /// Frames gathered so far: picks this frame's set of voxels (`bounce_frames`).
    frame: u32,
}

/// Boxes the clear's box buffer holds at first.
const BOX_ROOM: u64 = 16;

/// The clear's box buffer for `boxes` boxes.
fn box_buffer(ctx: &GpuContext, boxes: u64) -> wgpu::Buffer {
    ctx.create_buffer(
        OWNER,
        &wgpu::BufferDescriptor {
            label: Some("bounce boxes"),
            size: boxes * BOX_STRIDE,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        },
    )
}

/// Stride of the boxes in the per-frame box buffer (a storage binding offset alignment).
const BOX_STRIDE: u64 = 256;

/// The `BounceBox` words of `clipmap_bounce.wgsl` for box `b` of a clipmap of `res`^3 voxels
/// per level.
fn bounce_box_words(b: &UpdateBox, res: u32) -> [i32; 8] {
    let size = (b.hi - b.lo).max(glam::IVec3::ZERO);
    let first = (b.level as u64 * (res as u64).pow(3)) as u32;
    [
        b.lo.x,
        b.lo.y,
        b.lo.z,
        0,
        size.x,
        size.y,
        size.z,
        first as i32,
    ]
}

impl VctClipmap {
    /// The technique for `scene` at `width` x `height`.
    pub fn new(
        ctx: &GpuContext,
        settings: &VctSettings,
        scene: &crate::scene::Scene,
        width: u32,
        height: u32,
    ) -> Result<VctClipmap> {
        settings.validate()?;
        let (lo, hi) = scene.gi_bounds_at(0.0);
        let extent = (hi - lo).max_element();
        if !extent.is_finite() || extent <= 0.0 {
            return Err(Error::InvalidArgument(format!(
                "vct-clipmap needs a scene with extent; its bounds are {lo} to {hi}"
            )));
        }
        let tracer = ConeTracer::new(
            ctx,
            OWNER,
            TraceStructure {
                trace: "gi/vct/clipmap_trace",
                bounce: "gi/vct/clipmap_bounce",
                features: Vec::new(),
                bounce_features: Vec::new(),
                octree: false,
            },
            settings,
            settings.diffuse_cones(VctStructure::Clipmap),
            settings.bounce_cones(VctStructure::Clipmap),
            width,
            height,
        );
        let bounce = settings.multi_bounce.then(|| {
            let res = settings.resolution as u64;
            let slots = settings.levels as u64 * res * res * res;
            let module = tracer.bounce_module(ctx);
            ClipmapBounce {
                list: BounceList::new(ctx, OWNER, &module, slots as u32),
                irradiance: ctx.create_buffer(
                    OWNER,
                    &wgpu::BufferDescriptor {
                        label: Some("bounce irradiance"),
                        size: slots * 8,
                        usage: wgpu::BufferUsages::STORAGE,
                        mapped_at_creation: false,
                    },
                ),
                gather: ctx.compute_pipeline("bounce", &module, "bounce"),
                clear: ctx.compute_pipeline("bounce_clear", &module, "bounce_clear"),
                params: ctx.create_buffer_init(
                    OWNER,
                    "bounce params",
                    bytemuck::cast_slice(&[slots as u32, 0, 0, 0]),
                    wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                ),
                boxes: box_buffer(ctx, BOX_ROOM),
                clear_groups: Vec::new(),
                gather_group: KeptBindGroup::default(),
                frame: 0,
            }
        });
        let info = ctx.create_buffer(
            OWNER,
            &wgpu::BufferDescriptor {
                label: Some("clipmap info"),
                size: std::mem::size_of::<ClipInfo>() as u64,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            },
        );
        let tail = ClipmapTail::new(ctx, OWNER, settings.resolution);
        Ok(VctClipmap {
            settings: settings.clone(),
            clipmap: None,
            bounds: (lo, hi),
            dynamic_from: 0,
            scene_set: false,
            tracer,
            info,
            tail,
            bounce,
        })
    }

    /// The clipmap, once the first frame made it (for tests and tools).
    pub fn clipmap(&self) -> Option<&Clipmap> {
        self.clipmap.as_ref()
    }

    /// Multiple bounces, before the injection: the slots of every box the clipmap rewrote
    /// this frame lose their bounce light (a wrapped slot holds another voxel now; a moving
    /// object changed the voxels around it).
    fn clear_revoxelised(&mut self, ctx: &GpuContext, timer: &mut PassTimer, boxes: &[UpdateBox]) {
        let Some(b) = &mut self.bounce else { return };
        let boxes: Vec<&UpdateBox> = boxes.iter().filter(|b| b.volume() > 0).collect();
        if boxes.is_empty() {
            return;
        }
        let mut bytes = vec![0u8; boxes.len() * BOX_STRIDE as usize];
        for (k, ub) in boxes.iter().enumerate() {
            let words = bounce_box_words(ub, self.settings.resolution);
            let at = k * BOX_STRIDE as usize;
            bytes[at..at + 32].copy_from_slice(bytemuck::bytes_of(&words));
        }
        if b.boxes.size() < bytes.len() as u64 {
            b.boxes = box_buffer(ctx, (boxes.len() as u64).next_power_of_two());
        }
        ctx.queue.write_buffer(&b.boxes, 0, &bytes);
        b.clear_groups
            .resize_with(b.clear_groups.len().max(boxes.len()), Default::default);
        for (k, ub) in boxes.iter().enumerate() {
            let entries = [
                (CLIP_BINDINGS, self.info.as_entire_binding()),
                (22, b.irradiance.as_entire_binding()),
                (
                    23,
                    wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                        buffer: &b.boxes,
                        offset: k as u64 * BOX_STRIDE,
                        size: wgpu::BufferSize::new(32),
                    }),
                ),
            ];
            let group = b.clear_groups[k].get(ctx, "bounce clear", &b.clear, &entries);
            dispatch_1d(timer, "bounce clear", &b.clear, &group, ub.volume() as u32);
        }
    }

    /// Brings the clipmap's scene to this frame: the static triangles once, then the animated
    /// objects' triangles every frame (their old and new regions are revoxelised).
    fn sync_scene(&mut self, ctx: &GpuContext, frame: &GiFrame) -> Result<()> {
        if self.clipmap.is_none() {
            let mut clipmap = self.make_clipmap(ctx, frame.view.position)?;
            clipmap.set_bounce(self.bounce.as_ref().map(|b| b.irradiance.clone()))?;
            self.clipmap = Some(clipmap);
        }
        let Some(clipmap) = self.clipmap.as_mut() else {
            return Ok(());
        };
        if !self.scene_set {
            let (still, moving) = scene_triangles_split(frame.scene, frame.frame);
            let mut all: Vec<VoxelTriangle> = still;
            self.dynamic_from = all.len();
            all.extend(moving);
            clipmap.set_scene(ctx, &all);
            self.scene_set = true;
        } else if frame.scene.objects.iter().any(|o| o.animation.is_some()) {
            // Only the animated objects' triangles, every frame; none for a static scene.
            let moving = objects_triangles(frame.scene, frame.frame, true);
            clipmap.replace_triangles(ctx, self.dynamic_from, &moving)?;
        }
        Ok(())
    }

    /// The clipmap for a camera at `camera`, and the trace parameters that go with its voxel.
    fn make_clipmap(&self, ctx: &GpuContext, camera: glam::Vec3) -> Result<Clipmap> {
        let s = &self.settings;
        let (lo, hi) = self.bounds;
        let far = (0..8)
            .map(|k| {
                let corner = glam::Vec3::new(
                    if k & 1 == 0 { lo.x } else { hi.x },
                    if k & 2 == 0 { lo.y } else { hi.y },
                    if k & 4 == 0 { lo.z } else { hi.z },
                );
                (corner - camera).abs().max_element()
            })
            .fold(0.0f32, f32::max);
        let span = s.resolution as f32 * (1u32 << (s.levels - 1)) as f32;
        let voxel = 2.2 * far / span;
        // Footprints grow up to the tail's coarsest voxel; past it, steps stay that size.
        let coarsest = voxel * (1u32 << (s.levels - 1 + tail_levels(s.resolution))) as f32;
        if !voxel.is_finite() || voxel <= 0.0 {
            return Err(Error::InvalidArgument(format!(
                "vct-clipmap: no clipmap fits a camera at {camera} and scene bounds {lo} to {hi}"
            )));
        }
        let clip = ClipmapSettings {
            resolution: s.resolution,
            levels: s.levels,
            voxel_size: voxel,
        };
        self.tracer.set_cone(
            ctx,
            |cones| ConeParams::for_settings(s, cones, voxel, coarsest, 0.5 * span * voxel),
            s,
        );
        Clipmap::with_owner(
            ctx,
            clip,
            ClipmapOptions {
                filtered: true,
                anisotropic: false,
            },
            OWNER,
        )
    }
}

impl GiTechnique for VctClipmap {
    fn name(&self) -> &str {
        "vct-clipmap"
    }

    fn update(&mut self, ctx: &GpuContext, frame: &GiFrame, timer: &mut PassTimer) -> Result<()> {
        // 1. Voxels: the clipmap follows the camera; moving objects are revoxelised.
        self.sync_scene(ctx, frame)?;
        let Some(clipmap) = self.clipmap.as_mut() else {
            return Ok(());
        };
        clipmap.follow(ctx, timer, frame.view.position)?;
        ctx.queue.write_buffer(
            &self.info,
            0,
            bytemuck::bytes_of(&ClipInfo::new(&clipmap.settings, &clipmap.origins)),
        );
        // 2. Multiple bounces: the voxels the clipmap rewrote lose the bounce light they had.
        let boxes = clipmap.last_revoxelised().to_vec();
        self.clear_revoxelised(ctx, timer, &boxes);
        let Some(clipmap) = self.clipmap.as_mut() else {
            return Ok(());
        };
        // 3. Direct light (plus, with multiple bounces, the indirect irradiance the voxels
        //    gathered last frame) into the voxels.
        match self.settings.injection {
            ClipmapInjection::ShadowMaps => clipmap.inject_shadow_maps(
                ctx,
                timer,
                frame.lights,
                frame.frame.lights.len() as u32,
                frame.shadows.lookup(),
            )?,
            ClipmapInjection::VoxelRays => {
                clipmap.inject(ctx, timer, &frame.frame.lights, self.settings.inject_steps)?
            }
        }
        let Some(radiance) = &clipmap.radiance else {
            return Err(Error::Gpu("vct-clipmap: no injected radiance".into()));
        };
        // 4. The tail: coarser copies of the coarsest level, for wide cones.
        self.tail.record(ctx, timer, &self.info, radiance);
        // 5. Multiple bounces: this frame's set of voxels gathers indirect irradiance for the
        //    next frame (every voxel once in `bounce_frames` frames).
        if let Some(b) = &mut self.bounce {
            let spread = bounce_spread(self.settings.bounce_frames, b.frame);
            ctx.queue
                .write_buffer(&b.params, 12, bytemuck::bytes_of(&spread));
            b.frame = b.frame.wrapping_add(1);
            let [info, voxels] = clip_bindings(&self.info, &clipmap.voxels);
            let shared = [
                (21, clipmap.normals.as_entire_binding()),
                (22, b.irradiance.as_entire_binding()),
            ];
            let mut entries = vec![
                info.clone(),
                (CLIP_RADIANCE_BINDING, radiance.as_entire_binding()),
                (5, self.tracer.bounce_params().as_entire_binding()),
                (13, self.tail.buffer.as_entire_binding()),
            ];
            entries.extend(shared.iter().cloned());
            entries.extend(b.list.gather_entries());
            entries.extend(self.tracer.bounce_work(ctx, "bounce")?);
            let gather = b.gather_group.get(ctx, "vct bounce", &b.gather, &entries);
            let mut list = vec![info, voxels, (20, b.params.as_entire_binding())];
            list.extend(shared);
            b.list
                .record(ctx, timer, "bounce", &list, &b.gather, &gather);
        }
        // 6. Six cones per pixel through the injected radiance (sparse, then reconstructed;
        //    the specular cone where enabled).
        self.tracer.record(
            ctx,
            frame,
            timer,
            &[
                (CLIP_BINDINGS, self.info.as_entire_binding()),
                (CLIP_RADIANCE_BINDING, radiance.as_entire_binding()),
                (13, self.tail.buffer.as_entire_binding()),
            ],
        )
    }

    fn indirect_view(&self) -> &wgpu::TextureView {
        self.tracer.view()
    }

    fn specular_view(&self) -> Option<&wgpu::TextureView> {
        self.tracer.specular().map(|(_, view)| view)
    }

    fn reference_transport(&self) -> crate::transport::Transport {
        super::cone_transport(self.bounce.is_some())
    }

    fn as_any(&self) -> Option<&dyn std::any::Any> {
        Some(self)
    }
}
