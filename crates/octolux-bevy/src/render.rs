//! The render world's side: one [`GiEngine`] per camera with [`OctoluxGi`], kept in step with
//! the mirrored scene, recorded into Bevy's command encoder after the prepass, and composed
//! into the view's HDR target after Bevy's deferred lighting.

use crate::mirror::{GiScene, SceneSnapshot};
use crate::{units, DeviceStatus, GiAmbient, OctoluxGi, OctoluxGiStatus};
use bevy::app::App;
use bevy::camera::Exposure;
use bevy::core_pipeline::core_3d::main_opaque_pass_3d;
use bevy::core_pipeline::prepass::ViewPrepassTextures;
use bevy::core_pipeline::schedule::Core3d;
use bevy::core_pipeline::Core3dSystems;
use bevy::ecs::prelude::*;
use bevy::light::{AmbientLight, GlobalAmbientLight};
use bevy::log::{error, warn};
use bevy::pbr::deferred::deferred_lighting;
use bevy::render::camera::ExtractedCamera;
use bevy::render::renderer::{RenderContext, RenderDevice, RenderQueue, ViewQuery};
use bevy::render::sync_world::MainEntity;
use bevy::render::view::{ExtractedView, ViewTarget};
use bevy::render::{Extract, ExtractSchedule, Render, RenderApp, RenderStartup, RenderSystems};
use bevy::time::Time;
use glam::{Mat4, Vec3};
use octolux::embed::{
    CameraInput, DepthConvention, FrameInput, GBufferInput, GiConfig, GiEngine, InstanceId,
    LightId, MaterialId, Motion, NormalEncoding, NormalPacking, NormalSpace, TextureId,
};
use octolux::scene::Sky;
use std::collections::HashMap;
use std::sync::{Arc, Mutex, MutexGuard};

/// Registers the render world's systems.
pub(crate) fn build(app: &mut App, status: OctoluxGiStatus) {
    let Some(render_app) = app.get_sub_app_mut(RenderApp) else {
        warn!("octolux GI: no render app (add OctoluxGiPlugin after DefaultPlugins)");
        return;
    };
    render_app
        .insert_resource(status)
        .init_resource::<GiViews>()
        .add_systems(RenderStartup, check_device)
        .add_systems(ExtractSchedule, extract_gi)
        .add_systems(Render, prepare_gi.in_set(RenderSystems::PrepareResources))
        .add_systems(
            Core3d,
            (
                record_gi
                    .after(Core3dSystems::Prepass)
                    .before(Core3dSystems::MainPass),
                compose_gi
                    .after(deferred_lighting)
                    .before(main_opaque_pass_3d)
                    .in_set(Core3dSystems::MainPass),
            ),
        );
}

/// Every GI camera's octolux engine, in the render world, by main-world camera entity.
#[derive(Resource, Default)]
pub struct GiViews {
    scene: Arc<SceneSnapshot>,
    requests: HashMap<Entity, Request>,
    views: HashMap<Entity, ViewGi>,
    time: f32,
    compose: Option<Compose>,
    /// The last error building each camera's engine, logged once.
    build_errors: HashMap<Entity, String>,
}

impl GiViews {
    /// The octolux engine of `camera` (a main-world entity with [`OctoluxGi`]), for tests and
    /// tools: its indirect irradiance ([`GiEngine::read_indirect`]), memory and scene.
    pub fn engine(&self, camera: Entity) -> Option<MutexGuard<'_, GiEngine>> {
        self.views
            .get(&camera)
            .map(|v| v.engine.lock().unwrap_or_else(|p| p.into_inner()))
    }
}

/// What the main world asks of one camera this frame.
struct Request {
    gi: OctoluxGi,
    /// Octolux's sky radiance (W/(m^2 sr)) where the camera's ambient light is its sky.
    sky: Option<Vec3>,
    exposure: f32,
}

/// One camera's engine and what it was built from.
struct ViewGi {
    // A mutex because the render world's resources are shared between threads (octolux's
    // techniques are `Send` but keep per-thread caches).
    engine: Mutex<GiEngine>,
    /// The snapshot generation, sky and shadow map size the engine's scene was built from.
    built: (u64, Option<[u32; 3]>, u32),
    instances: Vec<InstanceId>,
    lights: Vec<LightId>,
    technique: (String, String),
    params: wgpu::Buffer,
    /// Whether this frame's GI was recorded (composed only then).
    recorded: bool,
    /// Whether the engine can record (a scene with triangles, no failure since its build).
    runnable: bool,
    last_error: Option<String>,
}

fn check_device(device: Res<RenderDevice>, status: Res<OctoluxGiStatus>) {
    match octolux::embed::check_device(device.wgpu_device()) {
        Ok(()) => status.set_device(DeviceStatus::Ready),
        Err(e) => {
            error!("octolux GI is off: {e}. The app keeps running without it.");
            status.set_device(DeviceStatus::Unavailable(e.to_string()));
        }
    }
}

