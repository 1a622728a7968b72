//! Reflective shadow maps (one per shadow layer: spot and directional lights have one, point
//! lights six cube faces). Each texel stores world position, light-facing normal and what the
//! injection needs for the VPL's physical flux and the surfel's area (see `rsm.wgsl`).

use super::shadow::LayerView;
use crate::frame::scene_gpu::{raster_pipeline, SceneGpu};
use crate::gpu::pass::SLOT;
use crate::gpu::shader::library_shader;
use crate::gpu::{GpuContext, PassTimer};
use crate::scene::{Light, LightKind};
use bytemuck::{Pod, Zeroable};
use glam::Vec3;

/// Format of the position (xyz, texel measure) target.
pub const POSITION_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;
/// Format of the normal (xyz, area / measure) and albedo x intensity targets; the three
/// targets fit the 32 bytes per sample every adapter allows.
pub const HALF_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;

/// `RsmLayer` of `rsm.wgsl`: one RSM layer's light and view.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct RsmLayer {
    /// Light position (point and spot lights).
    pub position: [f32; 3],
    /// [`crate::frame::LIGHT_POINT`], `LIGHT_SPOT` or `LIGHT_DIRECTIONAL`.
    pub kind: u32,
    /// Unit axis of the layer: the spot axis, the cube face's axis, the sun's direction of
    /// travel.
    pub axis: [f32; 3],
    /// Perspective layers: tangent of the half field of view.
    pub tan_half_fov: f32,
    /// Radiant intensity, W/sr, or irradiance, W/m^2 (directional lights).
    pub radiant: [f32; 3],
    /// The cube face of a point light's layer (+x, -x, +y, -y, +z, -z), -1 for other lights.
    pub face: i32,
    /// Cosine of a spot cone's inner half-angle (1 for other lights).
    pub cos_inner: f32,
    /// Cosine of a spot cone's outer half-angle (-1 for other lights).
    pub cos_outer: f32,
    /// RSM side in texels.
    pub side: u32,
    /// The shadow view the layer is drawn through.
    pub view: u32,
    /// Orthographic layers: a texel's area across the beam, m^2.
    pub texel_area: f32,
    /// Padding to the WGSL struct's 16-byte alignment.
    pub _pad: [u32; 3],
}

impl RsmLayer {
    /// The layer drawn `side` texels on a side (into the corner of larger targets): an
    /// orthographic layer's texels cover the same beam, so each is larger.
    pub fn at_side(self, side: u32) -> RsmLayer {
        let side = side.max(1);
        let scale = self.side as f32 / side as f32;
        RsmLayer {
            side,
            texel_area: self.texel_area * scale * scale,
            ..self
        }
    }
}

/// What a layer's RSM shows, byte for byte, whatever its side: the layer's light parameters
/// (position, direction, power, cone) and what its shadow view shows
/// ([`SceneGpu::view_content`]: the view's matrix, the objects in it and their transforms).
pub fn content_key(scene_gpu: &SceneGpu, layers: &[RsmLayer], i: usize) -> Vec<u8> {
    let view = RsmPass::view_of(layers, i) + 1;
    let layer = layers.get(i).copied().unwrap_or_default();
    let unsized_layer = RsmLayer {
        side: 0,
        texel_area: 0.0,
        ..layer
    };
    let mut key: Vec<u8> = bytemuck::bytes_of(&unsized_layer).to_vec();
    key.extend_from_slice(&scene_gpu.view_content(view));
    key
}

/// What each RSM layer showed in the last frame ([`content_key`]), to draw the layers whose
/// content moved at half the side: the frames that must draw a layer anew draw a quarter of
/// its texels, and a layer that holds still keeps the whole side (drawn once more at the
/// whole side when it comes to rest).
#[derive(Default)]
pub(crate) struct MovingLayers {
    keys: Vec<Vec<u8>>,
}

impl MovingLayers {
    /// `layers` with those whose content changed since the last call at half of `size` (when
    /// `enabled`); remembers this frame's contents either way.
    pub(crate) fn halve(
        &mut self,
        scene_gpu: &SceneGpu,
        layers: Vec<RsmLayer>,
        size: u32,
        enabled: bool,
    ) -> Vec<RsmLayer> {
        let keys: Vec<Vec<u8>> = (0..layers.len())
            .map(|i| content_key(scene_gpu, &layers, i))
            .collect();
        let last = std::mem::replace(&mut self.keys, keys);
        if !enabled {
            return layers;
        }
        layers
            .into_iter()
            .enumerate()
            .map(|(i, l)| match last.get(i) {
                Some(key) if *key != self.keys[i] => l.at_side(size / 2),
                _ => l,
            })
            .collect()
    }
}

