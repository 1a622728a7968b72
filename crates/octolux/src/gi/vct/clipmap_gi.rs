//! `vct-clipmap`: voxel cone tracing on the clipmap (`003` §3.2, §4): per frame the clipmap
//! follows the camera (and revoxelises around moving objects), direct light is injected into
//! its voxels, and every pixel gathers one bounce through six cones.

use super::cone::ConeParams;
use super::{CONE_WGSL, GATHER_WGSL};
use crate::gi::{GiFrame, GiTechnique};
use crate::gpu::{GpuContext, PassTimer};
use crate::render::dispatch_2d;
use crate::voxel::clipmap::{Clipmap, ClipmapOptions, ClipmapSettings};
use crate::voxel::sample::{ClipInfo, CLIPMAP_RADIANCE_WGSL, CLIPMAP_SAMPLE_WGSL};
use crate::voxel::{objects_triangles, scene_triangles_split, VoxelTriangle};
use crate::{Error, Result};

const OWNER: &str = "vct-clipmap";

/// Default sparse factor (see [`VctSettings::sparse`] and docs/vct.md for the measurements).
const SPARSE_DEFAULT: u32 = 4;

/// Settings of voxel cone tracing. Scene files: `[settings.vct]`.
#[derive(Clone, Debug, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct VctSettings {
    /// Voxels per side of every clipmap level, a power of two from 8 to 256 (default 64).
    pub resolution: u32,
    /// Clipmap levels, 1..=8 (default 4); the finest voxel is chosen so that the coarsest
    /// level, centred on the camera, reaches the scene's farthest point from where the camera
    /// is at the first frame (with 10 % to spare).
    pub levels: u32,
    /// Full aperture of the six diffuse cones in degrees (default 60: the ring's cones, 60
    /// degrees apart, touch).
    pub aperture: f32,
    /// Step along a cone as a fraction of its footprint (default 0.5).
    pub step: f32,
    /// Apex offset along the normal and first sample, in voxels of the finest level holding
    /// the surface (default 1.5): off the surface's own voxels.
    pub start: f32,
    /// Accumulated opacity at which a cone stops (default 0.95).
    pub stop_opacity: f32,
    /// Samples per shadow ray of the light injection (default 256).
    pub inject_steps: u32,
    /// Sparse tracing: one traced pixel per `sparse` x `sparse` block, the others
    /// reconstructed from the traced ones by depth and normal (1 = every pixel; 1..=8).
    pub sparse: u32,
}

impl Default for VctSettings {
    fn default() -> Self {
        VctSettings {
            resolution: 64,
            levels: 4,
            aperture: 60.0,
            step: 0.5,
            start: 1.5,
            stop_opacity: 0.95,
            inject_steps: 256,
            sparse: SPARSE_DEFAULT,
        }
    }
}

fn check(ok: bool, what: &str, range: &str) -> Result<()> {
    if ok {
        Ok(())
    } else {
        Err(Error::InvalidArgument(format!("{what} must be {range}")))
    }
}

impl VctSettings {
    /// Checks every value's range.
    pub fn validate(&self) -> Result<()> {
        check(
            self.resolution.is_power_of_two() && (8..=256).contains(&self.resolution),
            "vct resolution",
            "a power of two from 8 to 256",
        )?;
        check((1..=8).contains(&self.levels), "vct levels", "1..=8")?;
        check(
            self.aperture.is_finite() && self.aperture > 0.0 && self.aperture < 180.0,
            "vct aperture",
            "in (0, 180) degrees",
        )?;
        check(
            self.step.is_finite() && self.step >= 0.05 && self.step <= 4.0,
            "vct step",
            "0.05..=4",
        )?;
        check(
            self.start.is_finite() && (0.0..=16.0).contains(&self.start),
            "vct start",
            "0..=16 voxels",
        )?;
        check(
            self.stop_opacity.is_finite() && self.stop_opacity > 0.0 && self.stop_opacity <= 1.0,
            "vct stop_opacity",
            "in (0, 1]",
        )?;
        check(
            (1..=4096).contains(&self.inject_steps),
            "vct inject_steps",
            "1..=4096",
        )?;
        check((1..=8).contains(&self.sparse), "vct sparse", "1..=8")
    }
}

/// Uniform block of `trace.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct TraceParams {
    cone: ConeParams,
    misc: [f32; 4],
}

