//! The caller's camera and G-buffer, and the pass (`input.wgsl`) that brings its depth and
//! normal into octolux's conventions ([`GiSurfaces`]).

use crate::frame::GiSurfaces;
use crate::gpu::alloc::image_target;
use crate::gpu::shader::library_shader;
use crate::gpu::{GpuContext, PassTimer};
use crate::scene::CameraView;
use crate::{Error, Result};
use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec4};

const OWNER: &str = "gbuffer input";

/// The caller's camera: the matrices its G-buffer was drawn with (wgpu's clip space: y up,
/// depth 0..1 after the divide, right-handed view space looking down -z). Any perspective or
/// orthographic projection, standard or reversed depth, finite or infinite far plane.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraInput {
    /// World to view.
    pub view: Mat4,
    /// View to clip.
    pub proj: Mat4,
}

impl CameraInput {
    /// The camera of `view` and `proj`.
    pub fn new(view: Mat4, proj: Mat4) -> CameraInput {
        CameraInput { view, proj }
    }

    /// Octolux's view of this camera for a `width` x `height` image: the same view, x and y
    /// projection, and a standard depth range over the caller's near and far planes (an
    /// infinite far plane becomes [`crate::scene::MAX_DEPTH_RATIO`] x near).
    pub fn octolux_view(&self, width: u32, height: u32) -> Result<CameraView> {
        let bad = |why: &str| {
            Error::InvalidArgument(format!(
                "camera: {why} (view {:?}, proj {:?})",
                self.view, self.proj
            ))
        };
        if !self.view.is_finite() || !self.proj.is_finite() {
            return Err(bad("the matrices must be finite"));
        }
        if self.view.determinant().abs() < 1e-12 || self.proj.determinant().abs() < 1e-30 {
            return Err(bad("the matrices must be invertible"));
        }
        let inv_proj = self.proj.inverse();
        // View-space distance in front of the camera at NDC depth d on the axis.
        let distance = |d: f32| {
            let v = inv_proj * Vec4::new(0.0, 0.0, d, 1.0);
            if v.w.abs() < 1e-30 {
                f32::INFINITY
            } else {
                -v.z / v.w
            }
        };
        let (d0, d1) = (distance(0.0), distance(1.0));
        let near = d0.min(d1);
        let mut far = d0.max(d1);
        if !(near > 0.0 || self.is_orthographic()) || near.is_nan() {
            return Err(bad("the near plane must be in front of the camera"));
        }
        let max_far = near.abs().max(1e-6) * crate::scene::MAX_DEPTH_RATIO;
        if !far.is_finite() || far > max_far {
            far = max_far;
        }
        let mut proj = self.proj;
        // Replace the depth row (row 2) by a standard one over [near, far].
        let (a, b) = if self.is_orthographic() {
            (1.0 / (near - far), near / (near - far))
        } else if self.is_perspective() {
            (far / (near - far), near * far / (near - far))
        } else {
            return Err(bad(
                "only perspective and orthographic projections are accepted",
            ));
        };
        proj.x_axis.z = 0.0;
        proj.y_axis.z = 0.0;
        proj.z_axis.z = a;
        proj.w_axis.z = b;
        let view_proj = proj * self.view;
        Ok(CameraView {
            view: self.view,
            proj,
            view_proj,
            inv_view_proj: view_proj.inverse(),
            position: self.view.inverse().w_axis.truncate(),
            width,
            height,
        })
    }

    fn is_perspective(&self) -> bool {
        let w = self.proj.row(3);
        w.x == 0.0 && w.y == 0.0 && w.z == -1.0 && w.w == 0.0
    }

    fn is_orthographic(&self) -> bool {
        self.proj.row(3) == Vec4::W
    }
}

/// Which depth value is near: wgpu's standard (0 near, 1 far) or reversed (1 near, 0 far,
/// the common choice for precision, with a finite or infinite far plane).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DepthConvention {
    /// 0 at the near plane, 1 at the far plane; nothing drawn = 1.
    #[default]
    Standard,
    /// 1 at the near plane, 0 at the far plane (or at infinity); nothing drawn = 0.
    Reversed,
}

/// The space the normals are in.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum NormalSpace {
    /// World space.
    #[default]
    World,
    /// The camera's view space ([`CameraInput::view`]).
    View,
}

