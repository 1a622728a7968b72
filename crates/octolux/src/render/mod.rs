//! The GPU frame: shadow maps -> G-buffer -> direct light -> GI technique -> compose + tone map.
//!
//! [`Renderer`] owns every stage. A frame evaluates the scene at a time, uploads transforms,
//! lights and matrices, records each stage as a named pass (timed by [`PassTimer`]) and leaves
//! the linear HDR image and the tone-mapped display image ready to read back.

mod compose;
mod direct;

use crate::frame::sky::SkyGpu;
use crate::frame::{
    shadow, shadow_layer_count, sky_regions_of, CameraUniform, GBuffer, GpuLight, SceneGpu,
    ShadowMaps,
};
use crate::gpu::pack::f16_to_f32;
use crate::image_io::check_image_size;

use crate::gi::{self, GiFrame, GiTechnique};
use crate::gpu::{read_texture, GpuContext, PassTimer, PassTiming};
use crate::image_io::HdrImage;
use crate::scene::{CameraView, Light, LightKind, Scene};
use crate::{Error, Result};
use bytemuck::Zeroable;
use glam::{Vec3, Vec4};

/// Frame settings.
#[derive(Clone, Debug)]
pub struct RenderSettings {
    /// Output width in pixels.
    pub width: u32,
    /// Output height in pixels.
    pub height: u32,
    /// Side of each shadow-map layer in texels.
    pub shadow_map_size: u32,
    /// Which scene camera to use.
    pub camera: usize,
    /// GI technique name (see [`gi::TECHNIQUES`]).
    pub gi: String,
    /// Settings of the GI techniques.
    pub gi_settings: gi::GiSettings,
    /// Soft shadows for the sky's directional lights (percentage-closer soft shadows with
    /// each light's angular size; `lights.wgsl`), else the 3x3 filter of every light. Off by
    /// default: smoother, but measured further from the reference (docs/scene-format.md).
    pub soft_sky_shadows: bool,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            width: 640,
            height: 360,
            shadow_map_size: 2048,
            camera: 0,
            gi: "none".into(),
            gi_settings: gi::GiSettings::default(),
            soft_sky_shadows: false,
        }
    }
}

/// What the HDR and display images of a frame hold (the G-buffer, direct light and GI passes
/// run the same whatever is chosen).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Output {
    /// The frame: direct light plus albedo/pi x indirect irradiance.
    #[default]
    Final = 0,
    /// Direct light (and emission) only.
    Direct = 1,
    /// The technique's indirect irradiance E, shown as E/pi: the radiance a white Lambertian
    /// surface would reflect, so it reads on the same exposure as the frame.
    IndirectIrradiance = 2,
    /// The technique's ambient occlusion (the indirect image's alpha: 1 = open, 0 =
    /// occluded), shown without exposure; only the cone-tracing techniques compute one.
    AmbientOcclusion = 3,
    /// The technique's specular image ([`crate::gi::GiTechnique::specular_view`]), black for
    /// techniques without one.
    Specular = 4,
}

impl Output {
    /// Every output, in menu order.
    pub const ALL: [Output; 5] = [
        Output::Final,
        Output::Direct,
        Output::IndirectIrradiance,
        Output::AmbientOcclusion,
        Output::Specular,
    ];

    /// Short name for menus and file names.
    pub fn name(self) -> &'static str {
        match self {
            Output::Final => "final",
            Output::Direct => "direct",
            Output::IndirectIrradiance => "indirect irradiance",
            Output::AmbientOcclusion => "ambient occlusion",
            Output::Specular => "specular",
        }
    }

    /// Whether the reference path tracer computes this output too (the frame, direct light
    /// and indirect irradiance; not ambient occlusion or specular), so the two can be compared.
    pub fn has_reference(self) -> bool {
        matches!(
            self,
            Output::Final | Output::Direct | Output::IndirectIrradiance
        )
    }
}

