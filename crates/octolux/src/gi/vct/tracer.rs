//! The passes both cone-tracing techniques share once their structure holds injected
//! radiance: the diffuse gather (`trace.wgsl`, every pixel or one per sparse block), the sparse
//! reconstruction (`upsample.wgsl`) and the optional specular cone. The structure comes in as
//! WGSL (`vct_sample`, `vct_surface_voxel` and their bindings) and as bind-group entries, so
//! the octree and the clipmap differ only there.

use super::cone::ConeParams;
use super::{DiffuseCones, VctSettings, CONE_WGSL, GATHER_WGSL};
use crate::gi::GiFrame;
use crate::gpu::pass::{dispatch_2d, KeptBindGroup};
use crate::gpu::{GpuContext, PassTimer};

/// `TraceParams` of `trace.wgsl` (a read-only storage block).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct TraceParams {
    cone: ConeParams,
    misc: [f32; 4],
}

/// An image of the technique's: texture, view and the pipeline that writes it.
struct Stage {
    texture: wgpu::Texture,
    view: wgpu::TextureView,
    pipeline: wgpu::ComputePipeline,
}

/// The gather, reconstruction and specular passes over one structure.
pub(crate) struct ConeTracer {
    /// The trace module: the gather, the specular cone and any entry point the structure's
    /// WGSL adds (the bounce gather).
    module: wgpu::ShaderModule,
    /// The voxels' bounce gather: its cones, and its module where the cone set differs from
    /// the pixels' (`None`: `module`), and its parameters (binding 5 of its passes).
    bounce: DiffuseCones,
    bounce_module: Option<wgpu::ShaderModule>,
    bounce_params: wgpu::Buffer,
    sparse: u32,
    trace: wgpu::ComputePipeline,
    /// Sparse tracing: the reduced image and the reconstruction into the full one.
    upsample: Option<Stage>,
    specular: Option<Stage>,
    params: wgpu::Buffer,
    texture: wgpu::Texture,
    view: wgpu::TextureView,
    /// The technique's diffuse cones (the settings' or its structure's defaults).
    diffuse: DiffuseCones,
    /// The trace, upsample and specular passes' bind groups, kept while their resources are.
    groups: [KeptBindGroup; 3],
}

/// A texture of the technique's (`Rgba16Float`, written by compute, read by the next pass).
fn image(
    ctx: &GpuContext,
    owner: &str,
    label: &str,
    width: u32,
    height: u32,
) -> (wgpu::Texture, wgpu::TextureView) {
    crate::gpu::alloc::image_target(
        ctx,
        owner,
        label,
        width,
        height,
        wgpu::TextureFormat::Rgba16Float,
        wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::TEXTURE_BINDING,
    )
}

