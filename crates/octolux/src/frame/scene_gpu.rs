//! Scene data on the GPU: vertex/index buffers per mesh, a bind group per material, per-object
//! transforms (one uniform buffer, dynamic offsets) and the view uniforms used by the camera and
//! every shadow-map layer.

use super::culling::{bounds_of, clusters, outside, visible_ranges, Cluster};
use crate::gpu::pass::SLOT;
use crate::gpu::GpuContext;
use crate::scene::{AlphaMode, Scene};
use crate::{Error, Result};
use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec3, Vec4};

const OWNER: &str = "scene";

/// Interleaved vertex layout: position, normal, uv.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub(crate) struct Vertex {
    position: [f32; 3],
    normal: [f32; 3],
    uv: [f32; 2],
}

pub(crate) const VERTEX_LAYOUT: wgpu::VertexBufferLayout<'static> = wgpu::VertexBufferLayout {
    array_stride: std::mem::size_of::<Vertex>() as u64,
    step_mode: wgpu::VertexStepMode::Vertex,
    attributes: &wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32x2],
};

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct MaterialUniform {
    /// Linear albedo factor.
    base_color: [f32; 3],
    /// Alpha cutoff of a masked material; negative: opaque.
    alpha_cutoff: f32,
    /// Emitted radiance, W/(m^2 sr).
    emission: [f32; 3],
    /// 1 if the base colour texture is used.
    textured: u32,
    /// Multiplies the texture's alpha.
    opacity: f32,
    /// 1 if the back face emits too.
    two_sided_emission: u32,
    _pad: [u32; 2],
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct ObjectUniform {
    model: [[f32; 4]; 4],
    normal_matrix: [[f32; 4]; 4],
}

/// View uniform for rasterisation (camera or shadow layer).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub(crate) struct ViewUniform {
    pub view_proj: [[f32; 4]; 4],
    pub position: [f32; 4],
}

pub(crate) struct GpuMesh {
    pub vertices: wgpu::Buffer,
    pub indices: wgpu::Buffer,
    pub index_count: u32,
    pub material: usize,
    /// Bounding box of the positions in model space (for culling).
    pub bounds: (Vec3, Vec3),
    /// Runs of consecutive triangles with their boxes (for culling).
    pub clusters: Vec<Cluster>,
}

/// Bind group layouts shared by every rasterisation pass.
pub(crate) struct RasterLayouts {
    pub view: wgpu::BindGroupLayout,
    pub material: wgpu::BindGroupLayout,
    pub object: wgpu::BindGroupLayout,
}

impl RasterLayouts {
    fn new(device: &wgpu::Device) -> RasterLayouts {
        let uniform = |dynamic: bool, visibility| wgpu::BindGroupLayoutEntry {
            binding: 0,
            visibility,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: dynamic,
                min_binding_size: None,
            },
            count: None,
        };
        let vf = wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT;
        RasterLayouts {
            view: device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("view"),
                entries: &[uniform(true, vf)],
            }),
            object: device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("object"),
                entries: &[uniform(true, wgpu::ShaderStages::VERTEX)],
            }),
            material: device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("material"),
                entries: &[
                    uniform(false, wgpu::ShaderStages::FRAGMENT),
                    wgpu::BindGroupLayoutEntry {
                        binding: 1,
                        visibility: wgpu::ShaderStages::FRAGMENT,
                        ty: wgpu::BindingType::Texture {
                            sample_type: wgpu::TextureSampleType::Float { filterable: true },
                            view_dimension: wgpu::TextureViewDimension::D2,
                            multisampled: false,
                        },
                        count: None,
                    },
                    wgpu::BindGroupLayoutEntry {
                        binding: 2,
                        visibility: wgpu::ShaderStages::FRAGMENT,
                        ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                        count: None,
                    },
                ],
            }),
        }
    }

    pub fn pipeline_layout(&self, device: &wgpu::Device) -> wgpu::PipelineLayout {
        device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("raster"),
            bind_group_layouts: &[Some(&self.view), Some(&self.material), Some(&self.object)],
            immediate_size: 0,
        })
    }
}