/// RSM layers [`half_layer_mask`] can mark.
pub const MAX_HALF_LAYERS: u32 = 256;

/// Per layer of `layers` in targets of side `size`, a bit set where the layer is drawn at half
/// of it (the injection's and the VPL generation's `half_layers`).
pub fn half_layer_mask(layers: &[RsmLayer], size: u32) -> [u32; 8] {
    let mut mask = [0u32; 8];
    for (i, l) in layers.iter().enumerate().take(MAX_HALF_LAYERS as usize) {
        if l.side < size {
            mask[i / 32] |= 1 << (i % 32);
        }
    }
    mask
}

/// Bytes of one [`RsmLayer`] (each in a uniform slot of [`SLOT`] bytes).
const LAYER_BYTES: usize = std::mem::size_of::<RsmLayer>();
const _: () = assert!(LAYER_BYTES <= SLOT as usize);

/// The RSM textures (arrays with one layer per shadow layer).
pub struct RsmTargets {
    /// Side in texels.
    pub size: u32,
    /// Number of layers (0 when the scene has no lights).
    pub layers: u32,
    /// Position + measure.
    pub position: wgpu::Texture,
    /// Normal + area ratio.
    pub normal: wgpu::Texture,
    /// Albedo x intensity.
    pub flux: wgpu::Texture,
    _depth: wgpu::Texture,
    pub(crate) position_array: wgpu::TextureView,
    pub(crate) normal_array: wgpu::TextureView,
    pub(crate) flux_array: wgpu::TextureView,
    /// Per layer: position, normal, flux, depth views.
    layer_views: Vec<[wgpu::TextureView; 4]>,
    uniforms: wgpu::Buffer,
}

impl RsmTargets {
    /// Allocates `layers` RSM layers of `size`^2 texels.
    pub fn new(ctx: &GpuContext, owner: &str, layers: u32, size: u32) -> RsmTargets {
        let make = |label: &str, format| {
            ctx.create_texture(
                owner,
                &wgpu::TextureDescriptor {
                    label: Some(label),
                    size: wgpu::Extent3d {
                        width: size,
                        height: size,
                        depth_or_array_layers: layers.max(1),
                    },
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D2,
                    format,
                    usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                        | wgpu::TextureUsages::TEXTURE_BINDING
                        | wgpu::TextureUsages::COPY_SRC,
                    view_formats: &[],
                },
            )
        };
        let position = make("rsm position", POSITION_FORMAT);
        let normal = make("rsm normal", HALF_FORMAT);
        let flux = make("rsm flux", HALF_FORMAT);
        let depth = make("rsm depth", wgpu::TextureFormat::Depth32Float);
        let array = |t: &wgpu::Texture| {
            t.create_view(&wgpu::TextureViewDescriptor {
                dimension: Some(wgpu::TextureViewDimension::D2Array),
                ..Default::default()
            })
        };
        let layer = |t: &wgpu::Texture, i: u32| {
            t.create_view(&wgpu::TextureViewDescriptor {
                dimension: Some(wgpu::TextureViewDimension::D2),
                base_array_layer: i,
                array_layer_count: Some(1),
                ..Default::default()
            })
        };
        let layer_views = (0..layers)
            .map(|i| {
                [
                    layer(&position, i),
                    layer(&normal, i),
                    layer(&flux, i),
                    layer(&depth, i),
                ]
            })
            .collect();
        RsmTargets {
            size,
            layers,
            position_array: array(&position),
            normal_array: array(&normal),
            flux_array: array(&flux),
            layer_views,
            uniforms: crate::gpu::alloc::uniform(ctx, owner, "rsm layers", layers as u64),
            position,
            normal,
            flux,
            _depth: depth,
        }
    }
}

/// The RSM rasterisation pipeline, and what the targets hold.
pub struct RsmPass {
    pipeline: wgpu::RenderPipeline,
    /// Clears the viewport of a layer drawn at less than the targets' side (`fs_clear`).
    clear: wgpu::RenderPipeline,
    group: wgpu::BindGroup,
    /// Per layer, everything its last rendering depended on (its parameters, its view
    /// matrix, the transforms of the objects in its view), byte for byte: a layer with the
    /// same is not rendered again (a still light keeps its RSM while nothing it sees moves).
    drawn: std::sync::Mutex<Vec<Option<Vec<u8>>>>,
}