impl ConeTracer {
    /// The passes for images of `width` x `height` over the structure whose sampling WGSL is
    /// `structure` (its sampler, then its `*_trace.wgsl`), recorded under `owner`, the pixels
    /// gathering with the `diffuse` cones and the voxels' bounce gather with the `bounce`
    /// cones.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn new(
        ctx: &GpuContext,
        owner: &str,
        structure: &[&str],
        settings: &VctSettings,
        diffuse: DiffuseCones,
        bounce: DiffuseCones,
        width: u32,
        height: u32,
    ) -> ConeTracer {
        let common = include_str!("../../frame/common.wgsl");
        let sparse_wgsl = include_str!("sparse.wgsl");
        let module_with = |label: &str, cones: u32| {
            let cone_set = super::gather::cone_set_wgsl(cones);
            let source = [common, cone_set.as_str()]
                .iter()
                .chain(structure)
                .chain(&[
                    CONE_WGSL,
                    GATHER_WGSL,
                    sparse_wgsl,
                    include_str!("trace.wgsl"),
                ])
                .copied()
                .collect::<Vec<_>>()
                .join("\n");
            ctx.shader(label, &source)
        };
        let module = module_with("vct trace", diffuse.cones);
        let bounce_module =
            (bounce.cones != diffuse.cones).then(|| module_with("vct bounce", bounce.cones));
        let trace = ctx.compute_pipeline("vct trace", &module, "main");
        let specular = settings.specular.then(|| {
            let (texture, view) = image(ctx, owner, "specular radiance", width, height);
            Stage {
                view,
                texture,
                pipeline: ctx.compute_pipeline("vct specular", &module, "specular"),
            }
        });
        let f = settings.sparse;
        let upsample = (f > 1).then(|| {
            let (texture, view) = image(
                ctx,
                owner,
                "sparse irradiance",
                width.div_ceil(f),
                height.div_ceil(f),
            );
            let source = [common, sparse_wgsl, include_str!("upsample.wgsl")].join("\n");
            let module = ctx.shader("vct upsample", &source);
            Stage {
                view,
                texture,
                pipeline: ctx.compute_pipeline("vct upsample", &module, "main"),
            }
        });
        let params_buffer = |label| {
            ctx.create_buffer(
                owner,
                &wgpu::BufferDescriptor {
                    label: Some(label),
                    size: std::mem::size_of::<TraceParams>() as u64,
                    usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                },
            )
        };
        let params = params_buffer("trace params");
        let bounce_params = params_buffer("bounce trace params");
        let (texture, view) = crate::gi::indirect_target(ctx, owner, width, height);
        ConeTracer {
            module,
            bounce,
            bounce_module,
            bounce_params,
            sparse: f,
            trace,
            upsample,
            specular,
            params,
            texture,
            view,
            diffuse,
            groups: Default::default(),
        }
    }

    /// Sets how cones are marched: `cone(cones)` for the pixels' and the bounce's cones (its
    /// `voxel` the finest voxel, its `start` unused: the trace derives both from the voxel
    /// where each surface is), their start offsets, the settings' sparse factor, specular
    /// aperture and the specular cone's fixed sample count.
    pub(crate) fn set_cone(
        &self,
        ctx: &GpuContext,
        cone: impl Fn(DiffuseCones) -> ConeParams,
        settings: &VctSettings,
    ) {
        for (cones, buffer) in [
            (self.diffuse, &self.params),
            (self.bounce, &self.bounce_params),
        ] {
            let params = TraceParams {
                cone: cone(cones),
                misc: [
                    cones.start,
                    settings.sparse as f32,
                    settings.specular_aperture(),
                    settings.specular_steps as f32,
                ],
            };
            ctx.queue
                .write_buffer(buffer, 0, bytemuck::bytes_of(&params));
        }
    }

    /// Records the gather (and the reconstruction and specular cone where enabled) with the
    /// structure bound at `structure`'s bindings.
    pub(crate) fn record(
        &self,
        ctx: &GpuContext,
        frame: &GiFrame,
        timer: &mut PassTimer,
        structure: &[(u32, wgpu::BindingResource)],
    ) {
        let tex = wgpu::BindingResource::TextureView;
        let bind = |kept: &KeptBindGroup, label: &str, pipeline, out: u32, view| {
            let mut entries = vec![
                (0, frame.camera_uniform.as_entire_binding()),
                (1, tex(&frame.gbuffer.depth_view)),
                (2, tex(&frame.gbuffer.normal_view)),
                (5, self.params.as_entire_binding()),
                (out, tex(view)),
            ];
            entries.extend(structure.iter().cloned());
            kept.get(ctx, label, pipeline, &entries)
        };
        let (w, h) = (self.texture.width(), self.texture.height());
        // 1. Six cones per traced pixel.
        let traced = self.upsample.as_ref().map_or(&self.view, |s| &s.view);
        let group = bind(&self.groups[0], "vct trace", &self.trace, 6, traced);
        let f = self.sparse;
        dispatch_2d(
            timer,
            "trace",
            &self.trace,
            &group,
            w.div_ceil(f),
            h.div_ceil(f),
        );
        // 2. Sparse tracing: the untraced pixels from the traced ones.
        if let Some(up) = &self.upsample {
            let entries = [
                (0, frame.camera_uniform.as_entire_binding()),
                (1, tex(&frame.gbuffer.depth_view)),
                (2, tex(&frame.gbuffer.normal_view)),
                (3, tex(&up.view)),
                (4, self.params.as_entire_binding()),
                (5, tex(&self.view)),
            ];
            let group = self.groups[1].get(ctx, "vct upsample", &up.pipeline, &entries);
            dispatch_2d(timer, "upsample", &up.pipeline, &group, w, h);
        }
        // 3. The optional specular cone, every pixel.
        if let Some(spec) = &self.specular {
            let group = bind(
                &self.groups[2],
                "vct specular",
                &spec.pipeline,
                30,
                &spec.view,
            );
            dispatch_2d(timer, "specular", &spec.pipeline, &group, w, h);
        }
    }

    /// The bounce gather's parameters (`TraceParams`, binding 5 of its passes).
    pub(crate) fn bounce_params(&self) -> &wgpu::Buffer {
        &self.bounce_params
    }

    /// A pipeline of the bounce gather's entry point `entry` (one the structure's WGSL adds),
    /// compiled with the bounce's cone set.
    pub(crate) fn bounce_pipeline(&self, ctx: &GpuContext, entry: &str) -> wgpu::ComputePipeline {
        let module = self.bounce_module.as_ref().unwrap_or(&self.module);
        ctx.compute_pipeline(entry, module, entry)
    }

    /// Indirect irradiance (rgb, W/m^2) and ambient occlusion (alpha).
    pub(crate) fn view(&self) -> &wgpu::TextureView {
        &self.view
    }

    /// The specular cone's radiance, when enabled.
    pub(crate) fn specular(&self) -> Option<(&wgpu::Texture, &wgpu::TextureView)> {
        self.specular.as_ref().map(|s| (&s.texture, &s.view))
    }
}