/// What extraction reads of a GI camera.
type GiCamera<'a> = (
    Entity,
    &'a OctoluxGi,
    Option<&'a AmbientLight>,
    Option<&'a Exposure>,
);

fn extract_gi(
    mut gi: ResMut<GiViews>,
    scene: Extract<Res<GiScene>>,
    cameras: Extract<Query<GiCamera>>,
    global_ambient: Extract<Option<Res<GlobalAmbientLight>>>,
    time: Extract<Res<Time>>,
) {
    gi.scene = scene.0.clone();
    gi.time = time.elapsed_secs();
    gi.requests.clear();
    for (entity, settings, ambient, exposure) in &cameras {
        let sky = (settings.ambient == GiAmbient::Sky).then(|| {
            let (color, nits) = match ambient {
                Some(a) => (a.color, a.brightness),
                None => global_ambient
                    .as_ref()
                    .map_or((bevy::color::Color::BLACK, 0.0), |g| {
                        (g.color, g.brightness)
                    }),
            };
            units::linear_rgb(color) * units::radiance_from_nits(nits)
        });
        gi.requests.insert(
            entity,
            Request {
                gi: settings.clone(),
                sky,
                // As Bevy extracts it for its own shading.
                exposure: exposure.copied().unwrap_or_default().exposure(),
            },
        );
    }
}

/// Brings every GI camera's engine up to date with this frame's scene and settings.
fn prepare_gi(
    mut gi: ResMut<GiViews>,
    device: Res<RenderDevice>,
    queue: Res<RenderQueue>,
    status: Res<OctoluxGiStatus>,
    cameras: Query<(&MainEntity, &ExtractedCamera, &ViewTarget)>,
) {
    let gi = &mut *gi;
    let available = status.device() == DeviceStatus::Ready;
    gi.views.retain(|e, _| gi.requests.contains_key(e));
    gi.build_errors.retain(|e, _| gi.requests.contains_key(e));
    status.retain_cameras(|e| gi.requests.contains_key(e));
    if !available {
        gi.views.clear();
        return;
    }
    let device = device.wgpu_device();
    let queue: &wgpu::Queue = &queue;
    for (main, camera, target) in &cameras {
        let entity = main.id();
        let Some(request) = gi.requests.get(&entity) else {
            continue;
        };
        let Some(size) = camera.physical_target_size.filter(|s| s.x > 0 && s.y > 0) else {
            continue;
        };
        if let Some(view) = gi.views.get_mut(&entity) {
            view.recorded = false;
        }
        if !request.gi.enabled {
            status.update_camera(entity, |s| s.active = false);
            continue;
        }
        let compose = gi.compose.get_or_insert_with(|| Compose::new(device));
        compose.pipeline(device, target.main_texture_format());
        let result = sync_view(
            &mut gi.views,
            entity,
            request,
            &gi.scene,
            (size.x, size.y),
            device,
            queue,
        );
        let view = gi.views.get_mut(&entity);
        let memory = view
            .as_ref()
            .map_or(0, |v| v.engine.lock().map_or(0, |e| e.memory().total()));
        status.update_camera(entity, |s| {
            s.technique = request.gi.technique.clone();
            s.memory_bytes = memory;
            if let Err(e) = &result {
                s.error = Some(e.clone());
            }
        });
        match (result, view) {
            (Err(e), Some(view)) => {
                view.runnable = false;
                report(view, &e);
            }
            // The engine could not be built: logged once per message, tried again next frame.
            (Err(e), None) => {
                if gi.build_errors.get(&entity) != Some(&e) {
                    error!("octolux GI: {e}. This camera renders without it.");
                    gi.build_errors.insert(entity, e);
                }
            }
            (Ok(()), _) => {
                gi.build_errors.remove(&entity);
            }
        }
    }
}

/// Logs an error once per distinct message.
fn report(view: &mut ViewGi, message: &str) {
    if view.last_error.as_deref() != Some(message) {
        error!("octolux GI: {message}. This camera renders without it until the scene changes.");
        view.last_error = Some(message.to_string());
    }
}