impl RsmPass {
    /// Builds the pipeline on the scene's raster layouts plus a per-layer uniform (group 3).
    pub(crate) fn new(ctx: &GpuContext, scene_gpu: &SceneGpu, targets: &RsmTargets) -> RsmPass {
        let device = &ctx.device;
        let layer_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("rsm layer"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: true,
                    min_binding_size: None,
                },
                count: None,
            }],
        });
        let l = &scene_gpu.layouts;
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("rsm"),
            bind_group_layouts: &[
                Some(&l.view),
                Some(&l.material),
                Some(&l.object),
                Some(&layer_layout),
            ],
            immediate_size: 0,
        });
        let module = ctx.shader("rsm", &library_shader("frame/rsm", &[]));
        let target = |format| {
            Some(wgpu::ColorTargetState {
                format,
                blend: None,
                write_mask: wgpu::ColorWrites::ALL,
            })
        };
        let targets_state = [
            target(POSITION_FORMAT),
            target(HALF_FORMAT),
            target(HALF_FORMAT),
        ];
        let pipeline = raster_pipeline(
            device,
            "rsm",
            &layout,
            &module,
            "fs_rsm",
            &targets_state,
            Default::default(),
        );
        let clear = clear_pipeline(device, &module, &targets_state);
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("rsm layer"),
            layout: &layer_layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: &targets.uniforms,
                    offset: 0,
                    size: wgpu::BufferSize::new(std::mem::size_of::<RsmLayer>() as u64),
                }),
            }],
        });
        RsmPass {
            pipeline,
            clear,
            group,
            drawn: std::sync::Mutex::new(Vec::new()),
        }
    }

    /// What a layer's RSM depends on this frame, byte for byte: what it shows
    /// ([`content_key`]) and the side it is drawn at.
    fn layer_inputs(scene_gpu: &SceneGpu, layers: &[RsmLayer], i: usize) -> Vec<u8> {
        let mut key = content_key(scene_gpu, layers, i);
        let layer = layers.get(i).copied().unwrap_or_default();
        key.extend_from_slice(&layer.side.to_le_bytes());
        key.extend_from_slice(&layer.texel_area.to_le_bytes());
        key
    }

    /// The shadow view layer `i` is drawn through.
    fn view_of(layers: &[RsmLayer], i: usize) -> usize {
        layers.get(i).map_or(i, |l| l.view as usize)
    }

    /// Uploads the per-layer light parameters of this frame.
    pub(crate) fn update(&self, ctx: &GpuContext, targets: &RsmTargets, layers: &[RsmLayer]) {
        let mut data = vec![0u8; targets.layers as usize * SLOT as usize];
        for (i, l) in layers.iter().enumerate().take(targets.layers as usize) {
            let start = i * SLOT as usize;
            data[start..start + LAYER_BYTES].copy_from_slice(bytemuck::bytes_of(l));
        }
        if !data.is_empty() {
            ctx.queue.write_buffer(&targets.uniforms, 0, &data);
        }
    }

    /// Rasterises every layer whose inputs changed since it was last drawn through its shadow
    /// view (`layers[i].view`), as the pass `name` (its work counts: [`RSM_WORK`]); no
    /// pass when none did.
    pub(crate) fn record(
        &self,
        ctx: &GpuContext,
        timer: &mut PassTimer,
        scene_gpu: &SceneGpu,
        targets: &RsmTargets,
        layers: &[RsmLayer],
        name: &str,
    ) -> crate::Result<()> {
        if targets.layers == 0 {
            return Ok(());
        }
        // Layers whose inputs are those they were drawn with already hold this frame's RSM.
        let n = targets.layer_views.len();
        let mut inputs: Vec<Vec<u8>> = (0..n)
            .map(|i| Self::layer_inputs(scene_gpu, layers, i))
            .collect();
        let mut drawn = self.drawn.lock().unwrap_or_else(|p| p.into_inner());
        drawn.resize(n, None);
        let stale: Vec<usize> = (0..n)
            .filter(|&i| drawn[i].as_ref() != Some(&inputs[i]))
            .collect();
        if stale.is_empty() {
            return Ok(());
        }
        // Forgotten until this frame's drawing is recorded whole.
        for &i in &stale {
            drawn[i] = None;
        }
        let mut triangles = 0;
        timer.pass(name, |encoder, stamps| {
            for (k, &i) in stale.iter().enumerate() {
                let views = &targets.layer_views[i];
                // A layer smaller than the targets fills their corner (the injection reads
                // that much of it), cleared by a triangle over that corner alone.
                let side = layer_side(layers, i, targets.size);
                let whole = side == targets.size;
                let color = |view| {
                    Some(wgpu::RenderPassColorAttachment {
                        view,
                        depth_slice: None,
                        resolve_target: None,
                        ops: wgpu::Operations {
                            load: if whole {
                                wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT)
                            } else {
                                wgpu::LoadOp::Load
                            },
                            store: wgpu::StoreOp::Store,
                        },
                    })
                };
                let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some("rsm layer"),
                    color_attachments: &[color(&views[0]), color(&views[1]), color(&views[2])],
                    depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                        view: &views[3],
                        depth_ops: Some(wgpu::Operations {
                            load: if whole {
                                wgpu::LoadOp::Clear(1.0)
                            } else {
                                wgpu::LoadOp::Load
                            },
                            store: wgpu::StoreOp::Store,
                        }),
                        stencil_ops: None,
                    }),
                    timestamp_writes: stamps.render_part(k == 0, k + 1 == stale.len()),
                    occlusion_query_set: None,
                    multiview_mask: None,
                });
                pass.set_viewport(0.0, 0.0, side as f32, side as f32, 0.0, 1.0);
                if !whole {
                    pass.set_pipeline(&self.clear);
                    pass.draw(0..3, 0..1);
                }
                pass.set_pipeline(&self.pipeline);
                let view = Self::view_of(layers, i);
                let view_offset = ((view as u64 + 1) * SLOT) as u32;
                pass.set_bind_group(0, &scene_gpu.view_group, &[view_offset]);
                pass.set_bind_group(3, &self.group, &[(i as u64 * SLOT) as u32]);
                triangles += scene_gpu.draw(&mut pass, view + 1);
            }
        });
        let drawn_layers = stale.len() as u64;
        let texels = stale
            .iter()
            .map(|&i| u64::from(layer_side(layers, i, targets.size)).pow(2))
            .sum();
        for (quantity, count) in [drawn_layers, triangles, texels].into_iter().enumerate() {
            crate::gpu::work::add(ctx, name, RSM_WORK, quantity, count)?;
        }
        for i in stale {
            drawn[i] = Some(std::mem::take(&mut inputs[i]));
        }
        Ok(())
    }
}

