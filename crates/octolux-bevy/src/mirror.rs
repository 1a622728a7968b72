//! The main world's scene as octolux takes it: every frame, the meshes drawn with a
//! `StandardMaterial`, their transforms, and the point, spot and directional lights become one
//! [`SceneSnapshot`], which the render world hands to each camera's [`octolux::embed::GiEngine`].
//!
//! What changes the scene's structure (an entity or asset added, removed or edited, a static
//! entity moved, a light changing kind) bumps [`SceneSnapshot::generation`]: the engines are
//! then rebuilt from the snapshot, as octolux rebuilds for any structural edit. Transforms of
//! movable entities and every light's parameters are per-frame updates.

use crate::units;
use bevy::asset::{AssetEvent, AssetId, Assets};
use bevy::camera::visibility::InheritedVisibility;
use bevy::ecs::prelude::*;
use bevy::image::Image;
use bevy::light::{DirectionalLight, PointLight, SpotLight};
use bevy::log::warn;
use bevy::mesh::skinning::SkinnedMesh;
use bevy::mesh::{Indices, Mesh, Mesh3d, PrimitiveTopology, VertexAttributeValues};
use bevy::pbr::{MeshMaterial3d, StandardMaterial};
use bevy::render::render_resource::TextureFormat;
use bevy::transform::components::GlobalTransform;
use glam::{Mat4, Vec2, Vec3};
use octolux::embed::Motion;
use octolux::scene::{AlphaMode, Light, Material, Texture};
use std::collections::{HashMap, HashSet};
use std::hash::{Hash, Hasher};
use std::sync::Arc;

/// How an entity's mesh moves, for octolux's structures (optional; without it an entity is
/// static until it first moves, and movable from then on).
///
/// Static geometry is baked into the techniques' structures (voxel octrees, probe placement,
/// geometry volumes); moving it rebuilds them. Movable geometry is updated every frame at a
/// per-frame cost.
#[derive(Component, Clone, Copy, Debug, PartialEq, Eq)]
pub enum GiMotion {
    /// Never moves: moving it anyway rebuilds octolux's structures each time.
    Static,
    /// Moves: updated every frame without a rebuild.
    Movable,
}

/// Marks an entity whose mesh or light octolux should not see (it keeps being drawn by Bevy).
#[derive(Component, Clone, Copy, Debug, Default)]
pub struct GiExclude;

/// One placed mesh of the snapshot.
#[derive(Clone, Debug)]
pub(crate) struct SnapshotInstance {
    /// Index into [`SceneSnapshot::meshes`].
    pub mesh: usize,
    /// Object to world.
    pub transform: Mat4,
    /// Whether it moves.
    pub motion: Motion,
}

/// The scene octolux sees, in octolux's types and units.
#[derive(Clone, Debug, Default)]
pub(crate) struct SceneSnapshot {
    /// Changes whenever anything but movable transforms and light parameters changes.
    pub generation: u64,
    /// Base-colour textures.
    pub textures: Vec<Arc<Texture>>,
    /// Materials; `base_color_texture` indexes `textures`.
    pub materials: Vec<Material>,
    /// Meshes, each with its index into `materials`.
    pub meshes: Vec<(Arc<MeshData>, usize)>,
    /// Instances, in entity order.
    pub instances: Vec<SnapshotInstance>,
    /// Lights, in entity order.
    pub lights: Vec<Light>,
}

/// The latest snapshot, shared with the render world.
#[derive(Resource, Clone, Default)]
pub(crate) struct GiScene(pub Arc<SceneSnapshot>);

/// What the mirror keeps between frames.
#[derive(Resource, Default)]
pub(crate) struct MirrorState {
    meshes: HashMap<AssetId<Mesh>, Option<Arc<MeshData>>>,
    materials: HashMap<AssetId<StandardMaterial>, (Material, Option<AssetId<Image>>)>,
    textures: HashMap<AssetId<Image>, Option<Arc<Texture>>>,
    /// Bumped when a cached asset changes.
    asset_epoch: u64,
    /// Each entity's transform the previous frame (to see the first move of an entity without
    /// [`GiMotion`]).
    last_transform: HashMap<Entity, [f32; 16]>,
    promoted: HashSet<Entity>,
    signature: u64,
    generation: u64,
    warned: HashSet<String>,
}

impl MirrorState {
    /// Warns once per `key`.
    fn warn_once(&mut self, key: String, message: impl FnOnce() -> String) {
        if self.warned.insert(key) {
            warn!("octolux GI: {}", message());
        }
    }
}

