//! Shadow maps: one depth layer per spot or directional light, six (a cube, one layer per
//! face) per point light, all in one `Depth32Float` array so the lighting shader indexes them
//! uniformly. Directional maps are orthographic and fitted to the scene bounds; spot maps cover
//! the outer cone; point faces are 90-degree frusta widened slightly so filtering never reads
//! past a face edge.
//!
//! The directional lights that stand in for the sky (`frame/sky.rs`) share layers: each gets
//! a tile of a quarter of the side (16 per layer), drawn through a viewport, so dozens of sky
//! lights cost a few layers. Their lookup matrices map into the tile.

use super::scene_gpu::{raster_pipeline, SceneGpu};
use crate::gpu::pass::SLOT;
use crate::gpu::shader::library_shader;
use crate::gpu::{GpuContext, PassTimer};
use crate::scene::{Light, LightKind};
use glam::{Mat4, Vec3};

const OWNER: &str = "shadow-maps";

/// Per-light placement in the shadow array.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ShadowSlot {
    /// Index of the light's first view (its matrix; a point light has six).
    pub first_layer: u32,
    /// For a sky light: the texture layer and the tile in it.
    pub tile: Option<(u32, u32)>,
}

/// View-projection and texel footprint of one shadow view (a layer, or a sky light's tile).
#[derive(Clone, Copy, Debug)]
pub struct LayerView {
    /// World to the clip space that shadow lookups use: for a tile, into the tile.
    pub view_proj: Mat4,
    /// World to clip for drawing the view (through its viewport, for a tile).
    pub raster_view_proj: Mat4,
    /// World size of a texel per metre of distance (perspective) or absolute (orthographic).
    pub texel: f32,
    /// Full width of the frustum at unit distance (perspective) or in metres (orthographic).
    pub extent: f32,
    /// Orthographic (directional light) or perspective.
    pub orthographic: bool,
    /// Texture layer of a sky light's tile (None: the layer with the view's own index).
    pub sky_layer: Option<u32>,
    /// Orthographic views: world depth between the near and far planes (0 for perspective).
    pub depth_range: f32,
}

/// Texels kept free around the scene in a sky tile, at most: soft-shadow filters reach this
/// far without reading the neighbouring tile.
const SKY_TILE_MARGIN: u32 = 32;

/// The margin of a sky tile of `side` texels.
pub(crate) fn sky_tile_margin(side: u32) -> u32 {
    SKY_TILE_MARGIN.min(side / 8)
}

/// Tiles per side of a sky layer.
pub(crate) const SKY_TILES: u32 = 4;

/// The shadow-map array and its rasterisation pipelines (perspective views biased, orthographic
/// views not).
pub struct ShadowMaps {
    pub(crate) slots: Vec<ShadowSlot>,
    /// Views (matrices): one per spot, directional or sky light, six per point light.
    pub(crate) view_count: u32,
    /// Texture layers: the punctual lights' views, then the sky tiles' layers.
    pub(crate) layer_count: u32,
    /// Views that own a texture layer (the punctual lights' views come first).
    punctual_views: u32,
    pub(crate) size: u32,
    texture: wgpu::Texture,
    pub(crate) array_view: wgpu::TextureView,
    layer_views: Vec<wgpu::TextureView>,
    /// Per view, the lookup matrix (`mat4x4<f32>`, view order), uploaded every frame.
    matrices: wgpu::Buffer,
    perspective_pipeline: wgpu::RenderPipeline,
    orthographic_pipeline: wgpu::RenderPipeline,
    /// Per texture layer, whether its views are orthographic (drawn without a depth bias).
    orthographic_layers: Vec<bool>,
    pub(crate) sampler: wgpu::Sampler,
    /// Per texture layer, what it showed when last drawn ([`ShadowMaps::layer_content`]): a
    /// layer whose lights and objects hold still is not drawn again.
    drawn: Vec<Vec<u8>>,
}

/// What a compute pass binds to look up shadow maps with `lights.wgsl`: the views' lookup
/// matrices (`shadow_matrices`: one `mat4x4<f32>` per view, in view order) and the shadow-map
/// array (`shadow_maps`). The renderer's is [`ShadowMaps::lookup`]; [`ShadowLookupBuffers`]
/// makes one for callers without a renderer.
#[derive(Clone, Copy)]
pub struct ShadowLookup<'a> {
    /// The lookup matrices (a storage buffer).
    pub matrices: &'a wgpu::Buffer,
    /// The shadow-map array as a `texture_depth_2d_array`.
    pub view: &'a wgpu::TextureView,
    /// The comparison sampler of the percentage-closer filter.
    pub sampler: &'a wgpu::Sampler,
}