/// How a unit normal is stored in the texel.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum NormalPacking {
    /// xyz in -1..1 (a float or snorm format).
    #[default]
    Xyz,
    /// xyz as n * 0.5 + 0.5 (a unorm format such as `Rgba8Unorm` or `Rgb10a2Unorm`).
    XyzUnorm,
    /// Octahedral in xy, -1..1 (`Rg16Float`, `Rg16Snorm`, ...).
    Octahedral,
    /// Octahedral in xy as e * 0.5 + 0.5 (`Rg8Unorm`, `Rg16Unorm`, ...).
    OctahedralUnorm,
}

/// The normal target's convention.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct NormalEncoding {
    /// World or view space.
    pub space: NormalSpace,
    /// How the texel holds it.
    pub packing: NormalPacking,
}

impl NormalEncoding {
    /// World-space xyz in a float format (octolux's own G-buffer).
    pub const WORLD: NormalEncoding = NormalEncoding {
        space: NormalSpace::World,
        packing: NormalPacking::Xyz,
    };
}

/// The caller's G-buffer as octolux reads it. Depth: a depth format (`Depth32Float`,
/// `Depth24Plus`, the depth aspect of a depth-stencil format, `Depth16Unorm`) or `R32Float`.
/// Normal: any float-sampled colour format holding one unit normal per pixel in `normal_encoding`
/// (which side it faces does not matter). Both need `TEXTURE_BINDING` and the engine's size.
#[derive(Clone, Copy, Debug)]
pub struct GBufferInput<'a> {
    /// Depth of the nearest surface per pixel.
    pub depth: &'a wgpu::TextureView,
    /// Which depth value is near.
    pub depth_convention: DepthConvention,
    /// Unit surface normal per pixel.
    pub normal: &'a wgpu::TextureView,
    /// How the normal is stored.
    pub normal_encoding: NormalEncoding,
}

impl<'a> GBufferInput<'a> {
    /// The G-buffer of `depth` and `normal` in the given conventions.
    pub fn new(
        depth: &'a wgpu::TextureView,
        depth_convention: DepthConvention,
        normal: &'a wgpu::TextureView,
        normal_encoding: NormalEncoding,
    ) -> GBufferInput<'a> {
        GBufferInput {
            depth,
            depth_convention,
            normal,
            normal_encoding,
        }
    }

    /// Whether depth is a colour (`R32Float`) texture rather than a depth format.
    fn float_depth(&self) -> bool {
        !self.depth.texture().format().has_depth_aspect()
    }

    /// A clear error where a target has the wrong size, format or usage.
    pub(crate) fn check(&self, width: u32, height: u32) -> Result<()> {
        for (what, view) in [("depth", self.depth), ("normal", self.normal)] {
            let t = view.texture();
            if (t.width(), t.height()) != (width, height) {
                return Err(Error::InvalidArgument(format!(
                    "G-buffer {what} is {}x{}, the GI engine is configured for {width}x{height} \
                     (GiEngine::resize)",
                    t.width(),
                    t.height()
                )));
            }
            if !t.usage().contains(wgpu::TextureUsages::TEXTURE_BINDING) {
                return Err(Error::InvalidArgument(format!(
                    "G-buffer {what} ({:?}) needs TEXTURE_BINDING usage",
                    t.format()
                )));
            }
        }
        let depth = self.depth.texture().format();
        if !(depth.has_depth_aspect() || depth == wgpu::TextureFormat::R32Float) {
            return Err(Error::InvalidArgument(format!(
                "G-buffer depth is {depth:?}; accepted: a depth format or R32Float"
            )));
        }
        let normal = self.normal.texture().format();
        let float = matches!(
            normal.sample_type(None, None),
            Some(wgpu::TextureSampleType::Float { .. })
        );
        if !float || normal.has_depth_aspect() {
            return Err(Error::InvalidArgument(format!(
                "G-buffer normal is {normal:?}; accepted: a colour format sampled as float \
                 (float, unorm or snorm)"
            )));
        }
        Ok(())
    }
}

/// `InputParams` of `input.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct InputParams {
    inv_proj: [[f32; 4]; 4],
    proj: [[f32; 4]; 4],
    inv_view: [[f32; 4]; 4],
    size: [f32; 4],
    packing: [u32; 4],
}