/// The scene's GPU resources: meshes, materials, object transforms and view uniforms.
/// Techniques that rasterise the scene (RSMs, voxelisation) build pipelines with
/// `layouts.pipeline_layout()` and the vertex layout `VERTEX_LAYOUT`, then call `draw`.
pub struct SceneGpu {
    pub(crate) layouts: RasterLayouts,
    pub(crate) meshes: Vec<GpuMesh>,
    pub(crate) materials: Vec<wgpu::BindGroup>,
    /// Per object: indices into `meshes`.
    pub(crate) object_meshes: Vec<Vec<usize>>,
    objects: wgpu::Buffer,
    pub(crate) object_group: wgpu::BindGroup,
    pub(crate) views: wgpu::Buffer,
    pub(crate) view_group: wgpu::BindGroup,
    /// This frame's object transforms and view matrices, as uploaded (for culling).
    transforms: Vec<Mat4>,
    view_projs: Vec<Mat4>,
    /// Per view uniform, [`SceneGpu::view_content`] of this frame, made when first asked (the
    /// shadow maps, the RSMs' redraw and their side all ask for the same views' contents).
    view_contents: Vec<std::sync::OnceLock<Vec<u8>>>,
}

impl SceneGpu {
    /// Uploads `scene`; `view_capacity` is how many view uniforms (camera + shadow layers) fit.
    pub(crate) fn new(ctx: &GpuContext, scene: &Scene, view_capacity: u32) -> Result<SceneGpu> {
        let device = &ctx.device;
        let layouts = RasterLayouts::new(device);
        let max_buffer = device.limits().max_buffer_size;
        let mut meshes = Vec::with_capacity(scene.meshes.len());
        for (i, mesh) in scene.meshes.iter().enumerate() {
            let vertices: Vec<Vertex> = (0..mesh.positions.len())
                .map(|v| Vertex {
                    position: mesh.positions[v].to_array(),
                    normal: mesh.normals.get(v).copied().unwrap_or_default().to_array(),
                    uv: mesh.uvs.get(v).copied().unwrap_or_default().to_array(),
                })
                .collect();
            let bytes: &[u8] = bytemuck::cast_slice(&vertices);
            if bytes.len() as u64 > max_buffer {
                return Err(Error::Gpu(format!(
                    "mesh '{}' needs a {} MiB vertex buffer, more than the adapter allows",
                    mesh.name,
                    bytes.len() >> 20
                )));
            }
            meshes.push(GpuMesh {
                vertices: ctx.create_buffer_init(
                    OWNER,
                    &format!("vertices {i}"),
                    bytes,
                    wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::STORAGE,
                ),
                indices: ctx.create_buffer_init(
                    OWNER,
                    &format!("indices {i}"),
                    bytemuck::cast_slice(&mesh.indices),
                    wgpu::BufferUsages::INDEX | wgpu::BufferUsages::STORAGE,
                ),
                index_count: mesh.indices.len() as u32,
                material: mesh.material as usize,
                bounds: bounds_of(mesh.positions.iter().copied()),
                clusters: clusters(&mesh.positions, &mesh.indices),
            });
        }

        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("material"),
            address_mode_u: wgpu::AddressMode::Repeat,
            address_mode_v: wgpu::AddressMode::Repeat,
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            mipmap_filter: wgpu::MipmapFilterMode::Linear,
            ..Default::default()
        });
        let max_dim = device.limits().max_texture_dimension_2d;
        let mut textures = Vec::with_capacity(scene.textures.len());
        for (i, tex) in scene.textures.iter().enumerate() {
            if tex.width == 0 || tex.height == 0 || tex.width > max_dim || tex.height > max_dim {
                return Err(Error::Gpu(format!(
                    "texture '{}' is {}x{}; the adapter allows 1..{max_dim} per side",
                    tex.name, tex.width, tex.height
                )));
            }
            textures.push(upload_rgba8(
                ctx,
                &format!("texture {i}"),
                tex.width,
                tex.height,
                &tex.rgba,
            ));
        }
        let white = upload_rgba8(ctx, "white", 1, 1, &[255; 4]);
        let materials = scene
            .materials
            .iter()
            .enumerate()
            .map(|(i, m)| {
                let texture = m.base_color_texture.and_then(|t| textures.get(t as usize));
                let cutoff = match m.alpha_mode {
                    AlphaMode::Opaque => -1.0,
                    AlphaMode::Mask(c) => c,
                };
                let uniform = MaterialUniform {
                    base_color: m.base_color.to_array(),
                    alpha_cutoff: cutoff,
                    emission: m.emission.to_array(),
                    textured: texture.is_some() as u32,
                    opacity: m.opacity,
                    two_sided_emission: m.emission_two_sided as u32,
                    _pad: [0; 2],
                };
                let buffer = ctx.create_buffer_init(
                    OWNER,
                    &format!("material {i}"),
                    bytemuck::bytes_of(&uniform),
                    wgpu::BufferUsages::UNIFORM,
                );
                let view = texture.unwrap_or(&white);
                device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some(&m.name),
                    layout: &layouts.material,
                    entries: &[
                        wgpu::BindGroupEntry {
                            binding: 0,
                            resource: buffer.as_entire_binding(),
                        },
                        wgpu::BindGroupEntry {
                            binding: 1,
                            resource: wgpu::BindingResource::TextureView(view),
                        },
                        wgpu::BindGroupEntry {
                            binding: 2,
                            resource: wgpu::BindingResource::Sampler(&sampler),
                        },
                    ],
                })
            })
            .collect();

        let object_count = scene.objects.len().max(1) as u64;
        let objects = ctx.create_buffer(
            OWNER,
            &wgpu::BufferDescriptor {
                label: Some("object transforms"),
                size: object_count * SLOT,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            },
        );
        let object_group = dynamic_group(device, &layouts.object, &objects, 128);
        let views = ctx.create_buffer(
            OWNER,
            &wgpu::BufferDescriptor {
                label: Some("view uniforms"),
                size: view_capacity as u64 * SLOT,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            },
        );
        let view_group = dynamic_group(device, &layouts.view, &views, 80);
        Ok(SceneGpu {
            layouts,
            meshes,
            materials,
            object_meshes: scene
                .objects
                .iter()
                .map(|o| o.meshes.iter().map(|&m| m as usize).collect())
                .collect(),
            objects,
            object_group,
            views,
            view_group,
            transforms: Vec::new(),
            view_projs: Vec::new(),
            view_contents: Vec::new(),
        })
    }

    /// The objects [`SceneGpu::draw`] would draw any triangle of through view uniform `view`
    /// this frame (every object where the view has no matrix).
    pub(crate) fn objects_in_view(&self, view: usize) -> Vec<usize> {
        let view_proj = self.view_projs.get(view);
        (0..self.object_meshes.len())
            .filter(|&o| {
                let model = self.transforms.get(o).copied().unwrap_or(Mat4::IDENTITY);
                let Some(clip) = view_proj.map(|vp| *vp * model) else {
                    return true;
                };
                self.object_meshes[o]
                    .iter()
                    .any(|&m| !outside(clip, self.meshes[m].bounds))
            })
            .collect()
    }

    /// What a rasterisation through view uniform `view` shows this frame, byte for byte: the
    /// view's matrix and the objects in it ([`SceneGpu::objects_in_view`]) with their
    /// transforms (meshes, materials and textures do not change). An object that enters or
    /// leaves the view changes it; one that moves outside the view does not.
    pub(crate) fn view_content(&self, view: usize) -> std::borrow::Cow<'_, [u8]> {
        match self.view_contents.get(view) {
            Some(cell) => cell.get_or_init(|| self.make_view_content(view)).into(),
            // A view without a uniform (no matrix: every object) is not kept.
            None => self.make_view_content(view).into(),
        }
    }

    fn make_view_content(&self, view: usize) -> Vec<u8> {
        let m = self.view_proj(view).unwrap_or_default();
        let mut key = bytemuck::bytes_of(&m.to_cols_array()).to_vec();
        for o in self.objects_in_view(view) {
            key.extend_from_slice(&(o as u32).to_le_bytes());
            let m = self.transforms.get(o).copied().unwrap_or_default();
            key.extend_from_slice(bytemuck::bytes_of(&m.to_cols_array()));
        }
        key
    }

    /// The view-projection of view uniform `view` this frame (0 = the camera).
    pub(crate) fn view_proj(&self, view: usize) -> Option<Mat4> {
        self.view_projs.get(view).copied()
    }

    /// Uploads this frame's object transforms.
    pub(crate) fn update_objects(&mut self, queue: &wgpu::Queue, transforms: &[Mat4]) {
        self.transforms = transforms.to_vec();
        self.view_contents.iter_mut().for_each(|c| drop(c.take()));
        let mut data = vec![0u8; transforms.len() * SLOT as usize];
        for (i, m) in transforms.iter().enumerate() {
            let u = ObjectUniform {
                model: m.to_cols_array_2d(),
                normal_matrix: m.inverse().transpose().to_cols_array_2d(),
            };
            let start = i * SLOT as usize;
            data[start..start + std::mem::size_of::<ObjectUniform>()]
                .copy_from_slice(bytemuck::bytes_of(&u));
        }
        if !data.is_empty() {
            queue.write_buffer(&self.objects, 0, &data);
        }
    }

    /// Uploads view uniforms (index 0 = camera, then shadow layers).
    pub(crate) fn update_views(&mut self, queue: &wgpu::Queue, views: &[(Mat4, Vec4)]) {
        self.view_projs = views.iter().map(|v| v.0).collect();
        self.view_contents = views.iter().map(|_| std::sync::OnceLock::new()).collect();
        let mut data = vec![0u8; views.len() * SLOT as usize];
        for (i, (view_proj, position)) in views.iter().enumerate() {
            let u = ViewUniform {
                view_proj: view_proj.to_cols_array_2d(),
                position: position.to_array(),
            };
            let start = i * SLOT as usize;
            data[start..start + std::mem::size_of::<ViewUniform>()]
                .copy_from_slice(bytemuck::bytes_of(&u));
        }
        queue.write_buffer(&self.views, 0, &data);
    }

    /// Draws every object with the bound pipeline; view group 0 must already be set to view
    /// uniform `view`. Meshes and clusters of triangles whose bounds lie wholly outside that view's
    /// clip volume are not drawn (they would produce no fragment; `frame/culling.rs`). Returns
    /// the triangles drawn.
    pub(crate) fn draw<'a>(&'a self, pass: &mut wgpu::RenderPass<'a>, view: usize) -> u64 {
        let mut triangles = 0;
        let view_proj = self.view_projs.get(view);
        for (o, meshes) in self.object_meshes.iter().enumerate() {
            let model = self.transforms.get(o).copied().unwrap_or(Mat4::IDENTITY);
            let clip_from_model = view_proj.map(|vp| *vp * model);
            let mut object_bound = false;
            for &m in meshes {
                let mesh = &self.meshes[m];
                let ranges = visible_ranges(
                    clip_from_model,
                    mesh.bounds,
                    &mesh.clusters,
                    mesh.index_count,
                );
                if ranges.is_empty() {
                    continue;
                }
                if !object_bound {
                    let offset = (o as u64 * SLOT) as u32;
                    pass.set_bind_group(2, &self.object_group, &[offset]);
                    object_bound = true;
                }
                pass.set_bind_group(1, &self.materials[mesh.material], &[]);
                pass.set_vertex_buffer(0, mesh.vertices.slice(..));
                pass.set_index_buffer(mesh.indices.slice(..), wgpu::IndexFormat::Uint32);
                for range in ranges {
                    triangles += (range.end - range.start) as u64 / 3;
                    pass.draw_indexed(range, 0, 0..1);
                }
            }
        }
        triangles
    }
}

