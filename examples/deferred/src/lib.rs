//! A small deferred wgpu renderer that is not octolux's: its own glTF loading, its own G-buffer
//! (albedo `Rgba8Unorm`, octahedral world normals in `Rg16Float`, reversed-Z infinite depth),
//! its own unshadowed point light and Reinhard tone map. Octolux's GI comes in through
//! [`octolux::embed::GiEngine`]: the scene is handed over in [`Example::new`], the moving
//! block and lamp are updated per frame, and one `record` call per frame adds the indirect
//! irradiance the lighting pass composes. Keys in the window: `T` switches technique.

pub mod model;

use anyhow::{Context, Result};
use glam::{Mat4, Vec3};
use model::{Lamp, Model};
use octolux::embed::{
    CameraInput, DepthConvention, FrameInput, GBufferInput, GiConfig, GiEngine, InstanceId,
    LightId, Motion, NormalEncoding, NormalPacking, NormalSpace,
};
use octolux::scene::{Light, Material, Mesh};

/// The example's G-buffer formats.
const ALBEDO: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;
const NORMAL: wgpu::TextureFormat = wgpu::TextureFormat::Rg16Float;
const DEPTH: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// The techniques `T` cycles through: octolux's, in its order.
pub use octolux::gi::TECHNIQUES;

/// A device for the example: the best adapter, with octolux's required limits and GPU
/// timestamps where the adapter has them.
pub fn create_device(
    instance: &wgpu::Instance,
) -> Result<(wgpu::Adapter, wgpu::Device, wgpu::Queue)> {
    let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
        power_preference: wgpu::PowerPreference::HighPerformance,
        ..Default::default()
    }))
    .context("no GPU adapter (on Linux without a GPU, install mesa-vulkan-drivers)")?;
    let features = adapter.features() & wgpu::Features::TIMESTAMP_QUERY;
    let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some("deferred example"),
        required_features: features | octolux::embed::required_features(),
        required_limits: octolux::embed::required_limits(),
        ..Default::default()
    }))
    .context("cannot create a device with octolux's required limits")?;
    Ok((adapter, device, queue))
}

/// How the example moves things over time `t` (seconds): the block slides along x and the lamp
/// circles; at `t = 0` both are where the file puts them.
pub fn animate(model: &Model, t: f32) -> (Mat4, Vec3) {
    let block = Mat4::from_translation(Vec3::new(0.45 * (0.9 * t).sin(), 0.0, 0.0));
    let lamp = model
        .lamps
        .first()
        .map_or(Vec3::new(1.0, 1.8, 1.0), |l| l.position);
    let lamp = lamp + Vec3::new(0.5 * (1.3 * t).sin(), 0.0, 0.3 * (1.0 - (1.3 * t).cos()));
    (block, lamp)
}

struct DrawMesh {
    vertices: wgpu::Buffer,
    indices: wgpu::Buffer,
    count: u32,
    uniform: wgpu::Buffer,
    group: wgpu::BindGroup,
    rest: Mat4,
    color: Vec3,
    /// The octolux instance of this mesh.
    instance: InstanceId,
    moves: bool,
}

/// The example's renderer with octolux's GI.
pub struct Example {
    device: wgpu::Device,
    queue: wgpu::Queue,
    /// Octolux's GI: the only octolux object the renderer holds.
    pub gi: GiEngine,
    model: Model,
    lamp: LightId,
    meshes: Vec<DrawMesh>,
    width: u32,
    height: u32,
    camera: wgpu::Buffer,
    camera_group: wgpu::BindGroup,
    gbuffer_pipeline: wgpu::RenderPipeline,
    light_pipeline: wgpu::RenderPipeline,
    light_layout: wgpu::BindGroupLayout,
    frame_uniform: wgpu::Buffer,
    albedo: wgpu::TextureView,
    normal: wgpu::TextureView,
    depth: wgpu::TextureView,
    /// Where headless frames go (`Rgba8UnormSrgb`).
    pub output: wgpu::Texture,
    /// Whether the indirect light is added (the `G` key).
    pub indirect_on: bool,
}