/// Voxel cone tracing on the clipmap.
pub struct VctClipmap {
    settings: VctSettings,
    /// Made at the first frame, sized from the camera's distance to the scene.
    clipmap: Option<Clipmap>,
    bounds: (glam::Vec3, glam::Vec3),
    /// Triangles of animated objects start here in the clipmap's scene.
    dynamic_from: usize,
    scene_set: bool,
    pipeline: wgpu::ComputePipeline,
    /// Sparse tracing: the reduced image and the reconstruction (None when every pixel is
    /// traced).
    sparse: Option<(wgpu::Texture, wgpu::TextureView, wgpu::ComputePipeline)>,
    params: wgpu::Buffer,
    info: wgpu::Buffer,
    texture: wgpu::Texture,
    view: wgpu::TextureView,
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
        let (lo, hi) = scene.bounds_at(0.0);
        let extent = (hi - lo).max_element();
        if !extent.is_finite() || extent <= 0.0 {
            return Err(Error::InvalidArgument(format!(
                "vct-clipmap needs a scene with extent; its bounds are {lo} to {hi}"
            )));
        }
        let source = [
            include_str!("../../render/common.wgsl"),
            CLIPMAP_SAMPLE_WGSL,
            CLIPMAP_RADIANCE_WGSL,
            CONE_WGSL,
            GATHER_WGSL,
            include_str!("sparse.wgsl"),
            include_str!("trace.wgsl"),
        ]
        .join("\n");
        let module = ctx.shader("vct trace", &source);
        let pipeline = ctx.compute_pipeline("vct trace", &module, "main");
        let f = settings.sparse;
        let sparse = (f > 1).then(|| {
            let texture = ctx.create_texture(
                OWNER,
                &wgpu::TextureDescriptor {
                    label: Some("sparse irradiance"),
                    size: wgpu::Extent3d {
                        width: width.div_ceil(f),
                        height: height.div_ceil(f),
                        depth_or_array_layers: 1,
                    },
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D2,
                    format: wgpu::TextureFormat::Rgba16Float,
                    usage: wgpu::TextureUsages::STORAGE_BINDING
                        | wgpu::TextureUsages::TEXTURE_BINDING,
                    view_formats: &[],
                },
            );
            let view = texture.create_view(&Default::default());
            let source = [
                include_str!("../../render/common.wgsl"),
                include_str!("sparse.wgsl"),
                include_str!("upsample.wgsl"),
            ]
            .join("\n");
            let module = ctx.shader("vct upsample", &source);
            let upsample = ctx.compute_pipeline("vct upsample", &module, "main");
            (texture, view, upsample)
        });
        let params = ctx.create_buffer(
            OWNER,
            &wgpu::BufferDescriptor {
                label: Some("trace params"),
                size: std::mem::size_of::<TraceParams>() as u64,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            },
        );
        let info = ctx.create_buffer(
            OWNER,
            &wgpu::BufferDescriptor {
                label: Some("clipmap info"),
                size: std::mem::size_of::<ClipInfo>() as u64,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            },
        );
        let (texture, view) = crate::gi::indirect_target(ctx, OWNER, width, height);
        Ok(VctClipmap {
            settings: settings.clone(),
            clipmap: None,
            bounds: (lo, hi),
            dynamic_from: 0,
            scene_set: false,
            pipeline,
            sparse,
            params,
            info,
            texture,
            view,
        })
    }

    /// Brings the clipmap's scene to this frame: the static triangles once, then the animated
    /// objects' triangles every frame (their old and new regions are revoxelised).
    fn sync_scene(&mut self, ctx: &GpuContext, frame: &GiFrame) -> Result<()> {
        if self.clipmap.is_none() {
            self.clipmap = Some(self.make_clipmap(ctx, frame.view.position)?);
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
        let params = TraceParams {
            cone: ConeParams {
                aperture: s.aperture.to_radians(),
                start: s.start * voxel,
                step: s.step,
                max_distance: 0.5 * span * voxel,
                voxel,
                stop_opacity: s.stop_opacity,
                max_steps: 512,
                pad: 0,
            },
            misc: [s.start, s.sparse as f32, 0.0, 0.0],
        };
        ctx.queue
            .write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
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
        // 2. Direct light into the voxels.
        clipmap.inject(ctx, timer, &frame.frame.lights, self.settings.inject_steps)?;
        // 3. Six cones per pixel through the injected radiance.
        ctx.queue.write_buffer(
            &self.info,
            0,
            bytemuck::bytes_of(&ClipInfo::new(&clipmap.settings, &clipmap.origins)),
        );
        let Some(radiance) = &clipmap.radiance else {
            return Err(Error::Gpu("vct-clipmap: no injected radiance".into()));
        };
        let tex = wgpu::BindingResource::TextureView;
        let traced = self.sparse.as_ref().map_or(&self.view, |(_, view, _)| view);
        let group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("vct trace"),
            layout: &self.pipeline.get_bind_group_layout(0),
            entries: &[
                (0, frame.camera_uniform.as_entire_binding()),
                (1, tex(&frame.gbuffer.depth_view)),
                (2, tex(&frame.gbuffer.normal_view)),
                (3, self.info.as_entire_binding()),
                (4, radiance.as_entire_binding()),
                (5, self.params.as_entire_binding()),
                (6, tex(traced)),
            ]
            .map(|(binding, resource)| wgpu::BindGroupEntry { binding, resource }),
        });
        let (w, h) = (self.texture.width(), self.texture.height());
        let f = self.settings.sparse;
        let (tw, th) = (w.div_ceil(f), h.div_ceil(f));
        dispatch_2d(timer, "vct trace", &self.pipeline, &group, tw, th);
        // 4. Sparse tracing: the untraced pixels from the traced ones.
        if let Some((_, view, upsample)) = &self.sparse {
            let group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("vct upsample"),
                layout: &upsample.get_bind_group_layout(0),
                entries: &[
                    (0, frame.camera_uniform.as_entire_binding()),
                    (1, tex(&frame.gbuffer.depth_view)),
                    (2, tex(&frame.gbuffer.normal_view)),
                    (3, tex(view)),
                    (4, self.params.as_entire_binding()),
                    (5, tex(&self.view)),
                ]
                .map(|(binding, resource)| wgpu::BindGroupEntry { binding, resource }),
            });
            dispatch_2d(timer, "vct upsample", upsample, &group, w, h);
        }
        Ok(())
    }

    fn indirect_view(&self) -> &wgpu::TextureView {
        &self.view
    }

    fn reference_bounces(&self) -> crate::reference::Bounces {
        crate::reference::Bounces::Indirect(1)
    }

    fn as_any(&self) -> Option<&dyn std::any::Any> {
        Some(self)
    }
}