/// A pipeline that rasterises the scene's meshes (vertex entry `vs`, [`VERTEX_LAYOUT`]) into a
/// `Depth32Float` depth buffer with a less-than test, and fragment entry `fs_entry` writing
/// `targets`. Shared by the G-buffer, shadow maps and reflective shadow maps.
pub(crate) fn raster_pipeline(
    device: &wgpu::Device,
    label: &str,
    layout: &wgpu::PipelineLayout,
    module: &wgpu::ShaderModule,
    fs_entry: &str,
    targets: &[Option<wgpu::ColorTargetState>],
    bias: wgpu::DepthBiasState,
) -> wgpu::RenderPipeline {
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(label),
        layout: Some(layout),
        vertex: wgpu::VertexState {
            module,
            entry_point: Some("vs"),
            compilation_options: Default::default(),
            buffers: &[Some(VERTEX_LAYOUT)],
        },
        // Surfaces are two-sided, so nothing is culled.
        primitive: wgpu::PrimitiveState::default(),
        depth_stencil: Some(wgpu::DepthStencilState {
            format: wgpu::TextureFormat::Depth32Float,
            depth_write_enabled: Some(true),
            depth_compare: Some(wgpu::CompareFunction::Less),
            stencil: Default::default(),
            bias,
        }),
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module,
            entry_point: Some(fs_entry),
            compilation_options: Default::default(),
            targets,
        }),
        multiview_mask: None,
        cache: None,
    })
}