/// A Bevy mesh's triangles in octolux's form (without a material).
#[derive(Debug)]
pub(crate) struct MeshData {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    uvs: Vec<Vec2>,
    indices: Vec<u32>,
}

impl MeshData {
    /// Octolux's mesh (its material is given when it is added to an engine).
    pub fn to_mesh(&self, name: String) -> octolux::scene::Mesh {
        octolux::scene::Mesh {
            name,
            positions: self.positions.clone(),
            normals: self.normals.clone(),
            uvs: self.uvs.clone(),
            indices: self.indices.clone(),
            material: 0,
        }
    }
}

/// Builds this frame's [`GiScene`] from the world (runs in `PostUpdate`, after transforms and
/// visibility are propagated).
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
pub(crate) fn mirror_scene(
    mut state: ResMut<MirrorState>,
    mut scene: ResMut<GiScene>,
    meshes: Res<Assets<Mesh>>,
    materials: Res<Assets<StandardMaterial>>,
    images: Res<Assets<Image>>,
    mut mesh_events: MessageReader<AssetEvent<Mesh>>,
    mut material_events: MessageReader<AssetEvent<StandardMaterial>>,
    mut image_events: MessageReader<AssetEvent<Image>>,
    drawn: Query<
        (
            Entity,
            &Mesh3d,
            &MeshMaterial3d<StandardMaterial>,
            &GlobalTransform,
            Option<&InheritedVisibility>,
            Option<&GiMotion>,
            Has<SkinnedMesh>,
        ),
        Without<GiExclude>,
    >,
    other_materials: Query<
        (Entity, Option<&Name>),
        (With<Mesh3d>, Without<MeshMaterial3d<StandardMaterial>>),
    >,
    point_lights: Query<
        (
            Entity,
            &PointLight,
            &GlobalTransform,
            Option<&InheritedVisibility>,
        ),
        Without<GiExclude>,
    >,
    spot_lights: Query<
        (
            Entity,
            &SpotLight,
            &GlobalTransform,
            Option<&InheritedVisibility>,
        ),
        Without<GiExclude>,
    >,
    directional_lights: Query<
        (
            Entity,
            &DirectionalLight,
            &GlobalTransform,
            Option<&InheritedVisibility>,
        ),
        Without<GiExclude>,
    >,
) {
    let state = &mut *state;
    forget_changed_assets(
        state,
        &mut mesh_events,
        &mut material_events,
        &mut image_events,
    );

    for (entity, name) in &other_materials {
        let label = name.map_or_else(|| format!("{entity}"), |n| n.to_string());
        state.warn_once(format!("material {entity}"), || {
            format!(
                "entity '{label}' has a mesh without a StandardMaterial: octolux does not see \
                 it (custom materials are not mirrored)"
            )
        });
    }

    let mut snapshot = SceneSnapshot::default();
    let mut signature = std::collections::hash_map::DefaultHasher::new();
    state.asset_epoch.hash(&mut signature);
    let mut mesh_slots: HashMap<(AssetId<Mesh>, AssetId<StandardMaterial>), usize> = HashMap::new();
    let mut material_slots: HashMap<AssetId<StandardMaterial>, usize> = HashMap::new();
    let mut texture_slots: HashMap<AssetId<Image>, usize> = HashMap::new();

    let mut entities: Vec<_> = drawn.iter().collect();
    entities.sort_by_key(|e| e.0);
    let mut seen = HashSet::new();
    for (entity, mesh, material, transform, visibility, motion, skinned) in entities {
        if visibility.is_some_and(|v| !v.get()) {
            continue;
        }
        if skinned {
            state.warn_once(format!("skinned {entity}"), || {
                format!("entity {entity} is a skinned mesh: octolux does not see it")
            });
            continue;
        }
        let Some(data) = mesh_data(state, &meshes, mesh.id(), entity) else {
            continue;
        };
        let Some(material_slot) = material_slot(
            state,
            &mut snapshot,
            &mut material_slots,
            &mut texture_slots,
            &materials,
            &images,
            material.id(),
        ) else {
            continue;
        };
        let key = (mesh.id(), material.id());
        let mesh_slot = *mesh_slots.entry(key).or_insert_with(|| {
            snapshot.meshes.push((data, material_slot));
            snapshot.meshes.len() - 1
        });
        let matrix = transform.to_matrix().to_cols_array();
        seen.insert(entity);
        let moved = state
            .last_transform
            .insert(entity, matrix)
            .is_some_and(|last| last != matrix);
        let motion = match motion {
            Some(GiMotion::Static) => Motion::Static,
            Some(GiMotion::Movable) => Motion::Movable,
            None => {
                // Static until it first moves: one rebuild then, per-frame updates after.
                if moved {
                    state.promoted.insert(entity);
                }
                if state.promoted.contains(&entity) {
                    Motion::Movable
                } else {
                    Motion::Static
                }
            }
        };
        entity.hash(&mut signature);
        key.hash(&mut signature);
        (motion == Motion::Movable).hash(&mut signature);
        if motion == Motion::Static {
            // A static instance is part of the structure: moving it rebuilds.
            matrix.map(f32::to_bits).hash(&mut signature);
        }
        snapshot.instances.push(SnapshotInstance {
            mesh: mesh_slot,
            transform: Mat4::from_cols_array(&matrix),
            motion,
        });
    }
    state.last_transform.retain(|e, _| seen.contains(e));
    state.promoted.retain(|e| seen.contains(e));

    let mut lights: Vec<(Entity, Light)> = Vec::new();
    let visible = |v: Option<&InheritedVisibility>| v.is_none_or(|v| v.get());
    for (entity, light, transform, visibility) in &point_lights {
        if visible(visibility) {
            let mut l = Light::point(
                vec3(transform.translation()),
                units::linear_rgb(light.color),
                units::intensity_from_lumens(light.intensity),
            );
            l.name = format!("point {entity}");
            lights.push((entity, l));
        }
    }
    for (entity, light, transform, visibility) in &spot_lights {
        if visible(visibility) {
            let mut l = Light::spot(
                vec3(transform.translation()),
                vec3(*transform.forward()),
                units::linear_rgb(light.color),
                units::intensity_from_lumens(light.intensity),
                light.inner_angle,
                light.outer_angle.max(light.inner_angle + 1e-4),
            );
            l.name = format!("spot {entity}");
            lights.push((entity, l));
        }
    }
    for (entity, light, transform, visibility) in &directional_lights {
        if visible(visibility) {
            let mut l = Light::directional(
                vec3(*transform.forward()),
                units::linear_rgb(light.color),
                units::irradiance_from_lux(light.illuminance),
            );
            l.name = format!("sun {entity}");
            lights.push((entity, l));
        }
    }
    // Textures arrive after their materials: the material changes then.
    for material in &snapshot.materials {
        material.base_color_texture.is_some().hash(&mut signature);
    }
    lights.sort_by_key(|l| l.0);
    for (entity, light) in lights {
        entity.hash(&mut signature);
        std::mem::discriminant(&light.kind).hash(&mut signature);
        snapshot.lights.push(light);
    }

    let signature = signature.finish();
    if signature != state.signature {
        state.signature = signature;
        state.generation += 1;
    }
    snapshot.generation = state.generation;
    scene.0 = Arc::new(snapshot);
}