/// The side in texels of layer `i`: its own, within the targets' `size`.
fn layer_side(layers: &[RsmLayer], i: usize, size: u32) -> u32 {
    layers.get(i).map_or(size, |l| l.side.clamp(1, size))
}

/// What an RSM pass counts: layers rendered (those whose inputs changed), triangles drawn into
/// them (those of clusters in each layer's view, `frame/culling.rs`), texels written (each
/// cleared first: a layer at half the side clears a quarter of its targets' layer).
pub const RSM_WORK: &[&str] = &["layers", "triangles drawn", "texels"];

/// The pipeline of the clearing triangle (`vs_clear`, `fs_clear` in `frame/rsm.wgsl`): every
/// target zero and depth 1 over the viewport, whatever was there.
fn clear_pipeline(
    device: &wgpu::Device,
    module: &wgpu::ShaderModule,
    targets: &[Option<wgpu::ColorTargetState>],
) -> wgpu::RenderPipeline {
    let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("rsm clear"),
        bind_group_layouts: &[],
        immediate_size: 0,
    });
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("rsm clear"),
        layout: Some(&layout),
        vertex: wgpu::VertexState {
            module,
            entry_point: Some("vs_clear"),
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
            module,
            entry_point: Some("fs_clear"),
            compilation_options: Default::default(),
            targets,
        }),
        multiview_mask: None,
        cache: None,
    })
}

/// Cube-face axes in the order of the shadow layers of a point light (+x, -x, +y, -y, +z, -z).
const FACE_AXES: [Vec3; 6] = [
    Vec3::X,
    Vec3::NEG_X,
    Vec3::Y,
    Vec3::NEG_Y,
    Vec3::Z,
    Vec3::NEG_Z,
];