/// G-buffer contents read back to the CPU (for tests and debugging).
#[derive(Clone, Debug)]
pub struct GBufferImages {
    /// Linear albedo per pixel (zero on background).
    pub albedo: Vec<Vec3>,
    /// World normal per pixel (zero on background).
    pub normal: Vec<Vec3>,
    /// Emission per pixel.
    pub emission: Vec<Vec3>,
    /// Depth-buffer value per pixel (1 on background).
    pub depth: Vec<f32>,
}

/// The GPU renderer for one scene and output size.
pub struct Renderer {
    ctx: GpuContext,
    settings: RenderSettings,
    scene_gpu: SceneGpu,
    shadows: ShadowMaps,
    gbuffer: GBuffer,
    direct: direct::DirectLight,
    compose: compose::Compose,
    gi: Box<dyn GiTechnique>,
    /// Directional lights standing in for the sky, appended to each frame's lights.
    sky_lights: Vec<Light>,
    /// Per sky light, the tangent of its angular radius (how soft its shadows are).
    sky_spread: Vec<f32>,
    /// Whether the sky lights' shadow maps are drawn and still valid (no object moves).
    sky_shadows_valid: bool,
    camera_uniform: wgpu::Buffer,
    timer: PassTimer,
    last_view: Option<CameraView>,
    output: Output,
}

/// Checks that the shadow-map array the lights need (6 layers per point light, 1 per spot or
/// directional light, and the sky's lights packed `SKY_TILES`^2 to a layer) fits the adapter's
/// `max_texture_array_layers`; the error says how many lights fit.
fn check_shadow_layers(ctx: &GpuContext, lights: &[Light], sky_lights: usize) -> Result<()> {
    let limit = ctx.device.limits().max_texture_array_layers;
    let punctual = shadow_layer_count(lights);
    let sky = (sky_lights as u32).div_ceil(shadow::SKY_TILES * shadow::SKY_TILES);
    let need = punctual as u64 + sky as u64;
    if need > limit as u64 {
        let points = lights.iter().filter(|l| l.kind == LightKind::Point).count();
        return Err(Error::InvalidArgument(format!(
            "the scene's {} lights ({points} point lights at 6 shadow-map layers each, the others \
             at 1{}) need {need} shadow-map layers; this adapter allows {limit} \
             (max_texture_array_layers): at most {} point lights, or {} spot and directional \
             lights",
            lights.len(),
            if sky > 0 {
                format!(", the sky {sky}")
            } else {
                String::new()
            },
            (limit.saturating_sub(sky)) / 6,
            limit.saturating_sub(sky),
        )));
    }
    Ok(())
}

