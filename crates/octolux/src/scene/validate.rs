//! Scene validation: turns malformed geometry into clear errors before anything reaches the GPU.

use super::Scene;
use crate::{Error, Result};

/// Largest far / near ratio of a camera: beyond it the GPU renderer's 32-bit depth buffer
/// loses the precision its lighting needs (at 5e6 the Cornell box's direct light is off by a
/// relMSE of 4e-4, at 1e7 by 1e-2). Mitsuba's default clip planes (0.01, 10^4) are within it.
pub const MAX_DEPTH_RATIO: f32 = 2e6;

/// Checks a scene and repairs what can be repaired:
/// - errors: no geometry, non-finite positions/normals/UVs, indices out of range or not a
///   multiple of three, material/texture/mesh references out of range, non-finite lights;
///   world coordinates (objects at rest, lights, cameras) beyond
///   [`MAX_COORDINATE`](crate::limits::MAX_COORDINATE); emission, light intensity and sky
///   radiance beyond [`MAX_RADIANCE`](crate::limits::MAX_RADIANCE); cameras with a field of
///   view outside (0, 180) degrees, `near` not positive, `far` not above `near`, far / near
///   above [`MAX_DEPTH_RATIO`], the eye on its target, or an exposure beyond +-64 EV;
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
            mesh.compute_normals()?;
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
    for texture in &scene.textures {
        texture.check().map_err(|e| match e {
            Error::InvalidArgument(message) => err(message),
            other => other,
        })?;
    }
    let tracks = scene
        .objects
        .iter()
        .map(|o| ("object", &o.name, &o.animation))
        .chain(
            scene
                .lights
                .iter()
                .map(|l| ("light", &l.name, &l.animation)),
        )
        .chain(
            scene
                .cameras
                .iter()
                .map(|c| ("camera", &c.name, &c.animation)),
        );
    for (kind, item, track) in tracks {
        if let Some(track) = track {
            check_track(track).map_err(|m| err(format!("{kind} '{item}': animation {m}")))?;
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
    check_ranges(scene).map_err(err)?;
    if scene.triangle_count() == 0 {
        return Err(err(
            "the scene has no geometry (no non-degenerate triangles)".into(),
        ));
    }
    Ok(())
}

/// Largest scene exposure, in stops either way (the same as the `--exposure` flag's).
pub const MAX_EXPOSURE: f32 = 64.0;

/// A track's keys: at least one, sorted, finite, with unit-length rotations.
fn check_track(track: &super::Track) -> std::result::Result<(), String> {
    if track.keys.is_empty() {
        return Err("has no keys".into());
    }
    for (i, key) in track.keys.iter().enumerate() {
        if !key.time.is_finite() || !key.translation.is_finite() || !key.rotation.is_finite() {
            return Err(format!(
                "key {i}: time, translation and rotation must be finite"
            ));
        }
        if key.translation.abs().max_element() > crate::limits::MAX_COORDINATE {
            return Err(format!(
                "key {i}: translation {} is beyond the coordinate limit of +-{:e} m",
                key.translation,
                crate::limits::MAX_COORDINATE
            ));
        }
        if (key.rotation.length() - 1.0).abs() > 1e-3 {
            return Err(format!(
                "key {i}: rotation {} is not a unit quaternion",
                key.rotation
            ));
        }
        if i > 0 && key.time < track.keys[i - 1].time {
            return Err(format!(
                "key {i}: keys must be sorted by time (Track::new sorts them)"
            ));
        }
    }
    Ok(())
}

/// The range checks of [`validate`] on values that are finite but too large to render.
fn check_ranges(scene: &Scene) -> std::result::Result<(), String> {
    use crate::limits::{MAX_COORDINATE, MAX_RADIANCE};
    let far_point = |p: glam::Vec3| p.abs().max_element() > MAX_COORDINATE;
    let coordinate_error = |what: String, p: glam::Vec3| {
        format!(
            "{what} lies at {p}, beyond the coordinate limit of +-{MAX_COORDINATE:e} m \
             (check the model's units or the scene's `unit`)"
        )
    };
    for object in &scene.objects {
        for &m in &object.meshes {
            let mesh = &scene.meshes[m as usize];
            if let Some(i) = mesh
                .positions
                .iter()
                .position(|&p| far_point(object.transform.transform_point3(p)))
            {
                return Err(coordinate_error(
                    format!("object '{}', mesh '{}', vertex {i}", object.name, mesh.name),
                    object.transform.transform_point3(mesh.positions[i]),
                ));
            }
        }
    }
    let radiance_error =
        |what: String, v: f32| format!("{what} is {v:e}; at most {MAX_RADIANCE:e} is accepted");
    for material in &scene.materials {
        let e = material.emission.max_element();
        if e > MAX_RADIANCE {
            return Err(radiance_error(
                format!("material '{}': emission (W/(m^2 sr))", material.name),
                e,
            ));
        }
        if material.emission.min_element() < 0.0 {
            return Err(format!(
                "material '{}': emission {} must not be negative",
                material.name, material.emission
            ));
        }
    }
    for light in &scene.lights {
        let radiant = light.radiant().max_element();
        if radiant > MAX_RADIANCE || light.intensity > MAX_RADIANCE {
            return Err(radiance_error(
                format!("light '{}': colour x intensity", light.name),
                radiant.max(light.intensity),
            ));
        }
        if far_point(light.position) {
            return Err(coordinate_error(
                format!("light '{}'", light.name),
                light.position,
            ));
        }
    }
    if let Some(sky) = &scene.sky {
        let peak = match &sky.radiance {
            super::SkyRadiance::Constant(c) => c.max_element(),
            super::SkyRadiance::Map(map) => map
                .image
                .pixels
                .iter()
                .fold(0.0f32, |m, p| m.max(p.max_element())),
        };
        let total = peak * sky.intensity;
        if !total.is_finite() || total > MAX_RADIANCE || !sky.intensity.is_finite() {
            return Err(radiance_error(
                "sky: peak radiance x intensity (W/(m^2 sr))".into(),
                total,
            ));
        }
    }
    if !scene.exposure.is_finite() || scene.exposure.abs() > MAX_EXPOSURE {
        return Err(format!(
            "exposure {}: expected a finite EV within -{MAX_EXPOSURE}..={MAX_EXPOSURE}",
            scene.exposure
        ));
    }
    for camera in &scene.cameras {
        check_camera(camera).map_err(|e| format!("camera '{}': {e}", camera.name))?;
    }
    Ok(())
}

/// Checks one camera's placement and projection.
fn check_camera(camera: &super::Camera) -> std::result::Result<(), String> {
    use crate::limits::MAX_COORDINATE;
    for (what, p) in [("position", camera.position), ("target", camera.target)] {
        if !p.is_finite() || p.abs().max_element() > MAX_COORDINATE {
            return Err(format!(
                "{what} {p}: expected finite coordinates within +-{MAX_COORDINATE:e} m"
            ));
        }
    }
    if !camera.up.is_finite() {
        return Err(format!("up {} is not finite", camera.up));
    }
    if (camera.target - camera.position).length_squared() <= 0.0 {
        return Err(format!(
            "position and target are the same point {}: the view has no direction",
            camera.position
        ));
    }
    let fov_ok = |f: f32| f > 0.0 && f < std::f32::consts::PI;
    for (what, fov) in [("vertical", Some(camera.vfov)), ("horizontal", camera.hfov)] {
        if let Some(f) = fov {
            if !fov_ok(f) {
                return Err(format!(
                    "{what} field of view {f} rad ({} degrees): expected more than 0 and less \
                     than pi rad (180 degrees)",
                    f.to_degrees()
                ));
            }
        }
    }
    let (near, far) = (camera.near, camera.far);
    if !(near.is_finite() && far.is_finite() && near > 0.0 && far > near) {
        return Err(format!(
            "near {near}, far {far}: need 0 < near < far, both finite"
        ));
    }
    if far / near > MAX_DEPTH_RATIO {
        return Err(format!(
            "far / near is {:e} (near {near}, far {far}); at most {MAX_DEPTH_RATIO:e} keeps \
             depth precise: raise near or lower far",
            far / near
        ));
    }
    Ok(())
}