/// Builds or updates one camera's engine for this frame.
fn sync_view(
    views: &mut HashMap<Entity, ViewGi>,
    entity: Entity,
    request: &Request,
    scene: &SceneSnapshot,
    size: (u32, u32),
    device: &wgpu::Device,
    queue: &wgpu::Queue,
) -> Result<(), String> {
    let sky = request.sky.map(|s| s.to_array().map(f32::to_bits));
    let built = (scene.generation, sky, request.gi.shadow_map_size);
    let technique = (
        request.gi.technique.clone(),
        format!("{:?}", request.gi.settings),
    );
    let rebuild = views.get(&entity).is_none_or(|v| v.built != built);
    if rebuild {
        // Anything structural: a fresh engine from the snapshot, as octolux itself rebuilds.
        views.remove(&entity);
        let view = build_view(request, scene, size, device, queue)?;
        views.insert(entity, view);
    }
    let Some(view) = views.get_mut(&entity) else {
        return Ok(());
    };
    view.built = built;
    let engine = view.engine.get_mut().unwrap_or_else(|p| p.into_inner());
    let config = engine.config();
    if (config.width, config.height) != size {
        engine.resize(size.0, size.1).map_err(|e| e.to_string())?;
    }
    if view.technique != technique {
        engine
            .set_technique(&request.gi.technique, &request.gi.settings)
            .map_err(|e| e.to_string())?;
        view.technique = technique;
        view.runnable = !scene.instances.is_empty();
        view.last_error = None;
    }
    // Per frame: what moves.
    for (instance, id) in scene.instances.iter().zip(&view.instances) {
        if instance.motion == Motion::Movable {
            engine
                .set_transform(*id, instance.transform)
                .map_err(|e| e.to_string())?;
        }
    }
    for (light, id) in scene.lights.iter().zip(&view.lights) {
        engine
            .set_light(*id, light.clone())
            .map_err(|e| e.to_string())?;
    }
    let params = [units::compose_scale(request.exposure), 0.0, 0.0, 0.0];
    queue.write_buffer(&view.params, 0, bytemuck::cast_slice(&params));
    Ok(())
}

/// A fresh engine holding the snapshot's scene.
fn build_view(
    request: &Request,
    scene: &SceneSnapshot,
    size: (u32, u32),
    device: &wgpu::Device,
    queue: &wgpu::Queue,
) -> Result<ViewGi, String> {
    let e = |e: octolux::Error| e.to_string();
    let config = GiConfig {
        settings: request.gi.settings.clone(),
        shadow_map_size: request.gi.shadow_map_size,
        ..GiConfig::new(size.0, size.1, &request.gi.technique)
    };
    let mut engine = GiEngine::new(device, queue, config).map_err(e)?;
    let textures: Vec<TextureId> = scene
        .textures
        .iter()
        .map(|t| engine.add_texture((**t).clone()))
        .collect::<Result<_, _>>()
        .map_err(e)?;
    let materials: Vec<MaterialId> = scene
        .materials
        .iter()
        .map(|m| {
            let mut m = m.clone();
            m.base_color_texture = m
                .base_color_texture
                .and_then(|t| textures.get(t as usize))
                .map(|t| t.0);
            engine.add_material(m)
        })
        .collect();
    let mut meshes = Vec::new();
    for (i, (data, material)) in scene.meshes.iter().enumerate() {
        let mesh = data.to_mesh(format!("bevy mesh {i}"));
        meshes.push(engine.add_mesh(mesh, materials[*material]).map_err(e)?);
    }
    let mut instances = Vec::new();
    for instance in &scene.instances {
        instances.push(
            engine
                .add_instance(meshes[instance.mesh], instance.transform, instance.motion)
                .map_err(e)?,
        );
    }
    let mut lights = Vec::new();
    for light in &scene.lights {
        lights.push(engine.add_light(light.clone()).map_err(e)?);
    }
    if let Some(radiance) = request.sky.filter(|s| s.max_element() > 0.0) {
        engine.set_sky(Some(Sky::constant(radiance)));
    }
    let params = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("octolux compose params"),
        size: 16,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    Ok(ViewGi {
        engine: Mutex::new(engine),
        built: (0, None, 0),
        instances,
        lights,
        technique: (
            request.gi.technique.clone(),
            format!("{:?}", request.gi.settings),
        ),
        params,
        recorded: false,
        // Octolux needs triangles to build anything; an empty scene adds no light.
        runnable: !scene.instances.is_empty(),
        last_error: None,
    })
}

fn mat4(m: bevy::math::Mat4) -> Mat4 {
    Mat4::from_cols_array(&m.to_cols_array())
}

