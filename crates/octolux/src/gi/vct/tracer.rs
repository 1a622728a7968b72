//! The passes both cone-tracing techniques share once their structure holds injected
//! radiance: the diffuse gather (`trace.wgsl`, every pixel or one per sparse block), the sparse
//! reconstruction (`frame::sparse`) and the optional specular cone. The structure comes in as
//! a WGSL module composed in as `gi/vct/structure` (`vct_sample`, `vct_surface_voxel` and the
//! bindings they read), its bounce module and as bind-group entries, so the octree and the
//! clipmap differ only there.

use super::cone::ConeParams;
use super::{cone_set_wgsl, gather::cone_lanes, DiffuseCones, VctSettings};
use crate::frame::sparse::SparseImage;
use crate::gi::GiFrame;
use crate::gpu::pass::{dispatch_1d, dispatch_2d, KeptBindGroup};
use crate::gpu::shader::{library_shader_with, module_source};
use crate::gpu::{GpuContext, PassTimer};
use crate::Result;

/// The structure a [`ConeTracer`] marches: its trace module (composed in as
/// `gi/vct/structure` for `trace.wgsl` and the marcher), its bounce gather's module and the `@if`
/// flags each is composed with.
pub(crate) struct TraceStructure {
    /// Module path of the structure's `vct_sample` and `vct_surface_voxel`.
    pub trace: &'static str,
    /// Module path of the voxels' bounce gather (its entry points).
    pub bounce: &'static str,
    /// The pixels' gather's `@if` flags.
    pub features: Vec<(&'static str, bool)>,
    /// The voxels' bounce gather's `@if` flags.
    pub bounce_features: Vec<(&'static str, bool)>,
    /// Whether its samples are octree lookups (counted as work after the cones' samples).
    pub octree: bool,
}

/// What the pixels' gather counts (`trace.wgsl`), and the octree's lookups after them.
const TRACE_WORK: [&str; 5] = [
    "pixels",
    "cones",
    "cone samples",
    "octree lookups",
    "octree nodes",
];
/// What the voxels' bounce gather counts (`svo_bounce.wgsl`, `clipmap_bounce.wgsl`): the
/// lanes launched (a GPU runs a SIMD group of lanes as long as its slowest lane), then the
/// voxels that gathered and their cones' work.
const BOUNCE_WORK: [&str; 6] = [
    "lanes",
    "voxels",
    "cones",
    "cone samples",
    "octree lookups",
    "octree nodes",
];

impl TraceStructure {
    /// `work` without the octree's two quantities (last) for a structure without an octree.
    fn work<const N: usize>(&self, work: &'static [&'static str; N]) -> &'static [&'static str] {
        &work[..if self.octree { N } else { N - 2 }]
    }
}

impl TraceStructure {
    /// The WGSL of `main` over this structure with the cone set of `cones` cones and the
    /// `@if` flags `features`.
    fn compose(&self, main: &str, cones: u32, features: &[(&str, bool)]) -> String {
        let set = cone_set_wgsl(cones);
        let structure = module_source(self.trace)
            .unwrap_or_else(|| panic!("internal shader error: no module {}", self.trace));
        library_shader_with(
            main,
            features,
            &[("gi/vct/cone_set", &set), ("gi/vct/structure", structure)],
        )
    }
}

/// `TraceParams` of `trace.wgsl` (a read-only storage block).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct TraceParams {
    cone: ConeParams,
    /// Apex offset along the normal and first sample, in voxels of the surface's level.
    apex_offset: f32,
    /// Sparse factor f: one traced pixel per f x f block.
    sparse: u32,
    /// The specular cone's full aperture (radians).
    specular_aperture: f32,
    /// The specular cone's fixed sample count (0: none).
    specular_steps: u32,
}

/// An image of the technique's: texture, view and the pipeline that writes it.
struct Stage {
    texture: wgpu::Texture,
    view: wgpu::TextureView,
    pipeline: wgpu::ComputePipeline,
}