fn dynamic_group(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    buffer: &wgpu::Buffer,
    size: u64,
) -> wgpu::BindGroup {
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout,
        entries: &[wgpu::BindGroupEntry {
            binding: 0,
            resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                buffer,
                offset: 0,
                size: wgpu::BufferSize::new(size),
            }),
        }],
    })
}

/// Halves an RGBA8 image with a 2x2 box filter, averaging colour in linear light (the texture
/// is sRGB) and alpha linearly. Odd edges repeat their last texel.
pub(crate) fn downsample_srgb(width: u32, height: u32, rgba: &[u8]) -> (u32, u32, Vec<u8>) {
    let (w, h) = ((width / 2).max(1), (height / 2).max(1));
    let to_linear = |v: u8| crate::scene::srgb_to_linear(v as f32 / 255.0);
    let mut out = Vec::with_capacity((w * h * 4) as usize);
    for y in 0..h {
        for x in 0..w {
            let mut sum = [0.0f32; 4];
            for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                let sx = (2 * x + dx).min(width - 1);
                let sy = (2 * y + dy).min(height - 1);
                let i = ((sy * width + sx) * 4) as usize;
                for c in 0..3 {
                    sum[c] += to_linear(rgba[i + c]);
                }
                sum[3] += rgba[i + 3] as f32 / 255.0;
            }
            for (c, v) in sum.iter().enumerate() {
                let v = v / 4.0;
                let encoded = if c < 3 {
                    crate::image_io::linear_to_srgb(v)
                } else {
                    v
                };
                out.push((encoded * 255.0 + 0.5).clamp(0.0, 255.0) as u8);
            }
        }
    }
    (w, h, out)
}

