//! The scene through code: materials, textures, meshes, instances and lights added, moved and
//! removed between frames. Moving a [`Motion::Movable`] instance or changing a light is a
//! per-frame upload; adding or removing anything, or moving a [`Motion::Static`] instance,
//! rebuilds the GPU scene and the technique at the next frame (what a level load or a
//! streaming step costs, not something to do every frame).

use super::GiEngine;
use crate::scene::{
    Camera, Keyframe, Light, Material, Mesh, Object, Scene, SceneFrame, Sky, Texture, Track,
};
use crate::{Error, Result};
use glam::{Mat4, Quat, Vec3};

/// A material added with [`GiEngine::add_material`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct MaterialId(pub u32);

/// A texture added with [`GiEngine::add_texture`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct TextureId(pub u32);

/// A mesh added with [`GiEngine::add_mesh`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct MeshId(pub u32);

/// An instance added with [`GiEngine::add_instance`] (stays valid until it is removed).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct InstanceId(u64);

/// A light added with [`GiEngine::add_light`] (stays valid until it is removed).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct LightId(u64);

/// Whether an instance moves.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Motion {
    /// Never moves: the techniques bake it into their static structures (voxels, probe
    /// geometry); moving it anyway rebuilds them.
    Static,
    /// Moves between frames ([`GiEngine::set_transform`]): the techniques update it every
    /// frame, as the scene format's animated objects.
    Movable,
}

/// Stable ids of the scene's objects and lights, in the scene's order.
#[derive(Clone, Debug, Default)]
pub(super) struct Ids {
    instances: Vec<u64>,
    lights: Vec<u64>,
    next: u64,
}

impl Ids {
    /// Ids for the objects and lights a scene already has.
    pub fn for_scene(scene: &Scene) -> Ids {
        let mut ids = Ids::default();
        ids.instances = (0..scene.objects.len()).map(|_| ids.fresh()).collect();
        ids.lights = (0..scene.lights.len()).map(|_| ids.fresh()).collect();
        ids
    }

    fn fresh(&mut self) -> u64 {
        self.next += 1;
        self.next
    }

    fn instance(&self, id: InstanceId) -> Result<usize> {
        self.instances
            .iter()
            .position(|&i| i == id.0)
            .ok_or_else(|| Error::InvalidArgument(format!("no instance {id:?} (removed?)")))
    }

    fn light(&self, id: LightId) -> Result<usize> {
        self.lights
            .iter()
            .position(|&i| i == id.0)
            .ok_or_else(|| Error::InvalidArgument(format!("no light {id:?} (removed?)")))
    }

    /// The scene at time `t` seen from `camera`.
    pub fn frame(&self, scene: &Scene, t: f32, camera: Camera) -> SceneFrame {
        SceneFrame {
            time: t,
            object_transforms: scene.objects.iter().map(|o| o.transform_at(t)).collect(),
            lights: scene.lights.iter().map(|l| l.at_time(t)).collect(),
            camera,
        }
    }
}

/// The track that marks an instance as moving: one key at rest (its place is its transform).
fn still_track() -> Track {
    Track {
        keys: vec![Keyframe {
            time: 0.0,
            translation: Vec3::ZERO,
            rotation: Quat::IDENTITY,
        }],
        looping: false,
    }
}

fn check_transform(what: &str, m: &Mat4) -> Result<()> {
    if !m.is_finite() || m.determinant().abs() < 1e-12 {
        return Err(Error::InvalidArgument(format!(
            "{what}: the transform must be finite and invertible, got {m:?}"
        )));
    }
    Ok(())
}

impl GiEngine {
    /// Adds a material (albedo `base_color`, `emission` radiance, `opacity`).
    pub fn add_material(&mut self, material: Material) -> MaterialId {
        self.scene.materials.push(material);
        self.structure_changed();
        MaterialId(self.scene.materials.len() as u32 - 1)
    }

    /// Replaces a material's values (a rebuild: materials are baked into the structures).
    pub fn set_material(&mut self, id: MaterialId, material: Material) -> Result<()> {
        let slot = self
            .scene
            .materials
            .get_mut(id.0 as usize)
            .ok_or_else(|| Error::InvalidArgument(format!("no material {id:?}")))?;
        *slot = material;
        self.structure_changed();
        Ok(())
    }

    /// Adds a base-colour texture (RGBA8, sRGB colour) for materials to refer to.
    pub fn add_texture(&mut self, texture: Texture) -> Result<TextureId> {
        texture.check()?;
        self.scene.textures.push(texture);
        self.structure_changed();
        Ok(TextureId(self.scene.textures.len() as u32 - 1))
    }