/// Records octolux's passes for the current view, after Bevy's prepass wrote its depth and
/// normals.
fn record_gi(
    view: ViewQuery<(&MainEntity, &ExtractedView, &ViewPrepassTextures)>,
    mut gi: ResMut<GiViews>,
    status: Res<OctoluxGiStatus>,
    mut ctx: RenderContext,
) {
    let (main, extracted, prepass) = view.into_inner();
    let entity = main.id();
    if !gi.requests.get(&entity).is_some_and(|r| r.gi.enabled) {
        return;
    }
    let time = gi.time;
    let Some(view) = gi.views.get_mut(&entity) else {
        return;
    };
    if !view.runnable {
        return;
    }
    let (Some(depth), Some(normal)) = (prepass.depth_only_view(), prepass.normal_view()) else {
        report(view, "the camera has no depth or normal prepass");
        return;
    };
    let camera = CameraInput::new(
        mat4(extracted.world_from_view.to_matrix().inverse()),
        mat4(extracted.clip_from_view),
    );
    let input = FrameInput {
        camera,
        gbuffer: GBufferInput::new(
            depth,
            DepthConvention::Reversed,
            normal,
            // Bevy's normal prepass: world space, n * 0.5 + 0.5 in Rgb10a2Unorm.
            NormalEncoding {
                space: NormalSpace::World,
                packing: NormalPacking::XyzUnorm,
            },
        ),
        time,
    };
    let engine = view.engine.get_mut().unwrap_or_else(|p| p.into_inner());
    let result = engine.record(ctx.command_encoder(), &input);
    let timings = engine.take_timings().ok().flatten();
    match result {
        Ok(()) => {
            view.recorded = true;
            status.update_camera(entity, |s| {
                s.active = true;
                s.error = None;
                if let Some(t) = timings {
                    s.timings = t.into_iter().map(|t| (t.name, t.ms)).collect();
                    s.timings_serial += 1;
                }
            });
        }
        Err(e) => {
            let e = e.to_string();
            view.runnable = false;
            report(view, &e);
            status.update_camera(entity, |s| {
                s.active = false;
                s.error = Some(e);
            });
        }
    }
}

/// Adds `diffuse / pi * E` to the view's HDR target, after Bevy's deferred lighting.
fn compose_gi(
    view: ViewQuery<(&MainEntity, &ViewTarget, &ViewPrepassTextures)>,
    gi: Res<GiViews>,
    device: Res<RenderDevice>,
    mut ctx: RenderContext,
) {
    let (main, target, prepass) = view.into_inner();
    let (Some(view), Some(compose)) = (gi.views.get(&main.id()), &gi.compose) else {
        return;
    };
    if !view.recorded {
        return;
    }
    let (Some(pipeline), Some(deferred)) = (
        compose.pipelines.get(&target.main_texture_format()),
        prepass.deferred.as_ref(),
    ) else {
        return;
    };
    let engine = view.engine.lock().unwrap_or_else(|p| p.into_inner());
    let Some(indirect) = engine.indirect_view() else {
        return;
    };
    let device = device.wgpu_device();
    let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("octolux compose"),
        layout: &compose.layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::TextureView(&deferred.texture.default_view),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: wgpu::BindingResource::TextureView(indirect),
            },
            wgpu::BindGroupEntry {
                binding: 2,
                resource: view.params.as_entire_binding(),
            },
        ],
    });
    let mut pass = ctx
        .command_encoder()
        .begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("octolux compose"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: target.main_texture_view(),
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Load,
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
    pass.set_pipeline(pipeline);
    pass.set_bind_group(0, &group, &[]);
    pass.draw(0..3, 0..1);
}

/// The full-screen pass that adds the indirect light: one pipeline per target format.
struct Compose {
    layout: wgpu::BindGroupLayout,
    pipeline_layout: wgpu::PipelineLayout,
    module: wgpu::ShaderModule,
    pipelines: HashMap<wgpu::TextureFormat, wgpu::RenderPipeline>,
}

impl Compose {
    fn new(device: &wgpu::Device) -> Compose {
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
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("octolux compose"),
            entries: &[
                texture(0, wgpu::TextureSampleType::Uint),
                texture(1, wgpu::TextureSampleType::Float { filterable: false }),
                wgpu::BindGroupLayoutEntry {
                    binding: 2,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                },
            ],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("octolux compose"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let module = device.create_shader_module(wgpu::include_wgsl!("compose.wgsl"));
        Compose {
            layout,
            pipeline_layout,
            module,
            pipelines: HashMap::new(),
        }
    }

    fn pipeline(&mut self, device: &wgpu::Device, format: wgpu::TextureFormat) {
        if self.pipelines.contains_key(&format) {
            return;
        }
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("octolux compose"),
            layout: Some(&self.pipeline_layout),
            vertex: wgpu::VertexState {
                module: &self.module,
                entry_point: Some("vs"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: Default::default(),
            depth_stencil: None,
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &self.module,
                entry_point: Some("fs"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format,
                    // Added to Bevy's lighting; the target's alpha is kept.
                    blend: Some(wgpu::BlendState {
                        color: wgpu::BlendComponent {
                            src_factor: wgpu::BlendFactor::One,
                            dst_factor: wgpu::BlendFactor::One,
                            operation: wgpu::BlendOperation::Add,
                        },
                        alpha: wgpu::BlendComponent {
                            src_factor: wgpu::BlendFactor::Zero,
                            dst_factor: wgpu::BlendFactor::One,
                            operation: wgpu::BlendOperation::Add,
                        },
                    }),
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        });
        self.pipelines.insert(format, pipeline);
    }
}