/// Uploads an sRGB RGBA8 image with a full mip chain (trilinear filtering keeps distant
/// textured surfaces from aliasing).
fn upload_rgba8(
    ctx: &GpuContext,
    label: &str,
    width: u32,
    height: u32,
    rgba: &[u8],
) -> wgpu::TextureView {
    let levels = 32 - width.max(height).leading_zeros();
    let texture = ctx.create_texture(
        OWNER,
        &wgpu::TextureDescriptor {
            label: Some(label),
            size: wgpu::Extent3d {
                width,
                height,
                depth_or_array_layers: 1,
            },
            mip_level_count: levels,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Rgba8UnormSrgb,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        },
    );
    let mut level_data = (width, height, rgba.to_vec());
    for level in 0..levels {
        let (w, h, data) = &level_data;
        ctx.queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &texture,
                mip_level: level,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            data,
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(w * 4),
                rows_per_image: Some(*h),
            },
            wgpu::Extent3d {
                width: *w,
                height: *h,
                depth_or_array_layers: 1,
            },
        );
        if level + 1 < levels {
            level_data = downsample_srgb(*w, *h, data);
        }
    }
    texture.create_view(&Default::default())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn material_uniform_mirrors_the_wgsl_block() {
        crate::gpu::layout::assert_mirrors_wgsl!(
            MaterialUniform,
            "frame/raster",
            "Material",
            [
                base_color,
                alpha_cutoff,
                emission,
                textured,
                opacity,
                two_sided_emission,
                _pad
            ]
        );
    }

    #[test]
    fn downsample_averages_in_linear_light() {
        // Black and white average to linear 0.5, which is sRGB 188.
        let rgba = [
            0, 0, 0, 0, 255, 255, 255, 255, 0, 0, 0, 0, 255, 255, 255, 255,
        ];
        let (w, h, out) = downsample_srgb(2, 2, &rgba);
        assert_eq!((w, h), (1, 1));
        assert_eq!(out, vec![188, 188, 188, 128]);
        // Odd sizes: 3x1 -> 1x1 uses the first two texels.
        let (w, h, out) = downsample_srgb(
            3,
            1,
            &[10, 10, 10, 255, 10, 10, 10, 255, 200, 200, 200, 255],
        );
        assert_eq!((w, h, out), (1, 1, vec![10, 10, 10, 255]));
    }
}