impl Example {
    /// The renderer for `model` at `width` x `height` drawing into `target_format`, with
    /// octolux's `technique`.
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        model: Model,
        width: u32,
        height: u32,
        target_format: wgpu::TextureFormat,
        technique: &str,
    ) -> Result<Example> {
        // 1. Octolux on the example's device.
        let mut gi = GiEngine::new(device, queue, GiConfig::new(width, height, technique))?;
        // 2. The scene through code: one material, mesh and instance per glTF primitive.
        let model_layout = uniform_layout(device, wgpu::ShaderStages::VERTEX_FRAGMENT);
        let mut meshes = Vec::new();
        for mesh in &model.meshes {
            let material = gi.add_material(Material {
                name: mesh.node.clone(),
                base_color: mesh.base_color,
                emission: mesh.emission,
                ..Material::default()
            });
            let id = gi.add_mesh(
                Mesh {
                    name: mesh.node.clone(),
                    positions: mesh.positions.clone(),
                    normals: mesh.normals.clone(),
                    uvs: Vec::new(),
                    indices: mesh.indices.clone(),
                    material: 0,
                },
                material,
            )?;
            let moves = mesh.node == "block";
            let motion = if moves {
                Motion::Movable
            } else {
                Motion::Static
            };
            let instance = gi.add_instance(id, mesh.transform, motion)?;
            let vertices: Vec<f32> = mesh
                .positions
                .iter()
                .zip(&mesh.normals)
                .flat_map(|(p, n)| [p.x, p.y, p.z, n.x, n.y, n.z])
                .collect();
            let uniform = buffer(device, 144, wgpu::BufferUsages::UNIFORM);
            meshes.push(DrawMesh {
                vertices: buffer_init(
                    device,
                    bytemuck::cast_slice(&vertices),
                    wgpu::BufferUsages::VERTEX,
                    queue,
                ),
                indices: buffer_init(
                    device,
                    bytemuck::cast_slice(&mesh.indices),
                    wgpu::BufferUsages::INDEX,
                    queue,
                ),
                count: mesh.indices.len() as u32,
                group: bind(device, &model_layout, &[uniform.as_entire_binding()]),
                uniform,
                rest: mesh.transform,
                color: mesh.base_color,
                instance,
                moves,
            });
        }
        let first = model.lamps.first().copied().unwrap_or(Lamp {
            position: Vec3::new(1.0, 1.8, 1.0),
            intensity: Vec3::splat(3.0),
        });
        let lamp = gi.add_light(Light::point(first.position, first.intensity, 1.0))?;

        let camera_layout = uniform_layout(device, wgpu::ShaderStages::VERTEX);
        let camera = buffer(device, 64, wgpu::BufferUsages::UNIFORM);
        let camera_group = bind(device, &camera_layout, &[camera.as_entire_binding()]);
        let module = device.create_shader_module(wgpu::include_wgsl!("gbuffer.wgsl"));
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("gbuffer"),
            bind_group_layouts: &[Some(&camera_layout), Some(&model_layout)],
            immediate_size: 0,
        });
        let gbuffer_pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("gbuffer"),
            layout: Some(&layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs"),
                compilation_options: Default::default(),
                buffers: &[Some(wgpu::VertexBufferLayout {
                    array_stride: 24,
                    step_mode: wgpu::VertexStepMode::Vertex,
                    attributes: &wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3],
                })],
            },
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: Some(wgpu::DepthStencilState {
                format: DEPTH,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::Greater),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs"),
                compilation_options: Default::default(),
                targets: &[Some(ALBEDO.into()), Some(NORMAL.into())],
            }),
            multiview_mask: None,
            cache: None,
        });
        let (light_pipeline, light_layout) = light_pipeline(device, target_format);
        let frame_uniform = buffer(device, 112, wgpu::BufferUsages::UNIFORM);
        let target = |format, usage| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some("example target"),
                size: wgpu::Extent3d {
                    width,
                    height,
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage,
                view_formats: &[],
            })
        };
        let attachment =
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
        let view = |t: wgpu::Texture| t.create_view(&Default::default());
        Ok(Example {
            device: device.clone(),
            queue: queue.clone(),
            gi,
            model,
            lamp,
            meshes,
            width,
            height,
            camera,
            camera_group,
            gbuffer_pipeline,
            light_pipeline,
            light_layout,
            frame_uniform,
            albedo: view(target(ALBEDO, attachment)),
            normal: view(target(NORMAL, attachment)),
            depth: view(target(DEPTH, attachment)),
            output: target(
                wgpu::TextureFormat::Rgba8UnormSrgb,
                wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
            ),
            indirect_on: true,
        })
    }

    /// The camera: the file's, else one looking at the origin from +z; reversed-Z with an
    /// infinite far plane.
    pub fn camera(&self) -> CameraInput {
        let aspect = self.width as f32 / self.height as f32;
        let (transform, yfov, near) = match self.model.camera {
            Some(c) => (c.transform, c.yfov, c.znear),
            None => (Mat4::from_translation(Vec3::new(0.0, 1.0, 4.0)), 0.8, 0.05),
        };
        CameraInput::new(
            transform.inverse(),
            Mat4::perspective_infinite_reverse_rh(yfov, aspect, near),
        )
    }

    /// The model the example draws.
    pub fn model(&self) -> &Model {
        &self.model
    }

    /// Records and submits one frame at time `t` into `target` (a view of `output`, or of a
    /// window's surface texture).
    pub fn frame(&mut self, t: f32, target: &wgpu::TextureView) -> Result<()> {
        let (block, lamp_position) = animate(&self.model, t);
        let intensity = self
            .model
            .lamps
            .first()
            .map_or(Vec3::splat(3.0), |l| l.intensity);
        // 3. Per frame: what moved.
        self.gi
            .set_light(self.lamp, Light::point(lamp_position, intensity, 1.0))?;
        for mesh in &self.meshes {
            let model = if mesh.moves {
                block * mesh.rest
            } else {
                mesh.rest
            };
            if mesh.moves {
                self.gi.set_transform(mesh.instance, model)?;
            }
            let normal = model.inverse().transpose();
            let mut data = [0f32; 36];
            data[..16].copy_from_slice(&model.to_cols_array());
            data[16..32].copy_from_slice(&normal.to_cols_array());
            data[32..35].copy_from_slice(&mesh.color.to_array());
            self.queue
                .write_buffer(&mesh.uniform, 0, bytemuck::cast_slice(&data));
        }
        let camera = self.camera();
        let view_proj = camera.proj * camera.view;
        self.queue.write_buffer(
            &self.camera,
            0,
            bytemuck::cast_slice(&view_proj.to_cols_array()),
        );
        let mut frame = [0f32; 28];
        frame[..16].copy_from_slice(&view_proj.inverse().to_cols_array());
        frame[16..19].copy_from_slice(&lamp_position.to_array());
        frame[20..23].copy_from_slice(&intensity.to_array());
        frame[24..28].copy_from_slice(&[
            self.width as f32,
            self.height as f32,
            1.0,
            self.indirect_on as u32 as f32,
        ]);
        self.queue
            .write_buffer(&self.frame_uniform, 0, bytemuck::cast_slice(&frame));

        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("frame"),
            });
        self.draw_gbuffer(&mut encoder);
        // 4. Octolux's passes, reading the example's G-buffer.
        self.gi.record(
            &mut encoder,
            &FrameInput {
                camera,
                gbuffer: GBufferInput::new(
                    &self.depth,
                    DepthConvention::Reversed,
                    &self.normal,
                    NormalEncoding {
                        space: NormalSpace::World,
                        packing: NormalPacking::Octahedral,
                    },
                ),
                time: t,
            },
        )?;
        // 5. The example's lighting, with the indirect irradiance.
        let indirect = self.gi.indirect_view().context("no indirect image")?;
        let group = bind_textures(
            &self.device,
            &self.light_layout,
            &self.frame_uniform,
            [&self.albedo, &self.normal, &self.depth, indirect],
        );
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("lighting"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: target,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&self.light_pipeline);
            pass.set_bind_group(0, &group, &[]);
            pass.draw(0..3, 0..1);
        }
        self.queue.submit([encoder.finish()]);
        Ok(())
    }

    fn draw_gbuffer(&self, encoder: &mut wgpu::CommandEncoder) {
        let clear = |view| {
            Some(wgpu::RenderPassColorAttachment {
                view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                    store: wgpu::StoreOp::Store,
                },
            })
        };
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("example gbuffer"),
            color_attachments: &[clear(&self.albedo), clear(&self.normal)],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &self.depth,
                depth_ops: Some(wgpu::Operations {
                    // Reversed-Z: 0 is infinitely far.
                    load: wgpu::LoadOp::Clear(0.0),
                    store: wgpu::StoreOp::Store,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&self.gbuffer_pipeline);
        pass.set_bind_group(0, &self.camera_group, &[]);
        for mesh in &self.meshes {
            pass.set_bind_group(1, &mesh.group, &[]);
            pass.set_vertex_buffer(0, mesh.vertices.slice(..));
            pass.set_index_buffer(mesh.indices.slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(0..mesh.count, 0, 0..1);
        }
    }

    /// Renders `frames` frames all at time `t` into [`Example::output`] (what a paused
    /// animation shows).
    pub fn render_at(&mut self, t: f32, frames: u32) -> Result<()> {
        let view = self.output.create_view(&Default::default());
        for _ in 0..frames {
            self.frame(t, &view)?;
        }
        Ok(())
    }

    /// Renders `frames` frames at 30 per second into [`Example::output`] and reads the last
    /// one back as RGBA8 (sRGB).
    pub fn run_headless(&mut self, frames: u32) -> Result<image::RgbaImage> {
        let view = self.output.create_view(&Default::default());
        for i in 0..frames.max(1) {
            self.frame(i as f32 / 30.0, &view)?;
        }
        self.read_output()
    }

    /// Reads [`Example::output`] back.
    pub fn read_output(&self) -> Result<image::RgbaImage> {
        let (w, h) = (self.width, self.height);
        let row = (w * 4).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
        let staging = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("screenshot"),
            size: row as u64 * h as u64,
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        let mut encoder = self.device.create_command_encoder(&Default::default());
        encoder.copy_texture_to_buffer(
            self.output.as_image_copy(),
            wgpu::TexelCopyBufferInfo {
                buffer: &staging,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(row),
                    rows_per_image: Some(h),
                },
            },
            self.output.size(),
        );
        self.queue.submit([encoder.finish()]);
        let (send, receive) = std::sync::mpsc::channel();
        staging.map_async(wgpu::MapMode::Read, .., move |r| {
            let _ = send.send(r);
        });
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .context("waiting for the GPU")?;
        receive.recv()?.context("reading the screenshot back")?;
        let data = staging.get_mapped_range(..).context("screenshot mapping")?;
        let mut pixels = Vec::with_capacity((w * h * 4) as usize);
        for y in 0..h as usize {
            let start = y * row as usize;
            pixels.extend_from_slice(&data[start..start + w as usize * 4]);
        }
        image::RgbaImage::from_raw(w, h, pixels).context("screenshot size")
    }
}