/// A [`ShadowLookup`] that owns its matrices, for passes run outside the renderer (tests and
/// tools that render shadow maps themselves).
pub struct ShadowLookupBuffers {
    /// The lookup matrices.
    pub matrices: wgpu::Buffer,
    /// The array view of the shadow-map texture.
    pub view: wgpu::TextureView,
    /// The comparison sampler.
    pub sampler: wgpu::Sampler,
}

impl ShadowLookupBuffers {
    /// Uploads the matrices of `shadow_layers` (under `owner`) and views `shadow_array` as an
    /// array.
    pub fn new(
        ctx: &GpuContext,
        owner: &str,
        shadow_array: &wgpu::Texture,
        shadow_layers: &[LayerView],
    ) -> ShadowLookupBuffers {
        let matrices = ctx.create_buffer_init(
            owner,
            "shadow lookup matrices",
            bytemuck::cast_slice(&lookup_matrices(shadow_layers)),
            wgpu::BufferUsages::STORAGE,
        );
        let view = shadow_array.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::D2Array),
            ..Default::default()
        });
        ShadowLookupBuffers {
            matrices,
            view,
            sampler: comparison_sampler(ctx),
        }
    }

    /// The lookup these buffers make.
    pub fn lookup(&self) -> ShadowLookup<'_> {
        ShadowLookup {
            matrices: &self.matrices,
            view: &self.view,
            sampler: &self.sampler,
        }
    }
}

/// The bilinear depth-comparison sampler of the shadow lookups' percentage-closer filter.
fn comparison_sampler(ctx: &GpuContext) -> wgpu::Sampler {
    ctx.device.create_sampler(&wgpu::SamplerDescriptor {
        label: Some("shadow compare"),
        mag_filter: wgpu::FilterMode::Linear,
        min_filter: wgpu::FilterMode::Linear,
        compare: Some(wgpu::CompareFunction::LessEqual),
        ..Default::default()
    })
}