fn vec3(v: bevy::math::Vec3) -> Vec3 {
    Vec3::new(v.x, v.y, v.z)
}

/// Drops the cached conversions of assets that changed or went away.
fn forget_changed_assets(
    state: &mut MirrorState,
    meshes: &mut MessageReader<AssetEvent<Mesh>>,
    materials: &mut MessageReader<AssetEvent<StandardMaterial>>,
    images: &mut MessageReader<AssetEvent<Image>>,
) {
    for event in meshes.read() {
        if let AssetEvent::Modified { id } | AssetEvent::Removed { id } = event {
            if state.meshes.remove(id).is_some() {
                state.asset_epoch += 1;
            }
        }
    }
    for event in materials.read() {
        if let AssetEvent::Modified { id } | AssetEvent::Removed { id } = event {
            if state.materials.remove(id).is_some() {
                state.asset_epoch += 1;
            }
        }
    }
    for event in images.read() {
        if let AssetEvent::Modified { id } | AssetEvent::Removed { id } = event {
            if state.textures.remove(id).is_some() {
                state.asset_epoch += 1;
            }
        }
    }
}

/// The converted mesh, or None while it is not loaded or when it cannot be converted (warned
/// once).
fn mesh_data(
    state: &mut MirrorState,
    meshes: &Assets<Mesh>,
    id: AssetId<Mesh>,
    entity: Entity,
) -> Option<Arc<MeshData>> {
    if let Some(cached) = state.meshes.get(&id) {
        return cached.clone();
    }
    // Not loaded yet: it appears once it is (a structural change then).
    let mesh = meshes.get(id)?;
    let converted = match convert_mesh(mesh) {
        Ok(data) => Some(Arc::new(data)),
        Err(why) => {
            state.warn_once(format!("mesh {id:?}"), || {
                format!("the mesh of entity {entity} is not mirrored: {why}")
            });
            None
        }
    };
    state.meshes.insert(id, converted.clone());
    converted
}