fn light_pipeline(
    device: &wgpu::Device,
    format: wgpu::TextureFormat,
) -> (wgpu::RenderPipeline, wgpu::BindGroupLayout) {
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
    let float = wgpu::TextureSampleType::Float { filterable: false };
    let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("lighting"),
        entries: &[
            uniform_entry(0, wgpu::ShaderStages::FRAGMENT),
            texture(1, float),
            texture(2, float),
            texture(3, wgpu::TextureSampleType::Depth),
            texture(4, float),
        ],
    });
    let module = device.create_shader_module(wgpu::include_wgsl!("light.wgsl"));
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("lighting"),
        bind_group_layouts: &[Some(&layout)],
        immediate_size: 0,
    });
    let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("lighting"),
        layout: Some(&pipeline_layout),
        vertex: wgpu::VertexState {
            module: &module,
            entry_point: Some("vs"),
            compilation_options: Default::default(),
            buffers: &[],
        },
        primitive: Default::default(),
        depth_stencil: None,
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module: &module,
            entry_point: Some("fs"),
            compilation_options: Default::default(),
            targets: &[Some(format.into())],
        }),
        multiview_mask: None,
        cache: None,
    });
    (pipeline, layout)
}

fn uniform_entry(binding: u32, visibility: wgpu::ShaderStages) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