/// The pass and octolux's depth and normal targets it writes.
pub(crate) struct InputPass {
    /// Per depth kind (a depth format, `R32Float`): pipeline and its bind group layout.
    pipelines: [(wgpu::RenderPipeline, wgpu::BindGroupLayout); 2],
    params: wgpu::Buffer,
    depth: wgpu::Texture,
    depth_view: wgpu::TextureView,
    normal_view: wgpu::TextureView,
}

impl InputPass {
    pub fn new(ctx: &GpuContext, width: u32, height: u32) -> InputPass {
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
        let (depth, depth_view) = image_target(
            ctx,
            OWNER,
            "depth",
            width,
            height,
            wgpu::TextureFormat::Depth32Float,
            usage,
        );
        let (_, normal_view) = image_target(
            ctx,
            OWNER,
            "normal",
            width,
            height,
            crate::frame::GBUFFER_FORMAT,
            usage,
        );
        let params = ctx.create_buffer_init(
            OWNER,
            "params",
            bytemuck::bytes_of(&InputParams::zeroed()),
            wgpu::BufferUsages::UNIFORM,
        );
        let pipelines = [false, true].map(|float_depth| pipeline(ctx, float_depth));
        InputPass {
            pipelines,
            params,
            depth,
            depth_view,
            normal_view,
        }
    }

    /// Octolux's depth and normal, written by [`InputPass::record`].
    pub fn surfaces(&self) -> GiSurfaces<'_> {
        GiSurfaces {
            depth_view: &self.depth_view,
            normal_view: &self.normal_view,
            width: self.depth.width(),
            height: self.depth.height(),
        }
    }

    /// Records the conversion of `input` (drawn through `camera`).
    pub fn record(
        &self,
        ctx: &GpuContext,
        timer: &mut PassTimer,
        input: &GBufferInput,
        camera: &CameraInput,
        view: &CameraView,
    ) {
        let (w, h) = (self.depth.width(), self.depth.height());
        let params = InputParams {
            inv_proj: camera.proj.inverse().to_cols_array_2d(),
            proj: view.proj.to_cols_array_2d(),
            inv_view: camera.view.inverse().to_cols_array_2d(),
            size: [
                w as f32,
                h as f32,
                (input.depth_convention == DepthConvention::Reversed) as u32 as f32,
                (input.normal_encoding.space == NormalSpace::View) as u32 as f32,
            ],
            packing: [input.normal_encoding.packing as u32, 0, 0, 0],
        };
        ctx.queue
            .write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        let (pipeline, layout) = &self.pipelines[input.float_depth() as usize];
        let group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("gbuffer input"),
            layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: self.params.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(input.depth),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::TextureView(input.normal),
                },
            ],
        });
        timer.pass("gbuffer input", |encoder, stamps| {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("gbuffer input"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &self.normal_view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &self.depth_view,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(1.0),
                        store: wgpu::StoreOp::Store,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: stamps.render(),
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, &group, &[]);
            pass.draw(0..3, 0..1);
        });
    }
}

/// The input pipeline for a depth format (`float_depth` false) or `R32Float` depth, with an
/// explicit layout: unfilterable float textures accept every float-sampled format.
fn pipeline(ctx: &GpuContext, float_depth: bool) -> (wgpu::RenderPipeline, wgpu::BindGroupLayout) {
    let texture = |binding, sample_type| wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Texture {
            sample_type,
            view_dimension: wgpu::TextureViewDimension::D2,
            multisampled: false,
        },
        count: None,
    };
    let unfilterable = wgpu::TextureSampleType::Float { filterable: false };
    let layout = ctx
        .device
        .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("gbuffer input"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                },
                texture(
                    1,
                    match float_depth {
                        true => unfilterable,
                        false => wgpu::TextureSampleType::Depth,
                    },
                ),
                texture(2, unfilterable),
            ],
        });
    let pipeline_layout = ctx
        .device
        .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("gbuffer input"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
    let module = ctx.shader(
        "gbuffer input",
        &library_shader("embed/input", &[("float_depth", float_depth)]),
    );
    let pipeline = ctx
        .device
        .create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("gbuffer input"),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: Some(wgpu::DepthStencilState {
                format: wgpu::TextureFormat::Depth32Float,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::Always),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format: crate::frame::GBUFFER_FORMAT,
                    blend: None,
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        });
    (pipeline, layout)
}
