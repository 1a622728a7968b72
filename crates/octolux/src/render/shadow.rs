//! Shadow maps: one depth layer per spot or directional light, six (a cube, one layer per
//! face) per point light, all in one `Depth32Float` array so the lighting shader indexes them
//! uniformly. Directional maps are orthographic and fitted to the scene bounds; spot maps cover
//! the outer cone; point faces are 90-degree frusta widened slightly so filtering never reads
//! past a face edge.

use super::scene_gpu::{raster_pipeline, SceneGpu};
use crate::gpu::{GpuContext, PassTimer};
use crate::scene::{Light, LightKind};
use glam::{Mat4, Vec3, Vec4};

const OWNER: &str = "shadow-maps";

/// Per-light placement in the shadow array.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ShadowSlot {
    pub first_layer: u32,
}

/// View-projection and texel footprint of one shadow layer.
#[derive(Clone, Copy, Debug)]
pub struct LayerView {
    /// World to clip of this layer.
    pub view_proj: Mat4,
    /// World size of a texel per metre of distance (perspective) or absolute (orthographic).
    pub texel: f32,
    /// Orthographic (directional light) or perspective.
    pub orthographic: bool,
}

/// The shadow-map array and its rasterisation pipeline.
pub struct ShadowMaps {
    pub(crate) slots: Vec<ShadowSlot>,
    pub(crate) layer_count: u32,
    pub(crate) size: u32,
    texture: wgpu::Texture,
    pub(crate) array_view: wgpu::TextureView,
    layer_views: Vec<wgpu::TextureView>,
    pipeline: wgpu::RenderPipeline,
    pub(crate) sampler: wgpu::Sampler,
}

/// Cube face directions and up vectors, in the order the lighting shader's `cube_face` uses.
const CUBE_FACES: [(Vec3, Vec3); 6] = [
    (Vec3::X, Vec3::NEG_Y),
    (Vec3::NEG_X, Vec3::NEG_Y),
    (Vec3::Y, Vec3::Z),
    (Vec3::NEG_Y, Vec3::NEG_Z),
    (Vec3::Z, Vec3::NEG_Y),
    (Vec3::NEG_Z, Vec3::NEG_Y),
];

fn any_perpendicular(d: Vec3) -> Vec3 {
    if d.y.abs() < 0.99 {
        Vec3::Y
    } else {
        Vec3::Z
    }
}