fn convert_mesh(mesh: &Mesh) -> Result<MeshData, String> {
    if mesh.primitive_topology() != PrimitiveTopology::TriangleList {
        return Err(format!(
            "{:?} (octolux takes triangle lists)",
            mesh.primitive_topology()
        ));
    }
    let attribute = |id| {
        mesh.try_attribute_option(id).map_err(|_| {
            "its data is only in the render world (RenderAssetUsages::RENDER_WORLD)".to_string()
        })
    };
    let positions = match attribute(Mesh::ATTRIBUTE_POSITION)? {
        Some(VertexAttributeValues::Float32x3(p)) => p
            .iter()
            .map(|&[x, y, z]| Vec3::new(x, y, z))
            .collect::<Vec<_>>(),
        Some(_) => return Err("positions are not 32-bit float triples".into()),
        None => return Err("no positions".into()),
    };
    let normals = match attribute(Mesh::ATTRIBUTE_NORMAL)? {
        Some(VertexAttributeValues::Float32x3(n)) if n.len() == positions.len() => {
            n.iter().map(|&[x, y, z]| Vec3::new(x, y, z)).collect()
        }
        // Octolux computes normals where a mesh has none.
        _ => Vec::new(),
    };
    let uvs = match attribute(Mesh::ATTRIBUTE_UV_0)? {
        Some(VertexAttributeValues::Float32x2(uv)) if uv.len() == positions.len() => {
            uv.iter().map(|&[u, v]| Vec2::new(u, v)).collect()
        }
        _ => Vec::new(),
    };
    let indices: Vec<u32> = match mesh
        .try_indices_option()
        .map_err(|_| "its indices are only in the render world".to_string())?
    {
        Some(Indices::U16(i)) => i.iter().map(|&i| i as u32).collect(),
        Some(Indices::U32(i)) => i.clone(),
        None => (0..positions.len() as u32).collect(),
    };
    if indices.len() < 3 {
        return Err("no triangles".into());
    }
    Ok(MeshData {
        positions,
        normals,
        uvs,
        indices,
    })
}

/// The snapshot's material slot for a `StandardMaterial` (adding it and its texture on first
/// use this frame), or None while it is not loaded.
fn material_slot(
    state: &mut MirrorState,
    snapshot: &mut SceneSnapshot,
    slots: &mut HashMap<AssetId<StandardMaterial>, usize>,
    texture_slots: &mut HashMap<AssetId<Image>, usize>,
    materials: &Assets<StandardMaterial>,
    images: &Assets<Image>,
    id: AssetId<StandardMaterial>,
) -> Option<usize> {
    if let Some(&slot) = slots.get(&id) {
        return Some(slot);
    }
    let (mut material, texture) = match state.materials.entry(id) {
        std::collections::hash_map::Entry::Occupied(e) => e.get().clone(),
        std::collections::hash_map::Entry::Vacant(e) => {
            e.insert(convert_material(materials.get(id)?)).clone()
        }
    };
    material.base_color_texture = None;
    if let Some(image) = texture {
        if let Some(texture) = texture_data(state, images, image) {
            let slot = *texture_slots.entry(image).or_insert_with(|| {
                snapshot.textures.push(texture);
                snapshot.textures.len() - 1
            });
            material.base_color_texture = Some(slot as u32);
        }
    }
    snapshot.materials.push(material);
    slots.insert(id, snapshot.materials.len() - 1);
    Some(snapshot.materials.len() - 1)
}

/// Octolux's Lambertian material for a `StandardMaterial`: the diffuse colour Bevy's deferred
/// shading uses (base colour x (1 - metallic)), emission in W/(m^2 sr), alpha as octolux's
/// glTF importer treats it (blended surfaces as a half-coverage mask).
fn convert_material(m: &StandardMaterial) -> (Material, Option<AssetId<Image>>) {
    let base = bevy::color::LinearRgba::from(m.base_color);
    let diffuse = (1.0 - m.metallic.clamp(0.0, 1.0))
        * (1.0 - m.specular_transmission.clamp(0.0, 1.0))
        * (1.0 - m.diffuse_transmission.clamp(0.0, 1.0));
    let emissive = m.emissive;
    let (opacity, alpha_mode) = match m.alpha_mode {
        bevy::material::AlphaMode::Opaque => (1.0, AlphaMode::Opaque),
        bevy::material::AlphaMode::Mask(cutoff) => (base.alpha, AlphaMode::Mask(cutoff)),
        _ => (base.alpha, AlphaMode::Mask(0.5)),
    };
    let material = Material {
        name: "bevy material".into(),
        base_color: Vec3::new(base.red, base.green, base.blue) * diffuse,
        base_color_texture: None,
        emission: Vec3::new(emissive.red, emissive.green, emissive.blue)
            * units::radiance_from_nits(1.0),
        emission_two_sided: m.double_sided,
        opacity,
        alpha_mode,
    };
    // Unlit surfaces show their colour without reflecting light; octolux sees them as black.
    let material = if m.unlit {
        Material {
            base_color: Vec3::ZERO,
            ..material
        }
    } else {
        material
    };
    (material, m.base_color_texture.as_ref().map(|h| h.id()))
}