/// The gather, reconstruction and specular passes over one structure.
pub(crate) struct ConeTracer {
    /// The structure, for the bounce gather's module (composed when asked for).
    structure: TraceStructure,
    /// The voxels' bounce gather: its cones and its parameters (binding 5 of its passes).
    bounce: DiffuseCones,
    bounce_params: wgpu::Buffer,
    sparse: u32,
    trace: wgpu::ComputePipeline,
    /// Sparse tracing: the reduced image and the reconstruction into the full one.
    upsample: Option<SparseImage>,
    specular: Option<Stage>,
    params: wgpu::Buffer,
    texture: wgpu::Texture,
    view: wgpu::TextureView,
    /// The technique's diffuse cones (the settings' or its structure's defaults).
    diffuse: DiffuseCones,
    /// The trace and specular passes' bind groups, kept while their resources are.
    groups: [KeptBindGroup; 2],
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
    /// The passes for images of `width` x `height` over `structure`, recorded under `owner`,
    /// the pixels gathering with the `diffuse` cones and the voxels' bounce gather with the
    /// `bounce` cones.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn new(
        ctx: &GpuContext,
        owner: &str,
        mut structure: TraceStructure,
        settings: &VctSettings,
        diffuse: DiffuseCones,
        bounce: DiffuseCones,
        width: u32,
        height: u32,
    ) -> ConeTracer {
        structure.features.push(ctx.work_feature());
        structure.bounce_features.push(ctx.work_feature());
        let module = ctx.shader(
            "vct trace",
            &structure.compose("gi/vct/trace", diffuse.cones, &structure.features),
        );
        let trace = ctx.compute_pipeline("vct trace", &module, "main");
        let specular = settings.specular.then(|| {
            let (texture, view) = image(ctx, owner, "specular radiance", width, height);
            Stage {
                view,
                texture,
                pipeline: ctx.compute_pipeline("vct specular", &module, "specular"),
            }
        });
        let f = settings.sparse_factor(height);
        let upsample = (f > 1).then(|| SparseImage::new(ctx, owner, f, width, height));
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
            structure,
            bounce,
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
    /// where each surface is), their start offsets, the sparse factor in use, specular
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
                apex_offset: cones.start,
                sparse: self.sparse,
                specular_aperture: settings.specular_aperture(),
                specular_steps: settings.specular_steps,
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
    ) -> Result<()> {
        let tex = wgpu::BindingResource::TextureView;
        let work = crate::gpu::work::entry(ctx, "trace", self.structure.work(&TRACE_WORK))?;
        let bind = |kept: &KeptBindGroup, label: &str, pipeline, out: u32, view, counted| {
            let mut entries = vec![
                (0, frame.camera_uniform.as_entire_binding()),
                (1, tex(frame.gbuffer.depth_view)),
                (2, tex(frame.gbuffer.normal_view)),
                (5, self.params.as_entire_binding()),
                (out, tex(view)),
            ];
            entries.extend(structure.iter().cloned());
            entries.extend(counted);
            kept.get(ctx, label, pipeline, &entries)
        };
        let (w, h) = (self.texture.width(), self.texture.height());
        // 1. The diffuse cones of each traced pixel, spread over its lanes.
        let traced = self.upsample.as_ref().map_or(&self.view, |s| s.view());
        let group = bind(&self.groups[0], "vct trace", &self.trace, 6, traced, work);
        let f = self.sparse;
        let lanes = w.div_ceil(f) * h.div_ceil(f) * cone_lanes(self.diffuse.cones);
        dispatch_1d(timer, "trace", &self.trace, &group, lanes);
        // 2. Sparse tracing: the untraced pixels from the traced ones.
        if let Some(up) = &self.upsample {
            up.record(
                ctx,
                timer,
                "upsample",
                frame.camera_uniform,
                frame.gbuffer,
                &self.view,
            )?;
        }
        // 3. The optional specular cone, every pixel.
        if let Some(spec) = &self.specular {
            let group = bind(
                &self.groups[1],
                "vct specular",
                &spec.pipeline,
                30,
                &spec.view,
                None,
            );
            dispatch_2d(timer, "specular", &spec.pipeline, &group, w, h);
        }
        Ok(())
    }

    /// The bind group entry of the bounce gather's work counts (`pass`: its timer name),
    /// where the context counts work.
    pub(crate) fn bounce_work<'a>(
        &self,
        ctx: &'a GpuContext,
        pass: &str,
    ) -> Result<Option<(u32, wgpu::BindingResource<'a>)>> {
        crate::gpu::work::entry(ctx, pass, self.structure.work(&BOUNCE_WORK))
    }

    /// The bounce gather's parameters (`TraceParams`, binding 5 of its passes).
    pub(crate) fn bounce_params(&self) -> &wgpu::Buffer {
        &self.bounce_params
    }

    /// The bounce gather's module (the structure's bounce module with the bounce's cone set),
    /// whose entry points the structure makes pipelines of.
    pub(crate) fn bounce_module(&self, ctx: &GpuContext) -> wgpu::ShaderModule {
        let source = self.structure.compose(
            self.structure.bounce,
            self.bounce.cones,
            &self.structure.bounce_features,
        );
        ctx.shader("vct bounce", &source)
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::layout::assert_mirrors_wgsl;

    /// The flags of the octree's structure, which `compose_alone` gives the trace.
    const FLAGS: &[(&str, bool)] = &[("anisotropic", false), ("facing", false)];

    #[test]
    fn trace_and_cone_params_mirror_the_wgsl_blocks() {
        assert_mirrors_wgsl!(
            TraceParams,
            "gi/vct/trace",
            "TraceParams",
            [cone, apex_offset, sparse, specular_aperture, specular_steps],
            FLAGS
        );
        // The cone block it holds.
        assert_mirrors_wgsl!(
            ConeParams,
            "gi/vct/trace",
            "ConeParams",
            [
                aperture,
                start,
                step,
                max_distance,
                voxel,
                stop_opacity,
                max_steps,
                max_footprint
            ],
            FLAGS
        );
    }
}