/// Which of `sky` sky lights get an RSM when at most `sky_rsms` may: evenly spread indices
/// (the lights hold about equal shares of the sky, being median-cut regions).
pub fn sky_subset(sky: usize, sky_rsms: u32) -> Vec<usize> {
    let m = sky.min(sky_rsms as usize);
    (0..m).map(|j| (2 * j + 1) * sky / (2 * m)).collect()
}

/// Per channel, the factor that makes the `chosen` sky lights (indices into the whole light
/// list, whose sky part starts at `first_sky`) carry the flux of all of `sky`. A channel none
/// of the chosen carries is lost rather than blown up.
pub fn sky_scale(sky: &[crate::scene::Light], chosen: &[usize], first_sky: usize) -> Vec3 {
    let total: Vec3 = sky.iter().map(|l| l.radiant()).sum();
    let carried: Vec3 = chosen.iter().map(|&i| sky[i - first_sky].radiant()).sum();
    Vec3::select(carried.cmpgt(Vec3::ZERO), total / carried, Vec3::ZERO)
}

/// RSM layers for the scene's own `lights` and `sky_lights` sky lights when at most
/// `sky_rsms` of those get one: every view of the scene's lights, then the chosen sky lights.
pub fn rsm_layer_count(lights: &[crate::scene::Light], sky_lights: usize, sky_rsms: u32) -> u32 {
    crate::frame::shadow_layer_count(lights) + sky_subset(sky_lights, sky_rsms).len() as u32
}

/// Per-layer light parameters for RSMs of side `rsm_size` rendered with the shadow views'
/// matrices: every light's views except the sky's, of which only [`sky_subset`] is drawn,
/// with the flux scaled so that the chosen ones carry the whole sky's (an unbiased choice of
/// an equal-share sample). `view` holds the shadow view each layer is drawn through.
pub fn rsm_layers(
    lights: &[Light],
    sky_lights: usize,
    shadow_layers: &[LayerView],
    rsm_size: u32,
    sky_rsms: u32,
) -> Vec<RsmLayer> {
    let first_sky = lights.len() - sky_lights.min(lights.len());
    let chosen: Vec<usize> = sky_subset(lights.len() - first_sky, sky_rsms)
        .into_iter()
        .map(|k| first_sky + k)
        .collect();
    let sky_scale = sky_scale(&lights[first_sky..], &chosen, first_sky);
    let mut out = Vec::new();
    let mut first = 0usize;
    for (index, light) in lights.iter().enumerate() {
        let views = if light.kind == LightKind::Point { 6 } else { 1 };
        let first_view = first;
        first += views;
        let is_sky = index >= first_sky;
        if is_sky && !chosen.contains(&index) {
            continue;
        }
        let radiant = if is_sky {
            light.radiant() * sky_scale
        } else {
            light.radiant()
        };
        let dir = light.direction.normalize_or(Vec3::NEG_Y);
        let Some(view) = shadow_layers.get(first_view) else {
            break;
        };
        let view_slot = first_view as u32;
        // The frustum's full width at unit distance (perspective) or in metres (orthographic).
        let width = view.extent;
        let (kind, cos_inner, cos_outer) = crate::frame::light_kind_and_cone(light.kind);
        let layer = RsmLayer {
            position: light.position.to_array(),
            kind,
            axis: dir.to_array(),
            radiant: radiant.to_array(),
            face: -1,
            cos_inner,
            cos_outer,
            side: rsm_size,
            view: view_slot,
            ..Default::default()
        };
        match light.kind {
            LightKind::Directional => {
                let side = width / rsm_size as f32;
                out.push(RsmLayer {
                    texel_area: side * side,
                    ..layer
                });
            }
            LightKind::Spot { .. } => out.push(RsmLayer {
                tan_half_fov: width * 0.5,
                ..layer
            }),
            LightKind::Point => {
                for (face, axis) in FACE_AXES.iter().enumerate() {
                    let tan = shadow_layers
                        .get(first_view + face)
                        .map_or(width, |v| v.extent)
                        * 0.5;
                    out.push(RsmLayer {
                        axis: axis.to_array(),
                        tan_half_fov: tan,
                        face: face as i32,
                        view: view_slot + face as u32,
                        ..layer
                    });
                }
            }
        }
    }
    out
}