    /// Adds a mesh (positions, and optionally normals and UVs per vertex; indices in threes)
    /// drawn with `material`. Missing normals are computed; malformed data is an error naming
    /// the mesh.
    pub fn add_mesh(&mut self, mut mesh: Mesh, material: MaterialId) -> Result<MeshId> {
        if material.0 as usize >= self.scene.materials.len() {
            return Err(Error::InvalidArgument(format!(
                "mesh '{}': no material {material:?}",
                mesh.name
            )));
        }
        mesh.material = material.0;
        // Checked on its own now, so that the error comes with the call that made it.
        let mut alone = Scene {
            name: format!("mesh '{}'", mesh.name),
            meshes: vec![mesh],
            materials: self.scene.materials.clone(),
            textures: self.scene.textures.clone(),
            objects: vec![Object {
                name: "check".into(),
                meshes: vec![0],
                transform: Mat4::IDENTITY,
                animation: None,
            }],
            ..Scene::default()
        };
        crate::scene::validate(&mut alone)?;
        self.scene.meshes.push(alone.meshes.remove(0));
        self.structure_changed();
        Ok(MeshId(self.scene.meshes.len() as u32 - 1))
    }

    /// Places `mesh` with `transform` (object to world).
    pub fn add_instance(
        &mut self,
        mesh: MeshId,
        transform: Mat4,
        motion: Motion,
    ) -> Result<InstanceId> {
        if mesh.0 as usize >= self.scene.meshes.len() {
            return Err(Error::InvalidArgument(format!("no mesh {mesh:?}")));
        }
        check_transform("add_instance", &transform)?;
        let id = self.ids.fresh();
        self.scene.objects.push(Object {
            name: format!("instance {id}"),
            meshes: vec![mesh.0],
            transform,
            animation: (motion == Motion::Movable).then(still_track),
        });
        self.ids.instances.push(id);
        self.structure_changed();
        Ok(InstanceId(id))
    }

    /// Moves an instance. A [`Motion::Movable`] one moves at the next frame; a static one
    /// rebuilds the structures.
    pub fn set_transform(&mut self, id: InstanceId, transform: Mat4) -> Result<()> {
        check_transform("set_transform", &transform)?;
        let i = self.ids.instance(id)?;
        let object = &mut self.scene.objects[i];
        if object.transform == transform {
            return Ok(());
        }
        object.transform = transform;
        if object.animation.is_none() {
            self.structure_changed();
        }
        Ok(())
    }

    /// Removes an instance.
    pub fn remove_instance(&mut self, id: InstanceId) -> Result<()> {
        let i = self.ids.instance(id)?;
        self.scene.objects.remove(i);
        self.ids.instances.remove(i);
        self.structure_changed();
        Ok(())
    }

    /// Adds a light.
    pub fn add_light(&mut self, light: Light) -> Result<LightId> {
        check_light(&light)?;
        let id = self.ids.fresh();
        self.scene.lights.push(light);
        self.ids.lights.push(id);
        self.structure_changed();
        Ok(LightId(id))
    }

    /// Changes a light (position, direction, colour, intensity, cone) from the next frame on;
    /// changing its kind rebuilds the shadow maps.
    pub fn set_light(&mut self, id: LightId, light: Light) -> Result<()> {
        check_light(&light)?;
        let i = self.ids.light(id)?;
        let kind_changed = std::mem::discriminant(&self.scene.lights[i].kind)
            != std::mem::discriminant(&light.kind);
        self.scene.lights[i] = light;
        if kind_changed {
            self.structure_changed();
        }
        Ok(())
    }

    /// Removes a light.
    pub fn remove_light(&mut self, id: LightId) -> Result<()> {
        let i = self.ids.light(id)?;
        self.scene.lights.remove(i);
        self.ids.lights.remove(i);
        self.structure_changed();
        Ok(())
    }

    /// Sets or clears the sky (a rebuild: the sky's lights get shadow maps).
    pub fn set_sky(&mut self, sky: Option<Sky>) {
        self.scene.sky = sky;
        self.structure_changed();
    }

    /// The engine's GPU scene and technique are rebuilt at the next frame.
    fn structure_changed(&mut self) {
        self.lit = None;
        let _ = self.drop_technique();
    }
}

fn check_light(light: &Light) -> Result<()> {
    let finite = light.position.is_finite()
        && light.direction.is_finite()
        && light.color.is_finite()
        && light.intensity.is_finite();
    if !finite || light.intensity < 0.0 || light.color.min_element() < 0.0 {
        return Err(Error::InvalidArgument(format!(
            "light '{}': position, direction, colour and intensity must be finite and not \
             negative",
            light.name
        )));
    }
    if light.kind != crate::scene::LightKind::Point && light.direction.length_squared() < 1e-12 {
        return Err(Error::InvalidArgument(format!(
            "light '{}': a spot or directional light needs a direction",
            light.name
        )));
    }
    Ok(())
}