/// The lookup matrices of `layers` as `lights.wgsl` reads them (one identity matrix when there
/// is no layer: a binding must not be empty).
fn lookup_matrices(layers: &[LayerView]) -> Vec<[f32; 16]> {
    let mut matrices: Vec<[f32; 16]> = layers.iter().map(|l| l.view_proj.to_cols_array()).collect();
    if matrices.is_empty() {
        matrices.push(Mat4::IDENTITY.to_cols_array());
    }
    matrices
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
    /// Shadow maps for `lights`, whose last `sky_lights` are sky lights (directional).
    pub(crate) fn new(
        ctx: &GpuContext,
        scene_gpu: &SceneGpu,
        lights: &[Light],
        sky_lights: usize,
        size: u32,
    ) -> ShadowMaps {
        let mut slots = Vec::with_capacity(lights.len());
        let punctual = lights.len() - sky_lights.min(lights.len());
        let mut view_count = 0;
        for light in &lights[..punctual] {
            slots.push(ShadowSlot {
                first_layer: view_count,
                tile: None,
            });
            view_count += if light.kind == LightKind::Point { 6 } else { 1 };
        }
        let punctual_views = view_count;
        let per_layer = SKY_TILES * SKY_TILES;
        for k in 0..(lights.len() - punctual) as u32 {
            slots.push(ShadowSlot {
                first_layer: view_count,
                tile: Some((punctual_views + k / per_layer, k % per_layer)),
            });
            view_count += 1;
        }
        let layer_count = punctual_views + (view_count - punctual_views).div_ceil(per_layer);
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
        let module = ctx.shader("shadow", &library_shader("frame/gbuffer", &[]));
        let layout = scene_gpu.layouts.pipeline_layout(&ctx.device);
        // Perspective views (point and spot lights) draw with a slope-scaled bias against acne
        // on surfaces at grazing angles to the light. Orthographic views (directional and sky
        // lights) draw without one: their lookups compare against the receiver's plane, which
        // needs none, and the bias pushed a wall seen nearly edge-on behind the surface that
        // meets it, so the light it blocks came through along the inner edge (`lights.wgsl`).
        let biased = wgpu::DepthBiasState {
            constant: 2,
            slope_scale: 1.5,
            clamp: 0.0,
        };
        let pipeline = |label, bias| {
            raster_pipeline(&ctx.device, label, &layout, &module, "fs_shadow", &[], bias)
        };
        let perspective_pipeline = pipeline("shadow (perspective)", biased);
        let orthographic_pipeline =
            pipeline("shadow (orthographic)", wgpu::DepthBiasState::default());
        // A punctual light's layers are its views; the sky layers hold directional tiles.
        let orthographic_layers = (0..layer_count)
            .map(|layer| {
                layer >= punctual_views
                    || lights[..punctual].iter().zip(&slots).any(|(light, slot)| {
                        slot.first_layer == layer && light.kind == LightKind::Directional
                    })
            })
            .collect();
        let sampler = comparison_sampler(ctx);
        let matrices = ctx.create_buffer_init(
            OWNER,
            "shadow matrices",
            &vec![0u8; view_count.max(1) as usize * 64],
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        );
        ShadowMaps {
            slots,
            view_count,
            layer_count,
            punctual_views,
            size,
            texture,
            array_view,
            layer_views,
            matrices,
            perspective_pipeline,
            orthographic_pipeline,
            orthographic_layers,
            sampler,
            drawn: Vec::new(),
        }
    }

    /// Uploads this frame's lookup matrices (from [`ShadowMaps::layer_views`], in view order).
    pub(crate) fn upload_matrices(&self, queue: &wgpu::Queue, layers: &[LayerView]) {
        if !layers.is_empty() {
            queue.write_buffer(
                &self.matrices,
                0,
                bytemuck::cast_slice(&lookup_matrices(layers)),
            );
        }
    }

    /// The shadow lookup compute passes bind: this frame's matrices and the array view.
    pub fn lookup(&self) -> ShadowLookup<'_> {
        ShadowLookup {
            matrices: &self.matrices,
            view: &self.array_view,
            sampler: &self.sampler,
        }
    }

    /// The depth array (one layer per spot/directional light, six per point light, then the
    /// sky lights' tiled layers).
    pub fn texture(&self) -> &wgpu::Texture {
        &self.texture
    }

    /// Views for the lights of one frame (the lights given to [`ShadowMaps::new`], in order),
    /// fitted to the scene bounds.
    pub(crate) fn layer_views(&self, lights: &[Light], bounds: (Vec3, Vec3)) -> Vec<LayerView> {
        let (lo, hi) = bounds;
        let centre = (lo + hi) * 0.5;
        let radius = ((hi - lo).length() * 0.5).max(1e-3);
        let mut views = Vec::with_capacity(self.view_count as usize);
        let size = self.size as f32;
        let plain = |view_proj: Mat4, texel: f32, extent: f32, orthographic: bool| LayerView {
            view_proj,
            raster_view_proj: view_proj,
            texel,
            extent,
            orthographic,
            sky_layer: None,
            depth_range: if orthographic { 3.0 * radius } else { 0.0 },
        };
        for (light, slot) in lights.iter().zip(&self.slots) {
            match light.kind {
                LightKind::Directional => {
                    let d = light.direction.normalize_or(Vec3::NEG_Y);
                    // A tile keeps the scene a margin from its edges, so filtering never reads
                    // the neighbouring tile.
                    let (side, r) = match slot.tile {
                        Some(_) => {
                            let side = self.size / SKY_TILES;
                            let margin = sky_tile_margin(side);
                            (
                                side as f32,
                                radius * side as f32 / (side - 2 * margin) as f32,
                            )
                        }
                        None => (size, radius),
                    };
                    let eye = centre - d * radius * 2.0;
                    let view = Mat4::look_at_rh(eye, centre, any_perpendicular(d));
                    let proj = Mat4::orthographic_rh(-r, r, -r, r, radius * 0.5, radius * 3.5);
                    let mut v = plain(proj * view, 2.0 * r / side, 2.0 * r, true);
                    if let Some((layer, tile)) = slot.tile {
                        v.view_proj = tile_matrix(tile) * v.raster_view_proj;
                        v.sky_layer = Some(layer);
                    }
                    views.push(v);
                }
                LightKind::Spot { outer_angle, .. } => {
                    let d = light.direction.normalize_or(Vec3::NEG_Y);
                    let (near, far) = near_far(light.position, centre, radius);
                    let fov = (2.0 * outer_angle + 4f32.to_radians()).min(170f32.to_radians());
                    let view =
                        Mat4::look_at_rh(light.position, light.position + d, any_perpendicular(d));
                    let proj = Mat4::perspective_rh(fov, 1.0, near, far);
                    let extent = 2.0 * (fov * 0.5).tan();
                    views.push(plain(proj * view, extent / size, extent, false));
                }
                LightKind::Point => {
                    let (near, far) = near_far(light.position, centre, radius);
                    // Widen each face by a few texels so the 4x4 filter footprint stays inside.
                    let half = (1.0 + 6.0 / size).atan();
                    for (dir, up) in CUBE_FACES {
                        let view = Mat4::look_at_rh(light.position, light.position + dir, up);
                        let proj = Mat4::perspective_rh(2.0 * half, 1.0, near, far);
                        let extent = 2.0 * half.tan();
                        views.push(plain(proj * view, extent / size, extent, false));
                    }
                }
            }
        }
        views
    }

    /// What texture layer `layer` shows: its view's content, or a sky layer's tiles' views'.
    fn layer_content(&self, scene_gpu: &SceneGpu, layer: u32) -> Vec<u8> {
        if layer < self.punctual_views {
            return scene_gpu.view_content(layer as usize + 1).into_owned();
        }
        let tiles = self.slots.iter().filter_map(|slot| match slot.tile {
            Some((tile_layer, _)) if tile_layer == layer => Some(slot.first_layer),
            _ => None,
        });
        tiles
            .flat_map(|view| scene_gpu.view_content(view as usize + 1).into_owned())
            .collect()
    }

    /// Pixel rectangle (x, y, side) of sky tile `tile` in its layer.
    fn tile_rect(&self, tile: u32) -> (f32, f32, f32) {
        let side = (self.size / SKY_TILES) as f32;
        let (i, j) = (tile % SKY_TILES, tile / SKY_TILES);
        (i as f32 * side, j as f32 * side, side)
    }

    /// Renders the layers whose content changed since they were last drawn: a punctual light's
    /// layer when its view or an object in it moved, a sky layer when one of its tiles' views
    /// did ([`SceneGpu::view_content`]). View uniforms 1.. must hold the views' raster
    /// matrices. Counts layers and triangles drawn ([`SHADOW_WORK`]); a frame that draws none
    /// still has the pass, empty.
    pub(crate) fn render(
        &mut self,
        timer: &mut PassTimer,
        scene_gpu: &SceneGpu,
    ) -> crate::Result<()> {
        if self.layer_count == 0 {
            return Ok(());
        }
        let shown: Vec<Vec<u8>> = (0..self.layer_count)
            .map(|layer| self.layer_content(scene_gpu, layer))
            .collect();
        let stale: Vec<u32> = (0..self.layer_count)
            .filter(|&l| self.drawn.get(l as usize) != shown.get(l as usize))
            .collect();
        let mut triangles = 0;
        timer.pass("shadow maps", |encoder, stamps| {
            if stale.is_empty() {
                // Nothing to draw: an empty pass keeps the pass (and its time, about 0) in
                // every frame's timings.
                encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("shadow maps (none stale)"),
                    timestamp_writes: stamps.compute(),
                });
                return;
            }
            let n = stale.len();
            for (k, &layer) in stale.iter().enumerate() {
                let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some("shadow layer"),
                    color_attachments: &[],
                    depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                        view: &self.layer_views[layer as usize],
                        depth_ops: Some(wgpu::Operations {
                            load: wgpu::LoadOp::Clear(1.0),
                            store: wgpu::StoreOp::Store,
                        }),
                        stencil_ops: None,
                    }),
                    timestamp_writes: stamps.render_part(k == 0, k + 1 == n),
                    occlusion_query_set: None,
                    multiview_mask: None,
                });
                pass.set_pipeline(if self.orthographic_layers[layer as usize] {
                    &self.orthographic_pipeline
                } else {
                    &self.perspective_pipeline
                });
                if layer < self.punctual_views {
                    triangles += draw_view(&mut pass, scene_gpu, layer);
                    continue;
                }
                for slot in &self.slots {
                    if let Some((tile_layer, tile)) = slot.tile {
                        if tile_layer == layer {
                            let (x, y, side) = self.tile_rect(tile);
                            pass.set_viewport(x, y, side, side, 0.0, 1.0);
                            triangles += draw_view(&mut pass, scene_gpu, slot.first_layer);
                        }
                    }
                }
            }
        });
        self.drawn = shown;
        let ctx = timer.context();
        crate::gpu::work::add(ctx, "shadow maps", SHADOW_WORK, 0, stale.len() as u64)?;
        crate::gpu::work::add(ctx, "shadow maps", SHADOW_WORK, 1, triangles)
    }
}