fn uniform_layout(device: &wgpu::Device, visibility: wgpu::ShaderStages) -> wgpu::BindGroupLayout {
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: None,
        entries: &[uniform_entry(0, visibility)],
    })
}

fn bind(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    resources: &[wgpu::BindingResource],
) -> wgpu::BindGroup {
    let entries: Vec<wgpu::BindGroupEntry> = resources
        .iter()
        .enumerate()
        .map(|(i, r)| wgpu::BindGroupEntry {
            binding: i as u32,
            resource: r.clone(),
        })
        .collect();
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout,
        entries: &entries,
    })
}

fn bind_textures(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    uniform: &wgpu::Buffer,
    textures: [&wgpu::TextureView; 4],
) -> wgpu::BindGroup {
    let mut resources = vec![uniform.as_entire_binding()];
    resources.extend(textures.map(wgpu::BindingResource::TextureView));
    bind(device, layout, &resources)
}

fn buffer(device: &wgpu::Device, size: u64, usage: wgpu::BufferUsages) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: None,
        size,
        usage: usage | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

fn buffer_init(
    device: &wgpu::Device,
    data: &[u8],
    usage: wgpu::BufferUsages,
    queue: &wgpu::Queue,
) -> wgpu::Buffer {
    let b = buffer(
        device,
        (data.len() as u64).next_multiple_of(4).max(4),
        usage,
    );
    queue.write_buffer(&b, 0, data);
    b
}