/// A base-colour texture as octolux's RGBA8 sRGB, or None while it loads or when its format
/// cannot be read (warned once; the material keeps its factor).
fn texture_data(
    state: &mut MirrorState,
    images: &Assets<Image>,
    id: AssetId<Image>,
) -> Option<Arc<Texture>> {
    if let Some(cached) = state.textures.get(&id) {
        return cached.clone();
    }
    let image = images.get(id)?;
    let converted = match image.texture_descriptor.format {
        TextureFormat::Rgba8UnormSrgb | TextureFormat::Rgba8Unorm => image.data.clone(),
        _ => image
            .convert(TextureFormat::Rgba8UnormSrgb)
            .and_then(|i| i.data),
    };
    let texture = match converted {
        Some(rgba) if rgba.len() == (image.width() * image.height() * 4) as usize => {
            Some(Arc::new(Texture {
                name: format!("{id:?}"),
                width: image.width(),
                height: image.height(),
                rgba,
            }))
        }
        _ => {
            state.warn_once(format!("image {id:?}"), || {
                format!(
                    "a base colour texture ({:?}, {}x{}) cannot be read on the CPU: octolux uses \
                     its material's colour factor instead",
                    image.texture_descriptor.format,
                    image.width(),
                    image.height()
                )
            });
            None
        }
    };
    state.textures.insert(id, texture.clone());
    texture
}

#[cfg(test)]
mod tests {
    use super::*;
    use bevy::asset::RenderAssetUsages;
    use bevy::color::{Color, LinearRgba};

    fn triangle(topology: PrimitiveTopology) -> Mesh {
        Mesh::new(topology, RenderAssetUsages::default())
            .with_inserted_attribute(
                Mesh::ATTRIBUTE_POSITION,
                vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            )
            .with_inserted_indices(Indices::U16(vec![0, 1, 2]))
    }

    #[test]
    fn meshes_convert_with_their_indices_and_without_normals_octolux_computes() {
        let data = convert_mesh(&triangle(PrimitiveTopology::TriangleList)).expect("a triangle");
        assert_eq!(data.indices, vec![0, 1, 2]);
        assert_eq!(data.positions[1], Vec3::X);
        assert!(data.normals.is_empty() && data.uvs.is_empty());
        let error = convert_mesh(&triangle(PrimitiveTopology::LineList)).unwrap_err();
        assert!(error.contains("LineList"), "{error}");
    }

    #[test]
    fn materials_become_their_diffuse_part_in_radiometric_units() {
        let (m, texture) = convert_material(&StandardMaterial {
            base_color: Color::linear_rgb(0.8, 0.4, 0.2),
            metallic: 0.5,
            emissive: LinearRgba::rgb(683.0, 0.0, 0.0),
            ..StandardMaterial::default()
        });
        assert!(texture.is_none());
        assert!(
            (m.base_color - Vec3::new(0.4, 0.2, 0.1))
                .abs()
                .max_element()
                < 1e-6
        );
        assert!((m.emission - Vec3::new(1.0, 0.0, 0.0)).abs().max_element() < 1e-6);
        assert_eq!(m.alpha_mode, AlphaMode::Opaque);
        let (unlit, _) = convert_material(&StandardMaterial {
            unlit: true,
            ..StandardMaterial::default()
        });
        assert_eq!(unlit.base_color, Vec3::ZERO);
        let (glass, _) = convert_material(&StandardMaterial {
            base_color: Color::linear_rgba(1.0, 1.0, 1.0, 0.2),
            alpha_mode: bevy::material::AlphaMode::Blend,
            ..StandardMaterial::default()
        });
        assert!(
            glass.is_clear(),
            "a mostly transparent blend is a hole for octolux"
        );
    }
}