impl Renderer {
    /// Uploads `scene` and builds every stage for images of the configured size.
    pub fn new(ctx: &GpuContext, scene: &Scene, settings: RenderSettings) -> Result<Renderer> {
        check_image_size(settings.width, settings.height)?;
        scene.check_camera(settings.camera)?;
        let max_dim = ctx.device.limits().max_texture_dimension_2d;
        if settings.width > max_dim || settings.height > max_dim {
            return Err(Error::InvalidArgument(format!(
                "image size {}x{} exceeds the adapter's limit of {max_dim} per side",
                settings.width, settings.height
            )));
        }
        if settings.shadow_map_size < 16 || settings.shadow_map_size > max_dim {
            return Err(Error::InvalidArgument(format!(
                "shadow map size {} must be within 16..={max_dim}",
                settings.shadow_map_size
            )));
        }
        let (w, h) = (settings.width, settings.height);
        let (sky_lights, sky_spread): (Vec<Light>, Vec<f32>) =
            sky_regions_of(scene).into_iter().unzip();
        check_shadow_layers(ctx, &scene.lights, sky_lights.len())?;
        let mut lights = scene.lights.clone();
        lights.extend(sky_lights.iter().cloned());
        let scene_gpu = SceneGpu::new(ctx, scene, 1 + shadow_layer_count(&lights))?;
        let shadows = ShadowMaps::new(
            ctx,
            &scene_gpu,
            &lights,
            sky_lights.len(),
            settings.shadow_map_size,
        );
        let sky = SkyGpu::new(ctx, scene.sky.as_ref());
        let gbuffer = GBuffer::new(ctx, &scene_gpu, w, h);
        let camera_uniform = ctx.create_buffer_init(
            "frame",
            "camera",
            bytemuck::bytes_of(&CameraUniform::zeroed()),
            wgpu::BufferUsages::UNIFORM,
        );
        let direct = direct::DirectLight::new(ctx, &camera_uniform, &gbuffer, &shadows, &sky, w, h);
        let gi = gi::create(&settings.gi, ctx, scene, &settings.gi_settings, w, h)?;
        let mut compose = compose::Compose::new(ctx, w, h);
        compose.bind(
            ctx,
            &camera_uniform,
            &direct.output_view,
            &gbuffer,
            gi.indirect_view(),
            gi.specular_view(),
        );
        ctx.check_errors()?;
        Ok(Renderer {
            ctx: ctx.clone(),
            settings,
            scene_gpu,
            shadows,
            gbuffer,
            direct,
            compose,
            gi,
            sky_lights,
            sky_spread,
            sky_shadows_valid: false,
            camera_uniform,
            timer: PassTimer::new(ctx),
            last_view: None,
            output: Output::Final,
        })
    }

    /// Replaces the GI technique with `name` built from `gi_settings`, keeping everything else
    /// (scene upload, shadow maps, G-buffer, direct light): what a run-time technique switch or
    /// a settings change needs. On error the current technique stays. The old technique's
    /// entries leave the memory ledger.
    pub fn set_technique(
        &mut self,
        scene: &Scene,
        name: &str,
        gi_settings: &gi::GiSettings,
    ) -> Result<()> {
        let (w, h) = (self.settings.width, self.settings.height);
        // Let the GPU finish with the old technique's resources before they are replaced.
        self.ctx.wait_idle()?;
        let technique = gi::create(name, &self.ctx, scene, gi_settings, w, h)?;
        let old = std::mem::replace(&mut self.gi, technique);
        if old.name() != self.gi.name() {
            // Same owner name: the new technique's entries have already replaced the old ones.
            self.ctx.ledger.release_owner(old.name());
        }
        for owner in old.other_ledger_owners() {
            if !self.gi.other_ledger_owners().contains(owner) {
                self.ctx.ledger.release_owner(owner);
            }
        }
        drop(old);
        self.compose.bind(
            &self.ctx,
            &self.camera_uniform,
            &self.direct.output_view,
            &self.gbuffer,
            self.gi.indirect_view(),
            self.gi.specular_view(),
        );
        self.settings.gi = name.to_string();
        self.settings.gi_settings = gi_settings.clone();
        self.ctx.check_errors()
    }

    /// Chooses what the next frames' images hold (default [`Output::Final`]).
    pub fn set_output(&mut self, output: Output) {
        self.output = output;
    }

    /// What the frames' images hold.
    pub fn output(&self) -> Output {
        self.output
    }

    /// The tone-mapped display image of the last frame on the GPU: `Rgba8Unorm` holding
    /// sRGB-encoded values, usable as a copy source (e.g. into an `Rgba8UnormSrgb` texture that
    /// a window samples).
    pub fn display_texture(&self) -> &wgpu::Texture {
        &self.compose.ldr
    }

    /// The settings in use.
    pub fn settings(&self) -> &RenderSettings {
        &self.settings
    }

    /// The active GI technique.
    pub fn technique(&self) -> &dyn GiTechnique {
        self.gi.as_ref()
    }

    /// The G-buffer (for GI techniques and debugging).
    pub fn gbuffer(&self) -> &GBuffer {
        &self.gbuffer
    }