/// What the shadow-map pass counts: texture layers drawn, triangles drawn into them (those of
/// clusters in each view, `frame/culling.rs`).
pub const SHADOW_WORK: &[&str] = &["layers", "triangles drawn"];

/// Draws the scene through view `view` (uniform slot `view + 1`); returns the triangles drawn.
fn draw_view<'a>(pass: &mut wgpu::RenderPass<'a>, scene_gpu: &'a SceneGpu, view: u32) -> u64 {
    let offset = ((view as u64 + 1) * SLOT) as u32;
    pass.set_bind_group(0, &scene_gpu.view_group, &[offset]);
    scene_gpu.draw(pass, view as usize + 1)
}

/// Clip-space map from the whole [-1, 1]^2 square into sky tile `tile` (column-major tiles of
/// a [`SKY_TILES`]^2 grid, row 0 at the top where texture v = 0).
fn tile_matrix(tile: u32) -> Mat4 {
    let n = SKY_TILES as f32;
    let (i, j) = ((tile % SKY_TILES) as f32, (tile / SKY_TILES) as f32);
    Mat4::from_translation(Vec3::new(
        (2.0 * i + 1.0) / n - 1.0,
        1.0 - (2.0 * j + 1.0) / n,
        0.0,
    )) * Mat4::from_scale(Vec3::new(1.0 / n, 1.0 / n, 1.0))
}

