//! The scene on the GPU with its lights: geometry upload, the lights as the shaders read them
//! (the scene's own, then the directional lights standing in for the sky), octolux's shadow
//! maps of them, and the sky's parameters. Built once per scene structure; updated per frame.

use crate::frame::sky::SkyGpu;
use crate::frame::{
    shadow, shadow_layer_count, sky_regions_of, GpuLight, LayerView, SceneGpu, ShadowMaps,
};
use crate::gpu::{GpuContext, PassTimer};
use crate::scene::{CameraView, Light, LightKind, Scene, SceneFrame};
use crate::{Error, Result};
use glam::{Vec3, Vec4};

/// Ledger owner of the lights buffer.
pub(crate) const OWNER: &str = "lights";

/// See the module docs.
pub(crate) struct LitScene {
    pub scene_gpu: SceneGpu,
    pub shadows: ShadowMaps,
    pub sky: SkyGpu,
    /// The lights as `frame/lights.wgsl` reads them (`array<Light>`).
    pub lights: wgpu::Buffer,
    /// Directional lights standing in for the sky, appended to each frame's lights.
    pub sky_lights: Vec<Light>,
    /// Per sky light, the tangent of its angular radius (how soft its shadows are).
    sky_spread: Vec<f32>,
    /// Soft shadows for the sky lights (octolux's own direct light; see `RenderSettings`).
    pub soft_sky_shadows: bool,
    frame: Option<SceneFrame>,
    layers: Vec<LayerView>,
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

impl LitScene {
    pub fn new(ctx: &GpuContext, scene: &Scene, shadow_map_size: u32) -> Result<LitScene> {
        let (sky_lights, sky_spread): (Vec<Light>, Vec<f32>) =
            sky_regions_of(scene).into_iter().unzip();
        check_shadow_layers(ctx, &scene.lights, sky_lights.len())?;
        let mut all = scene.lights.clone();
        all.extend(sky_lights.iter().cloned());
        let scene_gpu = SceneGpu::new(ctx, scene, 1 + shadow_layer_count(&all))?;
        let shadows = ShadowMaps::new(ctx, &scene_gpu, &all, sky_lights.len(), shadow_map_size);
        let sky = SkyGpu::new(ctx, scene.sky.as_ref());
        let lights = ctx.create_buffer_init(
            OWNER,
            "lights",
            &vec![0u8; all.len().max(1) * std::mem::size_of::<GpuLight>()],
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        );
        Ok(LitScene {
            scene_gpu,
            shadows,
            sky,
            lights,
            sky_lights,
            sky_spread,
            soft_sky_shadows: true,
            frame: None,
            layers: Vec::new(),
        })
    }

    /// Lights of the prepared frame, the sky's included.
    pub fn light_count(&self) -> usize {
        self.frame.as_ref().map_or(0, |f| f.lights.len())
    }

    /// The prepared frame (the sky's lights appended to its lights).
    pub fn frame(&self) -> Option<&SceneFrame> {
        self.frame.as_ref()
    }

    /// Per shadow layer of the prepared frame: view-projection and texel footprint.
    pub fn layers(&self) -> &[LayerView] {
        &self.layers
    }

    /// Uploads `frame` (object transforms, lights and their shadow views fitted to the scene)
    /// and the camera's view for rasterising.
    pub fn upload(
        &mut self,
        queue: &wgpu::Queue,
        scene: &Scene,
        mut frame: SceneFrame,
        view: &CameraView,
    ) {
        let first_sky = frame.lights.len();
        frame.lights.extend(self.sky_lights.iter().cloned());
        let layers = self
            .shadows
            .layer_views(&frame.lights, scene.bounds_at(frame.time));
        self.scene_gpu
            .update_objects(queue, &frame.object_transforms);
        let mut views = vec![(view.view_proj, view.position.extend(1.0))];
        views.extend(layers.iter().map(|l| (l.raster_view_proj, Vec4::ZERO)));
        self.scene_gpu.update_views(queue, &views);
        let gpu_lights: Vec<GpuLight> = frame
            .lights
            .iter()
            .enumerate()
            .map(|(i, light)| self.gpu_light(i, light, first_sky, &layers))
            .collect();
        if !gpu_lights.is_empty() {
            queue.write_buffer(&self.lights, 0, bytemuck::cast_slice(&gpu_lights));
        }
        self.shadows.upload_matrices(queue, &layers);
        self.frame = Some(frame);
        self.layers = layers;
    }

    fn gpu_light(
        &self,
        i: usize,
        light: &Light,
        first_sky: usize,
        layers: &[LayerView],
    ) -> GpuLight {
        let slot = self.shadows.slots.get(i);
        let first = slot.and_then(|s| layers.get(s.first_layer as usize));
        let shadow = shadow::shadow_params(slot, first);
        let mut gpu = GpuLight {
            direction: light.direction.normalize_or(Vec3::NEG_Y).to_array(),
            shadow_view: shadow.view,
            shadow_texel: shadow.texel,
            shadow_orthographic: shadow.orthographic,
            sky_layer_plus_one: shadow.sky_layer_plus_one,
            ..GpuLight::unshadowed(light)
        };
        // A sky light: its soft shadows' spread, the shadow view's depth range and the largest
        // filter radius in texels (lights.wgsl's `sky_visibility`).
        if let Some(k) = i.checked_sub(first_sky) {
            gpu.sky_spread = match self.soft_sky_shadows {
                true => self.sky_spread.get(k).copied().unwrap_or(0.0),
                false => 0.0,
            };
            gpu.sky_depth_range = first.map_or(0.0, |v| v.depth_range);
            gpu.sky_margin = shadow::sky_tile_margin(self.shadows.size / shadow::SKY_TILES)
                .saturating_sub(2) as f32;
        }
        gpu
    }

    /// Draws the shadow maps of the prepared frame: the layers whose light or objects moved
    /// since they were last drawn.
    pub fn render_shadows(&mut self, timer: &mut PassTimer) -> Result<()> {
        self.shadows.render(timer, &self.scene_gpu)
    }
}