    /// The shadow maps.
    pub fn shadow_maps(&self) -> &ShadowMaps {
        &self.shadows
    }

    /// Renders `scene` (the one given to [`Renderer::new`]) at time `t` seconds, waits for the
    /// GPU, and returns the per-pass times of this frame.
    pub fn render(&mut self, scene: &Scene, t: f32) -> Result<Vec<PassTiming>> {
        self.record(scene, t)?;
        self.timer.finish_frame()
    }

    /// Like [`Renderer::render`] but without waiting for the GPU (for real-time loops): returns
    /// the pass times of the most recent earlier frame whose GPU timestamps have come back, or
    /// None while none has. Reading an image back still waits for its frame.
    pub fn render_pipelined(&mut self, scene: &Scene, t: f32) -> Result<Option<Vec<PassTiming>>> {
        self.record(scene, t)?;
        self.timer.finish_frame_pipelined()
    }

    /// Records every pass of one frame into the timer.
    fn record(&mut self, scene: &Scene, t: f32) -> Result<()> {
        let (w, h) = (self.settings.width, self.settings.height);
        let mut frame = scene.frame(t, self.settings.camera);
        let first_sky = frame.lights.len();
        frame.lights.extend(self.sky_lights.iter().cloned());
        let view = frame.camera.view(w, h);
        let layers = self.shadows.layer_views(&frame.lights, scene.bounds_at(t));

        let queue = &self.ctx.queue;
        self.scene_gpu
            .update_objects(queue, &frame.object_transforms);
        let mut views = vec![(view.view_proj, view.position.extend(1.0))];
        views.extend(layers.iter().map(|l| (l.raster_view_proj, Vec4::ZERO)));
        self.scene_gpu.update_views(queue, &views);
        let gpu_lights: Vec<GpuLight> = frame
            .lights
            .iter()
            .enumerate()
            .map(|(i, light)| {
                let slot = self.shadows.slots.get(i);
                let first = slot.and_then(|s| layers.get(s.first_layer as usize));
                let (kind, cos_inner, cos_outer) = match light.kind {
                    LightKind::Point => (0.0, 1.0, -1.0),
                    LightKind::Spot {
                        inner_angle,
                        outer_angle,
                    } => (1.0, inner_angle.cos(), outer_angle.cos()),
                    LightKind::Directional => (2.0, 1.0, -1.0),
                };
                // Sky lights: x the tangent of the angular radius, y the shadow view's depth
                // range, z the largest soft-shadow filter radius in texels (lights.wgsl).
                let position = match i.checked_sub(first_sky) {
                    Some(k) => Vec3::new(
                        match self.settings.soft_sky_shadows {
                            true => self.sky_spread.get(k).copied().unwrap_or(0.0),
                            false => 0.0,
                        },
                        first.map_or(0.0, |v| v.depth_range),
                        shadow::sky_tile_margin(self.shadows.size / shadow::SKY_TILES)
                            .saturating_sub(2) as f32,
                    ),
                    None => light.position,
                };
                GpuLight {
                    position_kind: position.extend(kind).to_array(),
                    direction_cos_inner: light
                        .direction
                        .normalize_or(Vec3::NEG_Y)
                        .extend(cos_inner)
                        .to_array(),
                    radiant_cos_outer: light.radiant().extend(cos_outer).to_array(),
                    shadow: shadow::shadow_params(slot, first).to_array(),
                }
            })
            .collect();
        self.direct.upload(queue, &gpu_lights);
        self.shadows.upload_matrices(queue, &layers);
        let camera = CameraUniform {
            view_proj: view.view_proj.to_cols_array_2d(),
            inv_view_proj: view.inv_view_proj.to_cols_array_2d(),
            position: view.position.extend(1.0).to_array(),
            size: [w as f32, h as f32, 1.0 / w as f32, 1.0 / h as f32],
            params: [
                scene.exposure.exp2(),
                frame.lights.len() as f32,
                t,
                self.output as u32 as f32,
            ],
        };
        queue.write_buffer(&self.camera_uniform, 0, bytemuck::bytes_of(&camera));

        // The sky's maps depend on the geometry only: drawn once for a scene whose objects
        // stand still, every frame otherwise.
        let with_sky = !self.sky_shadows_valid;
        self.shadows
            .render(&mut self.timer, &self.scene_gpu, with_sky);
        self.sky_shadows_valid = !scene.objects.iter().any(|o| o.animation.is_some());
        self.gbuffer.render(&mut self.timer, &self.scene_gpu);
        self.direct.render(&mut self.timer, w, h);
        let gi_frame = GiFrame {
            scene,
            frame: &frame,
            view: &view,
            gbuffer: &self.gbuffer,
            camera_uniform: &self.camera_uniform,
            scene_gpu: &self.scene_gpu,
            shadows: &self.shadows,
            shadow_layers: &layers,
            lights: &self.direct.lights,
            sky_lights: self.sky_lights.len(),
        };
        let (gi, ctx) = (&mut self.gi, &self.ctx);
        let name = gi.name().to_string();
        self.timer
            .scoped(&name, |timer| gi.update(ctx, &gi_frame, timer))?;
        self.compose.render(&mut self.timer, w, h);
        self.last_view = Some(view);
        Ok(())
    }