/// Near and far planes for a perspective shadow frustum at `eye` enclosing the bounding sphere.
/// The near plane is 1/1000 of the far one, but never beyond 1 cm: depth precision at a
/// distance d is about d^2 / near, whatever the far plane, so geometry far from the light (one
/// triangle a kilometre away) must not push the near plane past the surfaces around it.
fn near_far(eye: Vec3, centre: Vec3, radius: f32) -> (f32, f32) {
    let far = (eye - centre).length() + radius;
    ((far * 1e-3).clamp(1e-3, 1e-2), far * 1.01)
}

/// The light's shadow parameters as the lighting shader wants them (see `lights.wgsl`): first
/// view, texel size, orthographic flag, and 1 + the texture layer for a sky light (else 0).
pub(crate) fn shadow_params(slot: Option<&ShadowSlot>, first: Option<&LayerView>) -> ShadowParams {
    match (slot, first) {
        (Some(s), Some(v)) => ShadowParams {
            view: s.first_layer as i32,
            texel: v.texel,
            orthographic: v.orthographic as u32,
            sky_layer_plus_one: v.sky_layer.map_or(0, |l| l + 1),
        },
        _ => ShadowParams {
            view: -1,
            ..Default::default()
        },
    }
}

/// A light's shadow lookup as [`crate::frame::GpuLight`] holds it (its `shadow_*` and
/// `sky_layer_plus_one` fields).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct ShadowParams {
    /// First shadow view, -1 for none.
    pub view: i32,
    /// World size of a texel (per metre for perspective views).
    pub texel: f32,
    /// 1 for orthographic views.
    pub orthographic: u32,
    /// 1 + the layer holding a sky light's tile, 0 for other lights.
    pub sky_layer_plus_one: u32,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A point drawn through a tile's viewport lands on the texel its lookup matrix reads:
    /// the viewport maps clip x, y in [-1, 1] to the tile's pixels (y down), the lookup maps
    /// them through `tile_matrix` and the shader's uv = (x/2 + 1/2, 1/2 - y/2) x layer side.
    #[test]
    fn tile_lookup_matches_the_viewport() {
        let size = 1024.0;
        let side = size / SKY_TILES as f32;
        for tile in 0..SKY_TILES * SKY_TILES {
            let (i, j) = ((tile % SKY_TILES) as f32, (tile / SKY_TILES) as f32);
            for (x, y) in [(-1.0, -1.0), (1.0, 1.0), (0.3, -0.7), (0.0, 0.0)] {
                let viewport = glam::Vec2::new(
                    i * side + (x + 1.0) * 0.5 * side,
                    j * side + (1.0 - y) * 0.5 * side,
                );
                let clip = tile_matrix(tile) * glam::Vec4::new(x, y, 0.5, 1.0);
                let uv = glam::Vec2::new(clip.x * 0.5 + 0.5, 0.5 - clip.y * 0.5) * size;
                assert!(
                    (uv - viewport).length() < 1e-3,
                    "tile {tile}: {uv} vs {viewport}"
                );
            }
        }
    }
}
