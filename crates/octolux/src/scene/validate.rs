//! Scene validation: turns malformed geometry into clear errors before anything reaches the GPU.

use super::Scene;
use crate::{Error, Result};

/// Checks a scene and repairs what can be repaired:
/// - errors: no geometry, non-finite positions/normals/UVs, indices out of range or not a
///   multiple of three, material/texture/mesh references out of range, non-finite lights;
/// - repaired with a warning: degenerate (zero-area) triangles are removed.
pub fn validate(scene: &mut Scene) -> Result<()> {
    let name = scene.name.clone();
    let err = |message: String| Error::scene(name.clone(), message);
    let mut dropped = 0usize;
    for mesh in &mut scene.meshes {
        let n = mesh.positions.len();
        if mesh.indices.len() % 3 != 0 {
            return Err(err(format!(
                "mesh '{}': {} indices is not a multiple of 3",
                mesh.name,
                mesh.indices.len()
            )));
        }
        if let Some(i) = mesh.positions.iter().position(|p| !p.is_finite()) {
            return Err(err(format!(
                "mesh '{}': vertex {i} has a non-finite position {:?}",
                mesh.name, mesh.positions[i]
            )));
        }
        if let Some(&i) = mesh.indices.iter().find(|&&i| i as usize >= n) {
            return Err(err(format!(
                "mesh '{}': index {i} out of range (mesh has {n} vertices)",
                mesh.name
            )));
        }
        if mesh.normals.len() != n {
            mesh.compute_normals();
        }
        if let Some(i) = mesh.normals.iter().position(|v| !v.is_finite()) {
            return Err(err(format!(
                "mesh '{}': vertex {i} has a non-finite normal",
                mesh.name
            )));
        }
        if mesh.uvs.len() != n {
            mesh.uvs = vec![glam::Vec2::ZERO; n];
        }
        if let Some(i) = mesh.uvs.iter().position(|v| !v.is_finite()) {
            return Err(err(format!(
                "mesh '{}': vertex {i} has a non-finite UV",
                mesh.name
            )));
        }
        if mesh.material as usize >= scene.materials.len() {
            return Err(err(format!(
                "mesh '{}': material {} out of range ({} materials)",
                mesh.name,
                mesh.material,
                scene.materials.len()
            )));
        }
        let before = mesh.indices.len() / 3;
        let positions = &mesh.positions;
        let kept: Vec<u32> = mesh
            .indices
            .chunks_exact(3)
            .filter(|t| {
                let [a, b, c] = [t[0], t[1], t[2]].map(|i| positions[i as usize]);
                (b - a).cross(c - a).length_squared() > 0.0
            })
            .flatten()
            .copied()
            .collect();
        dropped += before - kept.len() / 3;
        mesh.indices = kept;
    }
    if dropped > 0 {
        log::warn!("scene '{name}': removed {dropped} degenerate (zero-area) triangles");
    }
    for material in &scene.materials {
        if let Some(t) = material.base_color_texture {
            if t as usize >= scene.textures.len() {
                return Err(err(format!(
                    "material '{}': texture {t} out of range",
                    material.name
                )));
            }
        }
        if !material.base_color.is_finite() || !material.emission.is_finite() {
            return Err(err(format!(
                "material '{}': non-finite colour",
                material.name
            )));
        }
    }
    for object in &scene.objects {
        if let Some(&m) = object
            .meshes
            .iter()
            .find(|&&m| m as usize >= scene.meshes.len())
        {
            return Err(err(format!(
                "object '{}': mesh {m} out of range",
                object.name
            )));
        }
        if !object.transform.is_finite() {
            return Err(err(format!(
                "object '{}': non-finite transform",
                object.name
            )));
        }
    }
    for light in &scene.lights {
        if !light.position.is_finite()
            || !light.direction.is_finite()
            || !light.intensity.is_finite()
            || !light.color.is_finite()
            || light.intensity < 0.0
        {
            return Err(err(format!(
                "light '{}': position, direction, colour and intensity must be finite (intensity >= 0)",
                light.name
            )));
        }
        if light.direction.length_squared() < 1e-12 && light.kind != super::LightKind::Point {
            return Err(err(format!("light '{}': zero direction", light.name)));
        }
    }
    if scene.triangle_count() == 0 {
        return Err(err(
            "the scene has no geometry (no non-degenerate triangles)".into(),
        ));
    }
    Ok(())
}