    /// The camera matrices of the last frame rendered.
    pub fn last_view(&self) -> Option<&CameraView> {
        self.last_view.as_ref()
    }

    /// Reads the linear HDR output of the last frame.
    pub fn read_hdr(&self) -> Result<HdrImage> {
        let bytes = read_texture(&self.ctx, &self.compose.hdr, 0)?;
        let floats: Vec<f32> = bytes
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        Ok(HdrImage {
            width: self.settings.width,
            height: self.settings.height,
            pixels: floats
                .chunks_exact(4)
                .map(|p| Vec3::new(p[0], p[1], p[2]))
                .collect(),
        })
    }

    /// Reads the tone-mapped sRGB display image of the last frame as RGB8.
    pub fn read_display(&self) -> Result<Vec<u8>> {
        let bytes = read_texture(&self.ctx, &self.compose.ldr, 0)?;
        Ok(bytes
            .chunks_exact(4)
            .flat_map(|p| [p[0], p[1], p[2]])
            .collect())
    }

    /// Reads the direct-light radiance of the last frame.
    pub fn read_direct(&self) -> Result<HdrImage> {
        Ok(self.half_image(&self.direct.output)?.0)
    }

    /// Reads the G-buffer of the last frame.
    pub fn read_gbuffer(&self) -> Result<GBufferImages> {
        let depth_bytes = read_texture(&self.ctx, &self.gbuffer.depth, 0)?;
        Ok(GBufferImages {
            albedo: self.half_image(&self.gbuffer.albedo)?.0.pixels,
            normal: self.half_image(&self.gbuffer.normal)?.0.pixels,
            emission: self.half_image(&self.gbuffer.emission)?.0.pixels,
            depth: depth_bytes
                .chunks_exact(4)
                .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
                .collect(),
        })
    }

    fn half_image(&self, texture: &wgpu::Texture) -> Result<(HdrImage, Vec<f32>)> {
        let bytes = read_texture(&self.ctx, texture, 0)?;
        let values: Vec<f32> = bytes
            .chunks_exact(2)
            .map(|c| f16_to_f32(u16::from_le_bytes([c[0], c[1]])))
            .collect();
        let pixels = values
            .chunks_exact(4)
            .map(|p| Vec3::new(p[0], p[1], p[2]))
            .collect();
        let alpha = values.chunks_exact(4).map(|p| p[3]).collect();
        Ok((
            HdrImage {
                width: texture.width(),
                height: texture.height(),
                pixels,
            },
            alpha,
        ))
    }
}