/// An upper bound of the flux (W, any channel) the RSM layers can reflect: perspective layers
/// see at most the solid angle of their frustum, (2 tan(half fov))^2, orthographic ones the area
/// across the beam, texel area x side^2; albedo is taken as at most 4 (a margin over the
/// physical 1 for unvalidated material factors).
pub fn reflected_flux_bound(layers: &[RsmLayer]) -> f32 {
    layers
        .iter()
        .map(|l| {
            let radiant = l.radiant[0].max(l.radiant[1]).max(l.radiant[2]);
            let side = l.side as f32;
            let measure = if l.kind == crate::frame::LIGHT_DIRECTIONAL {
                l.texel_area * side * side
            } else {
                4.0 * l.tan_half_fov * l.tan_half_fov
            };
            4.0 * radiant.max(0.0) * measure
        })
        .sum()
}

/// One RSM layer read back to the CPU (row-major, `size`^2 texels), as the injection reads it.
#[derive(Clone, Debug)]
pub struct RsmImage {
    /// Side in texels.
    pub size: u32,
    /// World position (xyz) and texel measure (w, 0 where nothing was rasterised).
    pub position: Vec<[f32; 4]>,
    /// Light-facing normal (xyz) and area / measure (w).
    pub normal: Vec<[f32; 4]>,
    /// Albedo x radiant intensity or irradiance (rgb).
    pub flux: Vec<[f32; 4]>,
}

impl RsmImage {
    /// Reads layer `layer` of `targets`.
    pub fn read(ctx: &GpuContext, targets: &RsmTargets, layer: u32) -> crate::Result<RsmImage> {
        let f32s = |bytes: Vec<u8>| -> Vec<[f32; 4]> {
            bytes
                .chunks_exact(16)
                .map(|c| {
                    std::array::from_fn(|k| {
                        f32::from_le_bytes([c[4 * k], c[4 * k + 1], c[4 * k + 2], c[4 * k + 3]])
                    })
                })
                .collect()
        };
        let halves = |bytes: Vec<u8>| -> Vec<[f32; 4]> {
            bytes
                .chunks_exact(8)
                .map(|c| {
                    std::array::from_fn(|k| {
                        crate::gpu::pack::f16_to_f32(u16::from_le_bytes([c[2 * k], c[2 * k + 1]]))
                    })
                })
                .collect()
        };
        Ok(RsmImage {
            size: targets.size,
            position: f32s(crate::gpu::read_texture(ctx, &targets.position, layer)?),
            normal: halves(crate::gpu::read_texture(ctx, &targets.normal, layer)?),
            flux: halves(crate::gpu::read_texture(ctx, &targets.flux, layer)?),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rsm_layer_mirrors_the_wgsl_block() {
        crate::gpu::layout::assert_mirrors_wgsl!(
            RsmLayer,
            "frame/rsm",
            "RsmLayer",
            [
                position,
                kind,
                axis,
                tan_half_fov,
                radiant,
                face,
                cos_inner,
                cos_outer,
                side,
                view,
                texel_area,
                _pad
            ]
        );
    }

    #[test]
    fn sky_subset_spreads_evenly_and_keeps_small_skies_whole() {
        assert_eq!(sky_subset(32, 8), vec![2, 6, 10, 14, 18, 22, 26, 30]);
        assert_eq!(sky_subset(5, 8), vec![0, 1, 2, 3, 4]);
        assert_eq!(sky_subset(0, 8), Vec::<usize>::new());
        assert_eq!(sky_subset(3, 1), vec![1]);
    }

    #[test]
    fn chosen_sky_lights_carry_the_whole_sky() {
        let light = |c: Vec3| crate::scene::Light {
            name: "sky".into(),
            kind: LightKind::Directional,
            color: c,
            intensity: 1.0,
            position: Vec3::ZERO,
            direction: Vec3::NEG_Y,
            animation: None,
        };
        let sky = [
            light(Vec3::new(1.0, 0.0, 2.0)),
            light(Vec3::new(1.0, 0.5, 0.0)),
            light(Vec3::new(2.0, 0.0, 2.0)),
        ];
        // Lights 5 and 7 of a list whose sky starts at 5.
        let scale = sky_scale(&sky, &[5, 7], 5);
        let carried = (sky[0].radiant() + sky[2].radiant()) * scale;
        assert_eq!(carried.x, 4.0);
        assert_eq!(carried.z, 4.0);
        assert_eq!(
            scale.y, 0.0,
            "green is carried by no chosen light: lost, not infinite"
        );
    }
}