impl ShadowMaps {
    pub(crate) fn new(
        ctx: &GpuContext,
        scene_gpu: &SceneGpu,
        lights: &[Light],
        size: u32,
    ) -> ShadowMaps {
        let mut slots = Vec::with_capacity(lights.len());
        let mut layer_count = 0;
        for light in lights {
            let layers = if light.kind == LightKind::Point { 6 } else { 1 };
            slots.push(ShadowSlot {
                first_layer: layer_count,
            });
            layer_count += layers;
        }
        // A texture array needs at least one layer; the lighting shader never reads it then.
        let texture = ctx.create_texture(
            OWNER,
            &wgpu::TextureDescriptor {
                label: Some("shadow array"),
                size: wgpu::Extent3d {
                    width: size,
                    height: size,
                    depth_or_array_layers: layer_count.max(1),
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: wgpu::TextureFormat::Depth32Float,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                    | wgpu::TextureUsages::TEXTURE_BINDING
                    | wgpu::TextureUsages::COPY_SRC,
                view_formats: &[],
            },
        );
        let array_view = texture.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::D2Array),
            ..Default::default()
        });
        let layer_views = (0..layer_count)
            .map(|layer| {
                texture.create_view(&wgpu::TextureViewDescriptor {
                    dimension: Some(wgpu::TextureViewDimension::D2),
                    base_array_layer: layer,
                    array_layer_count: Some(1),
                    ..Default::default()
                })
            })
            .collect();
        let module = ctx.shader(
            "shadow",
            &[include_str!("raster.wgsl"), include_str!("gbuffer.wgsl")].concat(),
        );
        let layout = scene_gpu.layouts.pipeline_layout(&ctx.device);
        // Slope-scaled bias against acne on surfaces at grazing angles to the light.
        let bias = wgpu::DepthBiasState {
            constant: 2,
            slope_scale: 1.5,
            clamp: 0.0,
        };
        let pipeline = raster_pipeline(
            &ctx.device,
            "shadow",
            &layout,
            &module,
            "fs_shadow",
            &[],
            bias,
        );
        let sampler = ctx.device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("shadow compare"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            compare: Some(wgpu::CompareFunction::LessEqual),
            ..Default::default()
        });
        ShadowMaps {
            slots,
            layer_count,
            size,
            texture,
            array_view,
            layer_views,
            pipeline,
            sampler,
        }
    }

    /// The depth array (one layer per spot/directional light, six per point light).
    pub fn texture(&self) -> &wgpu::Texture {
        &self.texture
    }

    /// Layer views for the lights of one frame, fitted to the scene bounds.
    pub(crate) fn layer_views(&self, lights: &[Light], bounds: (Vec3, Vec3)) -> Vec<LayerView> {
        let (lo, hi) = bounds;
        let centre = (lo + hi) * 0.5;
        let radius = ((hi - lo).length() * 0.5).max(1e-3);
        let mut views = Vec::with_capacity(self.layer_count as usize);
        let size = self.size as f32;
        for light in lights {
            match light.kind {
                LightKind::Directional => {
                    let d = light.direction.normalize_or(Vec3::NEG_Y);
                    let eye = centre - d * radius * 2.0;
                    let view = Mat4::look_at_rh(eye, centre, any_perpendicular(d));
                    let proj = Mat4::orthographic_rh(
                        -radius,
                        radius,
                        -radius,
                        radius,
                        radius * 0.5,
                        radius * 3.5,
                    );
                    views.push(LayerView {
                        view_proj: proj * view,
                        texel: 2.0 * radius / size,
                        orthographic: true,
                    });
                }
                LightKind::Spot { outer_angle, .. } => {
                    let d = light.direction.normalize_or(Vec3::NEG_Y);
                    let (near, far) = near_far(light.position, centre, radius);
                    let fov = (2.0 * outer_angle + 4f32.to_radians()).min(170f32.to_radians());
                    let view =
                        Mat4::look_at_rh(light.position, light.position + d, any_perpendicular(d));
                    let proj = Mat4::perspective_rh(fov, 1.0, near, far);
                    views.push(LayerView {
                        view_proj: proj * view,
                        texel: 2.0 * (fov * 0.5).tan() / size,
                        orthographic: false,
                    });
                }
                LightKind::Point => {
                    let (near, far) = near_far(light.position, centre, radius);
                    // Widen each face by a few texels so the 4x4 filter footprint stays inside.
                    let half = (1.0 + 6.0 / size).atan();
                    for (dir, up) in CUBE_FACES {
                        let view = Mat4::look_at_rh(light.position, light.position + dir, up);
                        let proj = Mat4::perspective_rh(2.0 * half, 1.0, near, far);
                        views.push(LayerView {
                            view_proj: proj * view,
                            texel: 2.0 * half.tan() / size,
                            orthographic: false,
                        });
                    }
                }
            }
        }
        views
    }

    /// Renders every layer. View uniforms 1.. must hold the layer matrices.
    pub(crate) fn render(&self, timer: &mut PassTimer, scene_gpu: &SceneGpu) {
        if self.layer_count == 0 {
            return;
        }
        timer.pass("shadow maps", |encoder, stamps| {
            let n = self.layer_views.len();
            for (i, view) in self.layer_views.iter().enumerate() {
                let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some("shadow layer"),
                    color_attachments: &[],
                    depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                        view,
                        depth_ops: Some(wgpu::Operations {
                            load: wgpu::LoadOp::Clear(1.0),
                            store: wgpu::StoreOp::Store,
                        }),
                        stencil_ops: None,
                    }),
                    timestamp_writes: stamps.render_part(i == 0, i + 1 == n),
                    occlusion_query_set: None,
                    multiview_mask: None,
                });
                pass.set_pipeline(&self.pipeline);
                let offset = ((i as u64 + 1) * super::scene_gpu::UNIFORM_STRIDE) as u32;
                pass.set_bind_group(0, &scene_gpu.view_group, &[offset]);
                scene_gpu.draw(&mut pass, i + 1);
            }
        });
    }
}

/// Near and far planes for a perspective shadow frustum at `eye` enclosing the bounding sphere.
fn near_far(eye: Vec3, centre: Vec3, radius: f32) -> (f32, f32) {
    let far = (eye - centre).length() + radius;
    ((far * 1e-3).max(1e-3), far * 1.01)
}

/// The light's shadow parameters as the lighting shader wants them (see `direct.wgsl`).
pub(crate) fn shadow_params(slot: Option<&ShadowSlot>, first: Option<&LayerView>) -> Vec4 {
    match (slot, first) {
        (Some(s), Some(v)) => Vec4::new(
            s.first_layer as f32,
            v.texel,
            if v.orthographic { 1.0 } else { 0.0 },
            0.0,
        ),
        _ => Vec4::new(-1.0, 0.0, 0.0, 0.0),
    }
}
