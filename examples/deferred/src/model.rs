//! The example's own glTF loading: triangle meshes with their node transforms and base
//! colours, `KHR_lights_punctual` point lights and the first perspective camera. Nothing of
//! octolux's importer is used; octolux gets the result through code.

use anyhow::{bail, Context, Result};
use glam::{Mat4, Quat, Vec3};
use std::path::Path;

/// One glTF primitive, placed.
pub struct ModelMesh {
    /// Node name (the example moves the node called "block").
    pub node: String,
    /// Object-space positions.
    pub positions: Vec<Vec3>,
    /// Object-space unit normals, one per position.
    pub normals: Vec<Vec3>,
    /// Triangle list.
    pub indices: Vec<u32>,
    /// Linear base colour.
    pub base_color: Vec3,
    /// Emitted radiance (emissive factor x strength).
    pub emission: Vec3,
    /// Node to world.
    pub transform: Mat4,
}

/// A point light in radiometric units: W/sr (glTF's candela / 683 lm/W).
#[derive(Clone, Copy, Debug)]
pub struct Lamp {
    /// World position.
    pub position: Vec3,
    /// Linear colour x intensity, W/sr.
    pub intensity: Vec3,
}

/// A perspective camera.
#[derive(Clone, Copy, Debug)]
pub struct ModelCamera {
    /// Camera to world.
    pub transform: Mat4,
    /// Vertical field of view, radians.
    pub yfov: f32,
    /// Near plane distance.
    pub znear: f32,
}

/// What the example draws.
pub struct Model {
    /// Every primitive.
    pub meshes: Vec<ModelMesh>,
    /// Point lights.
    pub lamps: Vec<Lamp>,
    /// The first camera, if the file has one.
    pub camera: Option<ModelCamera>,
}

impl Model {
    /// Loads a glTF file (`.gltf` or `.glb`).
    pub fn load(path: &Path) -> Result<Model> {
        let (doc, buffers, _images) =
            gltf::import(path).with_context(|| format!("cannot read glTF {}", path.display()))?;
        let mut model = Model {
            meshes: Vec::new(),
            lamps: Vec::new(),
            camera: None,
        };
        let scene = doc
            .default_scene()
            .or_else(|| doc.scenes().next())
            .with_context(|| format!("{}: no scene", path.display()))?;
        for node in scene.nodes() {
            model.visit(&node, Mat4::IDENTITY, &buffers)?;
        }
        if model.meshes.is_empty() {
            bail!("{}: no triangle meshes", path.display());
        }
        Ok(model)
    }

    fn visit(
        &mut self,
        node: &gltf::Node,
        parent: Mat4,
        buffers: &[gltf::buffer::Data],
    ) -> Result<()> {
        let (t, r, s) = node.transform().decomposed();
        let world =
            parent * Mat4::from_scale_rotation_translation(s.into(), Quat::from_array(r), t.into());
        let name = node.name().unwrap_or("").to_string();
        if let Some(mesh) = node.mesh() {
            for primitive in mesh.primitives() {
                if primitive.mode() != gltf::mesh::Mode::Triangles {
                    continue;
                }
                let reader = primitive.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
                let positions: Vec<Vec3> = reader
                    .read_positions()
                    .with_context(|| format!("node '{name}': a primitive without positions"))?
                    .map(Vec3::from)
                    .collect();
                let indices: Vec<u32> = match reader.read_indices() {
                    Some(i) => i.into_u32().collect(),
                    None => (0..positions.len() as u32).collect(),
                };
                let normals: Vec<Vec3> = match reader.read_normals() {
                    Some(n) => n.map(Vec3::from).collect(),
                    None => face_normals(&positions, &indices),
                };
                let material = primitive.material();
                let pbr = material.pbr_metallic_roughness();
                let [r, g, b, _] = pbr.base_color_factor();
                let strength = material.emissive_strength().unwrap_or(1.0);
                self.meshes.push(ModelMesh {
                    node: name.clone(),
                    positions,
                    normals,
                    indices,
                    base_color: Vec3::new(r, g, b),
                    emission: Vec3::from(material.emissive_factor()) * strength,
                    transform: world,
                });
            }
        }
        if let Some(light) = node.light() {
            if let gltf::khr_lights_punctual::Kind::Point = light.kind() {
                self.lamps.push(Lamp {
                    position: world.transform_point3(Vec3::ZERO),
                    intensity: Vec3::from(light.color()) * light.intensity() / 683.0,
                });
            }
        }
        if let (Some(camera), None) = (node.camera(), &self.camera) {
            if let gltf::camera::Projection::Perspective(p) = camera.projection() {
                self.camera = Some(ModelCamera {
                    transform: world,
                    yfov: p.yfov(),
                    znear: p.znear(),
                });
            }
        }
        for child in node.children() {
            self.visit(&child, world, buffers)?;
        }
        Ok(())
    }
}

/// Per-vertex normals of a mesh without them: each vertex takes the sum of its triangles'
/// area-weighted normals.
fn face_normals(positions: &[Vec3], indices: &[u32]) -> Vec<Vec3> {
    let mut normals = vec![Vec3::ZERO; positions.len()];
    for tri in indices.chunks_exact(3) {
        let [a, b, c] = [0, 1, 2].map(|k| tri[k] as usize);
        if let (Some(&pa), Some(&pb), Some(&pc)) =
            (positions.get(a), positions.get(b), positions.get(c))
        {
            let n = (pb - pa).cross(pc - pa);
            for v in [a, b, c] {
                normals[v] += n;
            }
        }
    }
    normals.iter().map(|n| n.normalize_or(Vec3::Y)).collect()
}
