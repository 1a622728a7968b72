//! Scene files: a small TOML format that places models, lights and cameras, with keyframe
//! animation. `docs/scene-format.md` has the full reference and a complete example.
//!
//! ```toml
//! name = "cornell-box"
//! exposure = 0.0                      # stops
//! unit = 1.0                          # metres per scene unit (0.3048 for feet); the
//!                                     # `[settings]` tables stay in metres
//!
//! [settings]                          # kept as a raw table for GI technique settings
//!
//! [[model]]
//! path = "builtin:cornell-box"        # or "models/x.obj" (relative to this file),
//!                                     # or "scenes:crytek-sponza/sponza_noleaf.obj"
//!                                     # or "builtin:ground-plane" (with size = metres)
//! scale = 1.0                         # or [x, y, z]
//! rotate = [0.0, 90.0, 0.0]           # degrees, about x then y then z; or { axis = [..], angle = .. }
//! translate = [0.0, 0.0, 0.0]
//! pivot = [0.0, 0.0, 0.0]             # model-space point placed at `translate`
//! # transform = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]
//! #                                   # rows of an affine matrix, instead of the four above
//! objects = ["room"]                  # keep only these objects of the model (OBJ: o/g
//!                                     # names; glTF: node names)
//! # materials = ["white"]             # keep only meshes with these materials
//! # exclude_objects = ["tall-block"]  # then drop these objects
//! # exclude_materials = ["glass"]     # and the meshes with these materials
//! material = { albedo = [0.8, 0.8, 0.8], emission = [0.0, 0.0, 0.0] }
//! # material.two_sided = true         # emission from both faces (default: the front face)
//! # material.texture = "wood.png"     # base-colour texture (albedo, or white, modulates it)
//! loop = true
//! [[model.animation]]
//! time = 0.0
//! translate = [0.0, 0.0, 0.0]         # offset from the rest placement
//! rotate = [0.0, 0.0, 0.0]            # about the model's placed pivot
//!
//! [[light]]
//! type = "spot"                       # "point" | "spot" | "directional"
//! position = [0.278, 0.538, 0.2796]
//! direction = [0.0, -1.0, 0.0]        # or target = [x, y, z]
//! color = [1.0, 1.0, 1.0]             # linear
//! intensity = 1.0                     # W/sr (point, spot) or W/m^2 (directional)
//! inner_angle = 55.0                  # half-angles, degrees (spot only)
//! outer_angle = 70.0
//!
//! [sky]                               # environment light (optional)
//! color = [0.5, 0.6, 0.8]             # constant radiance, W/(m^2 sr); or:
//! # map = "sky.hdr"                   # equirectangular .hdr or .exr (Mitsuba's orientation)
//! intensity = 1.0                     # scales the radiance
//! rotate = [0.0, 90.0, 0.0]           # turns the map, like a model's rotate
//! directions = 32                     # shadowed sky lights of the GPU renderer (1..=64)
//!
//! [[camera]]
//! position = [0.278, 0.273, -0.8]
//! target = [0.278, 0.273, 0.0]
//! fov = 39.3                          # degrees, vertical unless fov_axis = "horizontal"
//! ```
//!
//! Keyframe rotations of a light or camera turn it about its own position; those of a model
//! turn it about its placed pivot (`translate`, which is where the model-space point `pivot`
//! lands). To express that with [`Track`]s (which apply on top of the rest transform, about the
//! world origin), the rest position of an animated item is folded into its keys: an animated
//! light or camera has its rest position at the origin and the keys carry `position +
//! translate`, and an animated object's rest transform has no translation.
//!
//! Unknown keys, out-of-range values and missing files are errors that name the scene file
//! (and the line, for syntax and type errors).

use super::{
    cornell, Camera, EnvironmentMap, Keyframe, Light, LightKind, Material, Mesh, Object, Scene,
    Sky, Track,
};
use crate::limits::{Account, Resource};
use crate::{Error, Result};
use glam::{Mat3, Mat4, Quat, Vec2, Vec3};
use serde::Deserialize;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// Prefix of model paths resolved against the shared scenes folder.
pub const SCENES_PREFIX: &str = "scenes:";
/// Prefix of built-in models.
pub const BUILTIN_PREFIX: &str = "builtin:";
/// Environment variable naming the shared scenes folder.
pub const SCENES_ENV: &str = "OCTOLUX_SCENES";

/// Loads and validates a scene file, dropping its `[settings]` table.
pub fn load(path: &Path) -> Result<Scene> {
    load_with_settings(path).map(|(scene, _)| scene)
}

/// Loads and validates a scene file; also returns its `[settings]` table (empty when absent),
/// which holds GI technique settings read elsewhere.
pub fn load_with_settings(path: &Path) -> Result<(Scene, toml::Table)> {
    load_within(path, &Account::default())
}

/// [`load_with_settings`], charging what the scene pulls in to `account` (see
/// [`crate::limits::Budget`]).
pub fn load_within(path: &Path, account: &Account) -> Result<(Scene, toml::Table)> {
    if !path.exists() {
        return Err(Error::io(
            path,
            std::io::Error::new(std::io::ErrorKind::NotFound, "file not found"),
        ));
    }
    let text = account.read_text(path)?;
    parse_within(&text, path, account)
}

/// Parses and validates scene-file text as if it had been read from `path` (relative model
/// paths resolve against `path`'s folder; errors name `path`).
pub fn parse(text: &str, path: &Path) -> Result<Scene> {
    parse_with_settings(text, path).map(|(scene, _)| scene)
}

/// [`parse`], also returning the `[settings]` table.
pub fn parse_with_settings(text: &str, path: &Path) -> Result<(Scene, toml::Table)> {
    parse_within(text, path, &Account::default())
}

fn parse_within(text: &str, path: &Path, account: &Account) -> Result<(Scene, toml::Table)> {
    let description = describe(text, path)?;
    let settings = description.settings.clone();
    let unit = description.unit;
    let mut scene = build(description, path, account)?;
    if unit != 1.0 {
        scene.scale_world(unit);
    }
    account.check()?;
    super::validate(&mut scene)?;
    Ok((scene, settings))
}

/// Parses and checks a scene file without loading any model: every field is checked and
/// every model file must exist. Returns the model files it refers to (built-ins excluded), in
/// file order.
pub fn model_files(path: &Path) -> Result<Vec<PathBuf>> {
    let text = crate::limits::read_text(path)?;
    let description = describe(&text, path)?;
    Ok(description
        .models
        .into_iter()
        .filter_map(|m| match m.source {
            Source::File(p) => Some(p),
            _ => None,
        })
        .collect())
}

/// A flat, square quad mesh in the xz plane centred on the origin, normal +y, `size` metres
/// along x and z, with UVs spanning 0..1. Used by `builtin:ground-plane`.
pub fn ground_plane(size: Vec2) -> Scene {
    let (hx, hz) = (size.x * 0.5, size.y * 0.5);
    let mesh = Mesh {
        name: "ground-plane".into(),
        positions: vec![
            Vec3::new(-hx, 0.0, -hz),
            Vec3::new(-hx, 0.0, hz),
            Vec3::new(hx, 0.0, hz),
            Vec3::new(hx, 0.0, -hz),
        ],
        normals: vec![Vec3::Y; 4],
        uvs: vec![Vec2::ZERO, Vec2::Y, Vec2::ONE, Vec2::X],
        // Counter-clockwise seen from +y.
        indices: vec![0, 1, 2, 0, 2, 3],
        material: 0,
    };
    Scene {
        name: "ground-plane".into(),
        meshes: vec![mesh],
        materials: vec![Material {
            name: "ground".into(),
            ..Material::default()
        }],
        objects: vec![Object {
            name: "ground-plane".into(),
            meshes: vec![0],
            transform: Mat4::IDENTITY,
            animation: None,
        }],
        ..Scene::default()
    }
}

// ---------------------------------------------------------------------------------------------
// Raw TOML shapes.

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFile {
    name: Option<String>,
    #[serde(default)]
    exposure: f32,
    unit: Option<f32>,
    #[serde(default)]
    settings: toml::Table,
    #[serde(default, rename = "model")]
    models: Vec<RawModel>,
    #[serde(default, rename = "light")]
    lights: Vec<RawLight>,
    #[serde(default, rename = "camera")]
    cameras: Vec<RawCamera>,
    sky: Option<RawSky>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSky {
    color: Option<[f32; 3]>,
    map: Option<String>,
    intensity: Option<f32>,
    rotate: Option<RawRotation>,
    directions: Option<u32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawModel {
    path: String,
    name: Option<String>,
    scale: Option<RawScale>,
    rotate: Option<RawRotation>,
    translate: Option<[f32; 3]>,
    pivot: Option<[f32; 3]>,
    transform: Option<[[f32; 4]; 4]>,
    objects: Option<Vec<String>>,
    materials: Option<Vec<String>>,
    exclude_objects: Option<Vec<String>>,
    exclude_materials: Option<Vec<String>>,
    size: Option<RawScale2>,
    material: Option<RawMaterial>,
    #[serde(default, rename = "loop")]
    looping: bool,
    #[serde(default)]
    animation: Vec<RawKey>,
}

#[derive(Deserialize)]
#[serde(untagged, expecting = "a number or an array [x, y, z]")]
enum RawScale {
    Uniform(f32),
    Axes([f32; 3]),
}

#[derive(Deserialize)]
#[serde(untagged, expecting = "a number or an array [x, z]")]
enum RawScale2 {
    Square(f32),
    Sides([f32; 2]),
}

#[derive(Deserialize)]
#[serde(
    untagged,
    expecting = "Euler angles [x, y, z] in degrees or { axis = [x, y, z], angle = degrees }"
)]
enum RawRotation {
    Euler([f32; 3]),
    AxisAngle(RawAxisAngle),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawAxisAngle {
    axis: [f32; 3],
    angle: f32,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMaterial {
    albedo: Option<[f32; 3]>,
    emission: Option<[f32; 3]>,
    two_sided: Option<bool>,
    texture: Option<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawKey {
    time: f32,
    translate: Option<[f32; 3]>,
    rotate: Option<RawRotation>,
}

#[derive(Deserialize, Clone, Copy, PartialEq, Debug)]
#[serde(rename_all = "lowercase")]
enum RawLightType {
    Point,
    Spot,
    Directional,
}

impl RawLightType {
    fn word(self) -> &'static str {
        match self {
            RawLightType::Point => "point",
            RawLightType::Spot => "spot",
            RawLightType::Directional => "directional",
        }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawLight {
    #[serde(rename = "type")]
    kind: RawLightType,
    name: Option<String>,
    position: Option<[f32; 3]>,
    direction: Option<[f32; 3]>,
    target: Option<[f32; 3]>,
    color: Option<[f32; 3]>,
    intensity: f32,
    inner_angle: Option<f32>,
    outer_angle: Option<f32>,
    #[serde(default, rename = "loop")]
    looping: bool,
    #[serde(default)]
    animation: Vec<RawKey>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCamera {
    name: Option<String>,
    position: [f32; 3],
    target: [f32; 3],
    up: Option<[f32; 3]>,
    fov: Option<f32>,
    fov_axis: Option<String>,
    near: Option<f32>,
    far: Option<f32>,
    #[serde(default, rename = "loop")]
    looping: bool,
    #[serde(default)]
    animation: Vec<RawKey>,
}

// ---------------------------------------------------------------------------------------------
// Checked description.

enum Source {
    CornellBox,
    GroundPlane(Vec2),
    File(PathBuf),
}

struct ModelSpec {
    label: String,
    name: Option<String>,
    source: Source,
    /// Rest placement: translate * rotate * scale * translate(-pivot).
    rotation: Quat,
    scale: Vec3,
    translate: Vec3,
    pivot: Vec3,
    /// A whole placement given as a matrix, replacing the four above.
    matrix: Option<Mat4>,
    /// Which objects and meshes of the model to keep.
    selection: Selection,
    albedo: Option<Vec3>,
    emission: Option<Vec3>,
    /// Whether the emission leaves both faces.
    two_sided: Option<bool>,
    /// Base-colour texture replacing the model's (the albedo, or white, modulates it).
    texture: Option<PathBuf>,
    animation: Option<Track>,
}

struct Description {
    name: String,
    exposure: f32,
    /// Metres per scene unit.
    unit: f32,
    settings: toml::Table,
    models: Vec<ModelSpec>,
    lights: Vec<Light>,
    cameras: Vec<Camera>,
    sky: Option<Sky>,
}

/// An error about `path` with a message.
fn bad(path: &Path, message: impl Into<String>) -> Error {
    Error::parse(path, message)
}

/// 1-based line and column of byte `offset` in `text`.
fn line_column(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..offset.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, column)
}

fn vec3(v: [f32; 3], what: &str, path: &Path) -> Result<Vec3> {
    let v = Vec3::from(v);
    if v.is_finite() {
        Ok(v)
    } else {
        Err(not_finite(path, what, v))
    }
}

/// The error for a value that is NaN or infinite, saying why a large number reads as inf.
fn not_finite(path: &Path, what: &str, value: impl std::fmt::Display) -> Error {
    bad(
        path,
        format!(
            "{what}: {value} is not finite (NaN or inf; a number beyond +-3.4e38, the range of \
             32-bit floats, reads as inf)"
        ),
    )
}

fn finite(x: f32, what: &str, path: &Path) -> Result<f32> {
    if x.is_finite() {
        Ok(x)
    } else {
        Err(not_finite(path, what, x))
    }
}

fn rotation(r: &RawRotation, what: &str, path: &Path) -> Result<Quat> {
    match r {
        RawRotation::Euler(angles) => {
            let a = vec3(*angles, what, path)?;
            // Applied about the fixed world axes in the order x, y, z.
            Ok(Quat::from_rotation_z(a.z.to_radians())
                * Quat::from_rotation_y(a.y.to_radians())
                * Quat::from_rotation_x(a.x.to_radians()))
        }
        RawRotation::AxisAngle(aa) => {
            let axis = vec3(aa.axis, &format!("{what}.axis"), path)?;
            let angle = finite(aa.angle, &format!("{what}.angle"), path)?;
            let axis = axis
                .try_normalize()
                .ok_or_else(|| bad(path, format!("{what}.axis is the zero vector")))?;
            Ok(Quat::from_axis_angle(axis, angle.to_radians()))
        }
    }
}

/// Builds a track whose keys are `rest_translation + key.translate` and `key.rotate`.
fn track(
    keys: &[RawKey],
    looping: bool,
    rest_translation: Vec3,
    what: &str,
    path: &Path,
) -> Result<Option<Track>> {
    if keys.is_empty() {
        if looping {
            return Err(bad(
                path,
                format!("{what}: `loop` is set but there are no animation keys"),
            ));
        }
        return Ok(None);
    }
    let mut out = Vec::with_capacity(keys.len());
    for (i, key) in keys.iter().enumerate() {
        let label = format!("{what}.animation[{i}]");
        let time = finite(key.time, &format!("{label}.time"), path)?;
        if out.iter().any(|k: &Keyframe| k.time == time) {
            return Err(bad(path, format!("{label}: two keys at time {time} s")));
        }
        let translate = match key.translate {
            Some(t) => vec3(t, &format!("{label}.translate"), path)?,
            None => Vec3::ZERO,
        };
        let rotate = match &key.rotate {
            Some(r) => rotation(r, &format!("{label}.rotate"), path)?,
            None => Quat::IDENTITY,
        };
        out.push(Keyframe {
            time,
            translation: rest_translation + translate,
            rotation: rotate,
        });
    }
    Ok(Track::new(out, looping))
}

fn describe(text: &str, path: &Path) -> Result<Description> {
    let raw: RawFile = toml::from_str(text).map_err(|e| {
        let message = e.message().trim_end().to_string();
        match e.span() {
            Some(span) => {
                let (line, column) = line_column(text, span.start);
                bad(path, format!("line {line}, column {column}: {message}"))
            }
            None => bad(path, message),
        }
    })?;
    let name = match raw.name {
        Some(n) => n,
        None => path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "scene".into()),
    };
    let exposure = finite(raw.exposure, "exposure", path)?;
    let unit = finite(raw.unit.unwrap_or(1.0), "unit", path)?;
    if unit <= 0.0 {
        return Err(bad(
            path,
            format!("unit (metres per scene unit) must be positive, got {unit}"),
        ));
    }
    let base = path.parent().unwrap_or(Path::new("."));
    let models = raw
        .models
        .iter()
        .enumerate()
        .map(|(i, m)| describe_model(i, m, base, path))
        .collect::<Result<Vec<_>>>()?;
    let lights = raw
        .lights
        .iter()
        .enumerate()
        .map(|(i, l)| describe_light(i, l, path))
        .collect::<Result<Vec<_>>>()?;
    let cameras = raw
        .cameras
        .iter()
        .enumerate()
        .map(|(i, c)| describe_camera(i, c, path))
        .collect::<Result<Vec<_>>>()?;
    let sky = match &raw.sky {
        Some(sky) => Some(describe_sky(sky, base, path)?),
        None => None,
    };
    Ok(Description {
        name,
        exposure,
        unit,
        settings: raw.settings,
        models,
        lights,
        cameras,
        sky,
    })
}

fn describe_sky(raw: &RawSky, base: &Path, path: &Path) -> Result<Sky> {
    let mut sky = match (&raw.color, &raw.map) {
        (Some(c), None) => {
            let c = vec3(*c, "sky.color", path)?;
            if c.min_element() < 0.0 {
                return Err(bad(
                    path,
                    format!("sky.color must not be negative, got {c}"),
                ));
            }
            Sky::constant(c)
        }
        (None, Some(map)) => {
            let file = resolve_file(map, "sky.map", base, path)?;
            Sky::map(EnvironmentMap::load(&file)?)
        }
        _ => {
            return Err(bad(
                path,
                "sky: give either `color` (constant radiance) or `map` (an equirectangular \
                 .hdr or .exr file)",
            ))
        }
    };
    if let Some(i) = raw.intensity {
        let i = finite(i, "sky.intensity", path)?;
        if i < 0.0 {
            return Err(bad(
                path,
                format!("sky.intensity must not be negative, got {i}"),
            ));
        }
        sky.intensity = i;
    }
    if let Some(r) = &raw.rotate {
        sky.to_world = Mat3::from_quat(rotation(r, "sky.rotate", path)?);
    }
    if let Some(n) = raw.directions {
        if n == 0 || n > Sky::MAX_DIRECTIONS {
            return Err(bad(
                path,
                format!(
                    "sky.directions must be within 1..={}, got {n}",
                    Sky::MAX_DIRECTIONS
                ),
            ));
        }
        sky.directions = n;
    }
    Ok(sky)
}

/// A file named in the scene file: relative to the scene file's folder, or `scenes:...`.
fn resolve_file(name: &str, what: &str, base: &Path, path: &Path) -> Result<PathBuf> {
    let file = match name.strip_prefix(SCENES_PREFIX) {
        Some(rel) => in_scenes_dir(rel, &super::scenes_dir(), what, path)?,
        None => base.join(name),
    };
    if !file.is_file() {
        return Err(bad(
            path,
            format!("{what} '{name}' not found (looked for {})", file.display()),
        ));
    }
    Ok(file)
}

fn resolve_source(model: &RawModel, what: &str, base: &Path, path: &Path) -> Result<Source> {
    let p = model.path.trim();
    if model.size.is_some() && p != "builtin:ground-plane" {
        return Err(bad(
            path,
            format!("{what}.size is only for builtin:ground-plane"),
        ));
    }
    if let Some(builtin) = p.strip_prefix(BUILTIN_PREFIX) {
        let source = match builtin {
            "cornell-box" => Source::CornellBox,
            "ground-plane" => {
                let size = match model.size {
                    None => Vec2::splat(10.0),
                    Some(RawScale2::Square(s)) => Vec2::splat(s),
                    Some(RawScale2::Sides(s)) => Vec2::from(s),
                };
                if !size.is_finite() || size.min_element() <= 0.0 {
                    return Err(bad(
                        path,
                        format!("{what}.size must be positive and finite, got {size}"),
                    ));
                }
                Source::GroundPlane(size)
            }
            other => {
                return Err(bad(
                    path,
                    format!(
                        "{what}: unknown built-in model '{other}' \
                         (expected builtin:cornell-box or builtin:ground-plane)"
                    ),
                ))
            }
        };
        return Ok(source);
    }
    let file = if let Some(rel) = p.strip_prefix(SCENES_PREFIX) {
        in_scenes_dir(rel, &super::scenes_dir(), what, path)?
    } else {
        base.join(p)
    };
    if !file.is_file() {
        return Err(bad(
            path,
            format!(
                "{what}: model file '{p}' not found (looked for {})",
                file.display()
            ),
        ));
    }
    let lower = p.to_lowercase();
    if lower.ends_with(".toml") {
        return Err(bad(
            path,
            format!(
                "{what}: '{p}' is a scene file; models must be .obj, .ply, .ply.gz, .gltf, .glb or .xml"
            ),
        ));
    }
    Ok(Source::File(file))
}

/// `rel` inside the shared scenes folder `dir`, which must exist.
fn in_scenes_dir(rel: &str, dir: &Path, what: &str, path: &Path) -> Result<PathBuf> {
    if !dir.is_dir() {
        return Err(bad(
            path,
            format!(
                "{what}: '{SCENES_PREFIX}{rel}' needs the shared scenes folder, which was not \
                 found at {}; set {SCENES_ENV} to the folder that holds the test scenes",
                dir.display()
            ),
        ));
    }
    Ok(dir.join(rel.trim_start_matches(['/', '\\'])))
}

/// A model's `transform`: four rows of an affine matrix (as scene formats write them), finite,
/// invertible, with the last row [0, 0, 0, 1]; it replaces `translate`, `rotate`, `scale` and
/// `pivot` and takes no animation.
fn placement_matrix(m: &RawModel, rows: [[f32; 4]; 4], what: &str, path: &Path) -> Result<Mat4> {
    let clash = [
        ("translate", m.translate.is_some()),
        ("rotate", m.rotate.is_some()),
        ("scale", m.scale.is_some()),
        ("pivot", m.pivot.is_some()),
        ("animation", !m.animation.is_empty()),
    ];
    if let Some((name, _)) = clash.iter().find(|(_, given)| *given) {
        return Err(bad(
            path,
            format!("{what}: `transform` replaces the placement; it cannot take `{name}` too"),
        ));
    }
    let matrix = Mat4::from_cols_array_2d(&rows).transpose();
    if !matrix.is_finite() {
        return Err(bad(path, format!("{what}.transform is not finite")));
    }
    if rows[3] != [0.0, 0.0, 0.0, 1.0] {
        return Err(bad(
            path,
            format!(
                "{what}.transform must be affine: its last row must be [0, 0, 0, 1], got {:?}",
                rows[3]
            ),
        ));
    }
    if matrix.determinant().abs() < 1e-12 {
        return Err(bad(path, format!("{what}.transform is singular")));
    }
    Ok(matrix)
}

fn describe_model(index: usize, m: &RawModel, base: &Path, path: &Path) -> Result<ModelSpec> {
    let what = format!("model[{index}] ({})", m.path);
    let source = resolve_source(m, &what, base, path)?;
    let scale = match m.scale {
        None => Vec3::ONE,
        Some(RawScale::Uniform(s)) => Vec3::splat(finite(s, &format!("{what}.scale"), path)?),
        Some(RawScale::Axes(s)) => vec3(s, &format!("{what}.scale"), path)?,
    };
    if scale.abs().min_element() == 0.0 {
        return Err(bad(
            path,
            format!("{what}.scale must not be zero (got {scale})"),
        ));
    }
    let rotation = match &m.rotate {
        Some(r) => rotation(r, &format!("{what}.rotate"), path)?,
        None => Quat::IDENTITY,
    };
    let translate = match m.translate {
        Some(t) => vec3(t, &format!("{what}.translate"), path)?,
        None => Vec3::ZERO,
    };
    let pivot = match m.pivot {
        Some(p) => vec3(p, &format!("{what}.pivot"), path)?,
        None => Vec3::ZERO,
    };
    let texture = match m.material.as_ref().and_then(|mat| mat.texture.as_deref()) {
        None => None,
        Some(t) => Some(resolve_file(
            t,
            &format!("{what}.material.texture"),
            base,
            path,
        )?),
    };
    let (albedo, emission) = match &m.material {
        None => (None, None),
        Some(mat) => {
            let albedo = match mat.albedo {
                Some(a) => {
                    let a = vec3(a, &format!("{what}.material.albedo"), path)?;
                    if a.min_element() < 0.0 || a.max_element() > 1.0 {
                        return Err(bad(
                            path,
                            format!("{what}.material.albedo must lie in [0, 1], got {a}"),
                        ));
                    }
                    Some(a)
                }
                None => None,
            };
            let emission = match mat.emission {
                Some(e) => {
                    let e = vec3(e, &format!("{what}.material.emission"), path)?;
                    if e.min_element() < 0.0 {
                        return Err(bad(
                            path,
                            format!("{what}.material.emission must not be negative, got {e}"),
                        ));
                    }
                    Some(e)
                }
                None => None,
            };
            (albedo, emission)
        }
    };
    let matrix = match m.transform {
        None => None,
        Some(rows) => Some(placement_matrix(m, rows, &what, path)?),
    };
    let animation = track(&m.animation, m.looping, translate, &what, path)?;
    Ok(ModelSpec {
        label: what,
        name: m.name.clone(),
        source,
        rotation,
        scale,
        translate,
        pivot,
        matrix,
        selection: Selection {
            objects: m.objects.clone(),
            materials: m.materials.clone(),
            exclude_objects: m.exclude_objects.clone().unwrap_or_default(),
            exclude_materials: m.exclude_materials.clone().unwrap_or_default(),
        },
        albedo,
        emission,
        two_sided: m.material.as_ref().and_then(|mat| mat.two_sided),
        texture,
        animation,
    })
}

fn describe_light(index: usize, l: &RawLight, path: &Path) -> Result<Light> {
    let name = l.name.clone().unwrap_or_else(|| format!("light-{index}"));
    let what = format!("light[{index}] ('{name}')");
    let intensity = finite(l.intensity, &format!("{what}.intensity"), path)?;
    if intensity < 0.0 {
        return Err(bad(
            path,
            format!("{what}.intensity must not be negative, got {intensity}"),
        ));
    }
    let color = match l.color {
        Some(c) => vec3(c, &format!("{what}.color"), path)?,
        None => Vec3::ONE,
    };
    if color.min_element() < 0.0 {
        return Err(bad(
            path,
            format!("{what}.color must not be negative, got {color}"),
        ));
    }
    let position = match l.position {
        Some(p) => Some(vec3(p, &format!("{what}.position"), path)?),
        None => None,
    };
    let target = match l.target {
        Some(p) => Some(vec3(p, &format!("{what}.target"), path)?),
        None => None,
    };
    let direction = match l.direction {
        Some(d) => Some(vec3(d, &format!("{what}.direction"), path)?),
        None => None,
    };
    if l.kind != RawLightType::Directional && position.is_none() {
        return Err(bad(
            path,
            format!("{what}: a {} light needs a position", l.kind.word()),
        ));
    }
    let direction = match (l.kind, direction, target) {
        (_, Some(_), Some(_)) => {
            return Err(bad(
                path,
                format!("{what}: give either direction or target, not both"),
            ))
        }
        (RawLightType::Point, Some(_), _) | (RawLightType::Point, _, Some(_)) => {
            return Err(bad(
                path,
                format!("{what}: a point light has no direction or target"),
            ))
        }
        (RawLightType::Point, None, None) => Vec3::NEG_Y,
        (_, Some(d), None) => d,
        (_, None, Some(t)) => match position {
            Some(p) => t - p,
            None => {
                return Err(bad(
                    path,
                    format!("{what}: target needs a position; give a direction instead"),
                ))
            }
        },
        (_, None, None) => return Err(bad(path, format!("{what}: needs a direction or a target"))),
    };
    let direction = direction.try_normalize().ok_or_else(|| {
        bad(
            path,
            format!("{what}: direction is zero (or target equals position)"),
        )
    })?;
    let kind = match l.kind {
        RawLightType::Spot => {
            let outer = l.outer_angle.ok_or_else(|| {
                bad(
                    path,
                    format!("{what}: a spot light needs outer_angle (degrees)"),
                )
            })?;
            let outer = finite(outer, &format!("{what}.outer_angle"), path)?;
            let inner = finite(
                l.inner_angle.unwrap_or(outer),
                &format!("{what}.inner_angle"),
                path,
            )?;
            if !(outer > 0.0 && outer < 180.0) {
                return Err(bad(
                    path,
                    format!("{what}.outer_angle must lie in (0, 180) degrees, got {outer}"),
                ));
            }
            if !(0.0..=outer).contains(&inner) {
                return Err(bad(
                    path,
                    format!(
                        "{what}.inner_angle must lie in [0, outer_angle = {outer}] degrees, \
                         got {inner}"
                    ),
                ));
            }
            LightKind::Spot {
                inner_angle: inner.to_radians(),
                outer_angle: outer.to_radians(),
            }
        }
        other => {
            if l.inner_angle.is_some() || l.outer_angle.is_some() {
                return Err(bad(
                    path,
                    format!(
                        "{what}: inner_angle and outer_angle are for spot lights only, \
                         this one is {}",
                        other.word()
                    ),
                ));
            }
            if other == RawLightType::Point {
                LightKind::Point
            } else {
                LightKind::Directional
            }
        }
    };
    let position = position.unwrap_or(Vec3::ZERO);
    let animation = track(&l.animation, l.looping, position, &what, path)?;
    Ok(Light {
        name,
        kind,
        color,
        intensity,
        // An animated light rests at the origin; its keys carry the position.
        position: if animation.is_some() {
            Vec3::ZERO
        } else {
            position
        },
        direction,
        animation,
    })
}

fn describe_camera(index: usize, c: &RawCamera, path: &Path) -> Result<Camera> {
    let name = c.name.clone().unwrap_or_else(|| format!("camera-{index}"));
    let what = format!("camera[{index}] ('{name}')");
    let defaults = Camera::default();
    let position = vec3(c.position, &format!("{what}.position"), path)?;
    let target = vec3(c.target, &format!("{what}.target"), path)?;
    if (target - position).length_squared() == 0.0 {
        return Err(bad(path, format!("{what}: target equals position")));
    }
    let up = match c.up {
        Some(u) => vec3(u, &format!("{what}.up"), path)?,
        None => Vec3::Y,
    };
    let up = up
        .try_normalize()
        .ok_or_else(|| bad(path, format!("{what}.up is the zero vector")))?;
    let fov = finite(
        c.fov.unwrap_or(defaults.vfov.to_degrees()),
        &format!("{what}.fov"),
        path,
    )?;
    if !(fov > 0.0 && fov < 180.0) {
        return Err(bad(
            path,
            format!("{what}.fov must lie in (0, 180) degrees, got {fov}"),
        ));
    }
    let horizontal = match c.fov_axis.as_deref() {
        None | Some("vertical") | Some("y") => false,
        Some("horizontal") | Some("x") => true,
        Some(other) => {
            return Err(bad(
                path,
                format!("{what}.fov_axis must be \"vertical\" or \"horizontal\", got {other:?}"),
            ))
        }
    };
    let near = finite(
        c.near.unwrap_or(defaults.near),
        &format!("{what}.near"),
        path,
    )?;
    let far = finite(c.far.unwrap_or(defaults.far), &format!("{what}.far"), path)?;
    if !(near > 0.0 && far > near) {
        return Err(bad(
            path,
            format!("{what}: need 0 < near < far, got near = {near}, far = {far}"),
        ));
    }
    let animation = track(&c.animation, c.looping, position, &what, path)?;
    Ok(Camera {
        name,
        // An animated camera rests at the origin, looking along its rest view direction; the
        // keys carry its position.
        position: if animation.is_some() {
            Vec3::ZERO
        } else {
            position
        },
        target: if animation.is_some() {
            target - position
        } else {
            target
        },
        up,
        vfov: if horizontal {
            defaults.vfov
        } else {
            fov.to_radians()
        },
        hfov: horizontal.then(|| fov.to_radians()),
        near,
        far,
        animation,
    })
}

// ---------------------------------------------------------------------------------------------
// Building the scene.

fn build(description: Description, path: &Path, account: &Account) -> Result<Scene> {
    let mut scene = Scene {
        name: description.name,
        exposure: description.exposure,
        ..Scene::default()
    };
    // A model placed by many `[[model]]`s is read once, and its meshes are in the scene once
    // for each selection and material override: each placement adds only objects that share
    // them. Each placement is charged to the budget before it is added, so a model listed
    // thousands of times stops with an error, not after minutes and gigabytes.
    let mut files: HashMap<PathBuf, Scene> = HashMap::new();
    let mut templates: HashMap<String, Template> = HashMap::new();
    for model in &description.models {
        let key = model.template_key();
        if !templates.contains_key(&key) {
            let base = match &model.source {
                Source::CornellBox => cornell::geometry(),
                Source::GroundPlane(size) => ground_plane(*size),
                Source::File(file) => match files.get(file) {
                    Some(base) => base.clone(),
                    None => {
                        let loaded = Scene::load_model_within(file, account).map_err(|e| {
                            bad(
                                path,
                                format!("{}: could not load the model: {e}", model.label),
                            )
                        })?;
                        files.insert(file.clone(), loaded.clone());
                        loaded
                    }
                },
            };
            let part = prepare_model(base, model, path, account)?;
            templates.insert(key.clone(), Template::add(&mut scene, part));
        }
        let template = &templates[&key];
        let what = || format!("{}: {}", path.display(), model.label);
        account.charge(Resource::Instances, template.objects.len() as u64, what)?;
        account.charge(Resource::Triangles, template.triangles, what)?;
        place(&mut scene, template, model);
    }
    scene.lights.extend(description.lights);
    scene.cameras.extend(description.cameras);
    if description.sky.is_some() {
        scene.sky = description.sky;
    }
    Ok(scene)
}

/// A model as its `[[model]]`s place it: meshes already in the scene, objects (in model
/// space) that refer to them, and the lights and cameras that came with it.
struct Template {
    objects: Vec<Object>,
    lights: Vec<Light>,
    cameras: Vec<Camera>,
    /// Triangles of one placement.
    triangles: u64,
}

impl Template {
    /// Adds `part`'s meshes, materials and textures to `scene`; keeps its objects, lights and
    /// cameras for placing.
    fn add(scene: &mut Scene, mut part: Scene) -> Template {
        let triangles = part.triangle_count() as u64;
        let objects = std::mem::take(&mut part.objects);
        let lights = std::mem::take(&mut part.lights);
        let cameras = std::mem::take(&mut part.cameras);
        let ids = scene.merge(part);
        let objects = objects
            .into_iter()
            .map(|mut o| {
                o.meshes.iter_mut().for_each(|m| *m = ids[*m as usize]);
                o
            })
            .collect();
        Template {
            objects,
            lights,
            cameras,
            triangles,
        }
    }
}

impl ModelSpec {
    /// What makes two `[[model]]`s share their meshes: the same source, selection and
    /// material overrides (placement, animation and names may differ).
    fn template_key(&self) -> String {
        let source = match &self.source {
            Source::CornellBox => "builtin:cornell-box".to_string(),
            Source::GroundPlane(size) => format!("builtin:ground-plane {size}"),
            Source::File(file) => file.display().to_string(),
        };
        format!(
            "{source}|{:?}|{:?}|{:?}|{:?}|{:?}|{:?}|{:?}|{:?}|{:?}",
            self.selection.objects,
            self.selection.materials,
            self.selection.exclude_objects,
            self.selection.exclude_materials,
            self.albedo,
            self.emission,
            self.two_sided,
            self.texture,
            self.animation.is_some()
        )
    }
}

/// The parts of `part` that `model` keeps, with its material overrides applied.
fn prepare_model(
    mut part: Scene,
    model: &ModelSpec,
    path: &Path,
    account: &Account,
) -> Result<Scene> {
    if part.objects.is_empty() {
        // A loader that only returns meshes: one object holds them all.
        part.objects.push(Object {
            name: part.name.clone(),
            meshes: (0..part.meshes.len() as u32).collect(),
            transform: Mat4::IDENTITY,
            animation: None,
        });
    }
    select_parts(&mut part, &model.selection, &model.label, path)?;
    let texture = match &model.texture {
        Some(file) => {
            part.textures
                .push(super::Texture::load_within(file, account)?);
            Some(part.textures.len() as u32 - 1)
        }
        None => None,
    };
    for material in &mut part.materials {
        if let Some(albedo) = model.albedo {
            // The override is the colour, modulated by the override's texture if it has one.
            material.base_color = albedo;
            material.base_color_texture = None;
        }
        if let Some(t) = texture {
            if model.albedo.is_none() {
                material.base_color = Vec3::ONE;
            }
            material.base_color_texture = Some(t);
        }
        if let Some(emission) = model.emission {
            material.emission = emission;
        }
        if let Some(two_sided) = model.two_sided {
            material.emission_two_sided = two_sided;
        }
    }
    if model.animation.is_some() {
        if let Some(object) = part.objects.iter().find(|o| o.animation.is_some()) {
            return Err(bad(
                path,
                format!(
                    "{}: object '{}' is already animated in the model file; \
                     it cannot take a model animation too",
                    model.label, object.name
                ),
            ));
        }
    }
    Ok(part)
}

/// Adds one placement of `template` to `scene`: its objects placed and named as `model`
/// says, and the lights and cameras that came with the model placed with it.
fn place(scene: &mut Scene, template: &Template, model: &ModelSpec) {
    let animated = model.animation.is_some();
    // Rest placement; when animated the translation lives in the track's keys.
    let rest_translation = if animated {
        Vec3::ZERO
    } else {
        model.translate
    };
    let placement = model.matrix.unwrap_or_else(|| {
        Mat4::from_scale_rotation_translation(model.scale, model.rotation, rest_translation)
            * Mat4::from_translation(-model.pivot)
    });
    let single = template.objects.len() == 1;
    for template_object in &template.objects {
        let mut object = template_object.clone();
        if placement != Mat4::IDENTITY {
            object.transform = placement * object.transform;
        }
        if animated {
            object.animation = model.animation.clone();
        }
        if let Some(name) = &model.name {
            object.name = if single {
                name.clone()
            } else {
                format!("{name}/{}", object.name)
            };
        }
        scene.objects.push(object);
    }
    // Lights and cameras that come with a model (glTF) are placed with it.
    for light in &template.lights {
        let mut light = light.clone();
        light.position = placement.transform_point3(light.position);
        light.direction = placement
            .transform_vector3(light.direction)
            .normalize_or(light.direction);
        scene.lights.push(light);
    }
    for camera in &template.cameras {
        let mut camera = camera.clone();
        camera.position = placement.transform_point3(camera.position);
        camera.target = placement.transform_point3(camera.target);
        scene.cameras.push(camera);
    }
}

/// The parts of a model a `[[model]]` keeps: `objects` and `materials` keep only what they
/// name, `exclude_objects` and `exclude_materials` then drop what they name.
#[derive(Default)]
struct Selection {
    objects: Option<Vec<String>>,
    materials: Option<Vec<String>>,
    exclude_objects: Vec<String>,
    exclude_materials: Vec<String>,
}

impl Selection {
    fn is_everything(&self) -> bool {
        self.objects.is_none()
            && self.materials.is_none()
            && self.exclude_objects.is_empty()
            && self.exclude_materials.is_empty()
    }
}

/// Names for an error message: the first 20, then how many more.
fn name_list<'a>(names: impl IntoIterator<Item = &'a str>) -> String {
    const SHOWN: usize = 20;
    let mut unique: Vec<&str> = Vec::new();
    for name in names {
        if !unique.contains(&name) {
            unique.push(name);
        }
    }
    if unique.is_empty() {
        return "none".into();
    }
    let mut list = unique
        .iter()
        .take(SHOWN)
        .map(|n| format!("'{n}'"))
        .collect::<Vec<_>>()
        .join(", ");
    if unique.len() > SHOWN {
        list.push_str(&format!(" and {} more", unique.len() - SHOWN));
    }
    list
}

/// Applies a [`Selection`] to `part`: keeps the chosen objects and, in them, the meshes whose
/// material is chosen; objects left without meshes are dropped, and only the meshes still used
/// are kept. Every name must exist in the model (the error lists the names it has), and the
/// selection must leave something.
fn select_parts(part: &mut Scene, selection: &Selection, label: &str, path: &Path) -> Result<()> {
    if selection.is_everything() {
        return Ok(());
    }
    let object_names: Vec<String> = part.objects.iter().map(|o| o.name.clone()).collect();
    // Materials the model's objects use (a material no mesh uses is not a choice).
    let mut used = vec![false; part.materials.len()];
    for object in &part.objects {
        for &m in &object.meshes {
            if let Some(mesh) = part.meshes.get(m as usize) {
                if let Some(u) = used.get_mut(mesh.material as usize) {
                    *u = true;
                }
            }
        }
    }
    let material_names: Vec<String> = part
        .materials
        .iter()
        .zip(&used)
        .filter(|(_, &u)| u)
        .map(|(m, _)| m.name.clone())
        .collect();
    let check = |key: &str, names: &[String], known: &[String], what: &str| -> Result<()> {
        for name in names {
            if !known.contains(name) {
                return Err(bad(
                    path,
                    format!(
                        "{label}.{key}: no {what} named '{name}' (the model has: {})",
                        name_list(known.iter().map(|s| s.as_str()))
                    ),
                ));
            }
        }
        Ok(())
    };
    let no_names = Vec::new();
    let keep_objects = selection.objects.as_ref();
    let keep_materials = selection.materials.as_ref();
    check(
        "objects",
        keep_objects.unwrap_or(&no_names),
        &object_names,
        "object",
    )?;
    check(
        "exclude_objects",
        &selection.exclude_objects,
        &object_names,
        "object",
    )?;
    check(
        "materials",
        keep_materials.unwrap_or(&no_names),
        &material_names,
        "material",
    )?;
    check(
        "exclude_materials",
        &selection.exclude_materials,
        &material_names,
        "material",
    )?;

    let material_kept: Vec<bool> = part
        .materials
        .iter()
        .map(|m| {
            keep_materials.is_none_or(|keep| keep.contains(&m.name))
                && !selection.exclude_materials.contains(&m.name)
        })
        .collect();
    part.objects.retain(|o| {
        keep_objects.is_none_or(|keep| keep.contains(&o.name))
            && !selection.exclude_objects.contains(&o.name)
    });
    let mut remap = vec![u32::MAX; part.meshes.len()];
    let mut meshes = Vec::new();
    for object in &mut part.objects {
        let mut kept = Vec::with_capacity(object.meshes.len());
        for &m in &object.meshes {
            let old = m as usize;
            let Some(slot) = remap.get_mut(old) else {
                return Err(bad(
                    path,
                    format!("{label}: object '{}' refers to a missing mesh", object.name),
                ));
            };
            let mesh = &part.meshes[old];
            if !material_kept
                .get(mesh.material as usize)
                .copied()
                .unwrap_or(true)
            {
                continue;
            }
            if *slot == u32::MAX {
                *slot = meshes.len() as u32;
                meshes.push(mesh.clone());
            }
            kept.push(*slot);
        }
        object.meshes = kept;
    }
    part.objects.retain(|o| !o.meshes.is_empty());
    part.meshes = meshes;
    if part.objects.is_empty() {
        return Err(bad(
            path,
            format!(
                "{label}: the object and material selection leaves nothing of the model \
                 (objects: {}; materials: {})",
                name_list(object_names.iter().map(|s| s.as_str())),
                name_list(material_names.iter().map(|s| s.as_str()))
            ),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const PATH: &str = "/virtual/test-scene.toml";

    fn parse_err(text: &str) -> String {
        match parse(text, Path::new(PATH)) {
            Ok(_) => panic!("expected an error for:\n{text}"),
            Err(e) => e.to_string(),
        }
    }

    const BOX: &str = "[[model]]\npath = \"builtin:cornell-box\"\n";

    #[test]
    fn sky_table() {
        let scene = parse(
            &format!("{BOX}[sky]\ncolor = [0.5, 0.6, 0.7]\nintensity = 2.0\nrotate = [0, 90, 0]\ndirections = 12\n"),
            Path::new(PATH),
        )
        .unwrap();
        let sky = scene.sky.as_ref().unwrap();
        assert_eq!(sky.radiance(Vec3::Y), Vec3::new(1.0, 1.2, 1.4));
        assert_eq!(sky.directions, 12);
        assert!((sky.to_world * Vec3::X - Vec3::NEG_Z).length() < 1e-6);
        assert!(scene.has_light(), "a sky lights the scene");
        for (text, needle) in [
            ("color = [1, 1, 1]\nmap = \"x.hdr\"", "either `color`"),
            ("intensity = 1.0", "either `color`"),
            ("color = [-1, 1, 1]", "must not be negative"),
            (
                "color = [1, 1, 1]\nintensity = -2.0",
                "must not be negative",
            ),
            ("color = [1, 1, 1]\ndirections = 0", "1..=64"),
            ("color = [1, 1, 1]\ndirections = 65", "1..=64"),
            ("map = \"nowhere.hdr\"", "not found"),
            ("colour = [1, 1, 1]", "unknown field"),
        ] {
            let e = parse_err(&format!("{BOX}[sky]\n{text}\n"));
            assert!(e.contains(needle), "{text}: {e}");
        }
    }

    #[test]
    fn minimal_builtin_scene() {
        let scene = parse(BOX, Path::new(PATH)).unwrap();
        assert_eq!(scene.name, "test-scene");
        assert_eq!(scene.objects.len(), 3);
        assert_eq!(scene.triangle_count(), 30);
        assert!(scene.lights.is_empty() && scene.cameras.is_empty());
    }

    #[test]
    fn settings_are_kept_raw() {
        let text = format!("{BOX}[settings]\nlpv = {{ size = 32 }}\ntechnique = \"lpv\"\n");
        let (_, settings) = parse_with_settings(&text, Path::new(PATH)).unwrap();
        assert_eq!(settings["technique"].as_str(), Some("lpv"));
        assert_eq!(settings["lpv"]["size"].as_integer(), Some(32));
    }

    #[test]
    fn model_transform_is_translate_rotate_scale() {
        let text = "[[model]]\npath = \"builtin:ground-plane\"\nsize = [2.0, 4.0]\n\
                    scale = [2.0, 1.0, 1.0]\nrotate = { axis = [0.0, 1.0, 0.0], angle = 90.0 }\n\
                    translate = [0.0, 1.0, 0.0]\nname = \"floor\"\n";
        let scene = parse(text, Path::new(PATH)).unwrap();
        assert_eq!(scene.objects[0].name, "floor");
        let m = scene.objects[0].transform;
        // Corner (1, 0, 2) -> scaled (2, 0, 2) -> turned 90 degrees about y (x -> -z,
        // z -> x) -> (2, 0, -2) -> moved up.
        let p = m.transform_point3(Vec3::new(1.0, 0.0, 2.0));
        assert!((p - Vec3::new(2.0, 1.0, -2.0)).length() < 1e-5, "{p}");
    }

    #[test]
    fn euler_angles_apply_x_then_y_then_z() {
        let q = rotation(&RawRotation::Euler([90.0, 90.0, 0.0]), "r", Path::new(PATH)).unwrap();
        // +y turned 90 degrees about x is +z, then 90 about y is +x.
        assert!((q * Vec3::Y - Vec3::X).length() < 1e-6);
    }

    #[test]
    fn material_override() {
        let text = format!(
            "{BOX}material = {{ albedo = [0.5, 0.25, 0.125], emission = [1.0, 2.0, 3.0] }}\n"
        );
        let scene = parse(&text, Path::new(PATH)).unwrap();
        for m in &scene.materials {
            assert_eq!(m.base_color, Vec3::new(0.5, 0.25, 0.125));
            assert_eq!(m.emission, Vec3::new(1.0, 2.0, 3.0));
        }
    }

    #[test]
    fn object_selection_and_names() {
        let text = "[[model]]\npath = \"builtin:cornell-box\"\nobjects = [\"tall-block\"]\n\
                    [[model]]\npath = \"builtin:cornell-box\"\nname = \"box\"\n";
        let scene = parse(text, Path::new(PATH)).unwrap();
        let names: Vec<&str> = scene.objects.iter().map(|o| o.name.as_str()).collect();
        assert_eq!(
            names,
            [
                "tall-block",
                "box/room",
                "box/short-block",
                "box/tall-block"
            ]
        );
        assert_eq!(scene.meshes.len(), 1 + 5);
        assert_eq!(scene.meshes[0].name, "tall-block");
        let err = parse_err("[[model]]\npath = \"builtin:cornell-box\"\nobjects = [\"teapot\"]\n");
        assert!(
            err.contains("teapot") && err.contains("short-block"),
            "{err}"
        );
    }

    #[test]
    fn material_selection_and_exclusion() {
        // The room's red and green walls only.
        let text = "[[model]]\npath = \"builtin:cornell-box\"\nmaterials = [\"red\", \"green\"]\n";
        let scene = parse(text, Path::new(PATH)).unwrap();
        let names: Vec<&str> = scene.objects.iter().map(|o| o.name.as_str()).collect();
        assert_eq!(names, ["room"]);
        let meshes: Vec<&str> = scene.meshes.iter().map(|m| m.name.as_str()).collect();
        assert_eq!(meshes, ["red-wall", "green-wall"]);
        // Everything but the tall block and the green wall.
        let text = "[[model]]\npath = \"builtin:cornell-box\"\n\
                    exclude_objects = [\"tall-block\"]\nexclude_materials = [\"green\"]\n";
        let scene = parse(text, Path::new(PATH)).unwrap();
        let names: Vec<&str> = scene.objects.iter().map(|o| o.name.as_str()).collect();
        assert_eq!(names, ["room", "short-block"]);
        let meshes: Vec<&str> = scene.meshes.iter().map(|m| m.name.as_str()).collect();
        assert_eq!(meshes, ["walls", "red-wall", "short-block"]);
        // Keep and drop together: the blocks but not the short one.
        let text = "[[model]]\npath = \"builtin:cornell-box\"\n\
                    objects = [\"short-block\", \"tall-block\"]\n\
                    exclude_objects = [\"short-block\"]\n";
        let scene = parse(text, Path::new(PATH)).unwrap();
        assert_eq!(scene.objects.len(), 1);
        assert_eq!(scene.objects[0].name, "tall-block");
        assert_eq!(scene.meshes.len(), 1);
        // Unknown names are errors listing the model's names.
        let err = parse_err("[[model]]\npath = \"builtin:cornell-box\"\nmaterials = [\"glass\"]\n");
        assert!(
            err.contains("materials: no material named 'glass'")
                && err.contains("'white', 'red', 'green'"),
            "{err}"
        );
        let err = parse_err(
            "[[model]]\npath = \"builtin:cornell-box\"\nexclude_objects = [\"teapot\"]\n",
        );
        assert!(
            err.contains("exclude_objects: no object named 'teapot'") && err.contains("'room'"),
            "{err}"
        );
        // A selection that leaves nothing.
        let err = parse_err(
            "[[model]]\npath = \"builtin:cornell-box\"\nobjects = [\"tall-block\"]\n\
             exclude_materials = [\"white\"]\n",
        );
        assert!(err.contains("leaves nothing"), "{err}");
    }

    #[test]
    fn long_name_lists_are_cut() {
        let names: Vec<String> = (0..25).map(|i| format!("g{i}")).collect();
        let list = name_list(names.iter().map(|s| s.as_str()));
        assert!(list.starts_with("'g0', 'g1'"), "{list}");
        assert!(list.contains("'g19'") && !list.contains("'g20'"), "{list}");
        assert!(list.ends_with(" and 5 more"), "{list}");
        assert_eq!(name_list(["a", "a", "b"]), "'a', 'b'");
    }

    #[test]
    fn light_target_becomes_direction() {
        let text = format!(
            "{BOX}[[light]]\ntype = \"spot\"\nposition = [0.0, 2.0, 0.0]\n\
             target = [2.0, 0.0, 0.0]\nintensity = 3.0\ninner_angle = 10.0\nouter_angle = 20.0\n"
        );
        let scene = parse(&text, Path::new(PATH)).unwrap();
        let light = &scene.lights[0];
        assert_eq!(light.name, "light-0");
        assert_eq!(light.color, Vec3::ONE);
        let expected = Vec3::new(1.0, -1.0, 0.0).normalize();
        assert!((light.direction - expected).length() < 1e-6);
        assert_eq!(
            light.kind,
            LightKind::Spot {
                inner_angle: 10f32.to_radians(),
                outer_angle: 20f32.to_radians()
            }
        );
    }

    #[test]
    fn animated_light_turns_about_its_position() {
        let text = format!(
            "{BOX}[[light]]\ntype = \"spot\"\nposition = [1.0, 2.0, 3.0]\n\
             direction = [0.0, -1.0, 0.0]\nintensity = 1.0\nouter_angle = 30.0\n\
             [[light.animation]]\ntime = 0.0\n\
             [[light.animation]]\ntime = 2.0\ntranslate = [1.0, 0.0, 0.0]\n\
             rotate = [0.0, 0.0, 90.0]\n"
        );
        let scene = parse(&text, Path::new(PATH)).unwrap();
        let at0 = scene.lights[0].at_time(0.0);
        assert!((at0.position - Vec3::new(1.0, 2.0, 3.0)).length() < 1e-6);
        let at1 = scene.lights[0].at_time(1.0);
        assert!((at1.position - Vec3::new(1.5, 2.0, 3.0)).length() < 1e-6);
        // Halfway: 45 degrees about z turns -y towards +x.
        let h = std::f32::consts::FRAC_1_SQRT_2;
        assert!((at1.direction - Vec3::new(h, -h, 0.0)).length() < 1e-5);
        // Not looping: holds the last key.
        let at9 = scene.lights[0].at_time(9.0);
        assert!((at9.position - Vec3::new(2.0, 2.0, 3.0)).length() < 1e-6);
        assert!((at9.direction - Vec3::X).length() < 1e-5);
    }

    #[test]
    fn animated_camera_keeps_its_view_direction() {
        let text = format!(
            "{BOX}[[camera]]\nposition = [0.0, 1.0, 5.0]\ntarget = [0.0, 1.0, 0.0]\n\
             loop = true\n[[camera.animation]]\ntime = 0.0\n\
             [[camera.animation]]\ntime = 1.0\ntranslate = [0.0, 0.0, -2.0]\n"
        );
        let scene = parse(&text, Path::new(PATH)).unwrap();
        let c = scene.cameras[0].at_time(1.5);
        assert!((c.position - Vec3::new(0.0, 1.0, 4.0)).length() < 1e-6);
        assert!((c.target - Vec3::new(0.0, 1.0, -1.0)).length() < 1e-6);
        assert_eq!(scene.cameras[0].vfov, 45f32.to_radians());
    }

    #[test]
    fn unknown_key_is_named_with_its_line() {
        let err =
            parse_err("name = \"x\"\n[[model]]\npath = \"builtin:cornell-box\"\ncolour = 1\n");
        assert!(err.contains(PATH), "{err}");
        assert!(err.contains("colour"), "{err}");
        assert!(err.contains("line 4"), "{err}");
        let err = parse_err(&format!("{BOX}[[light]]\ntype = \"point\"\nposition = [0.0, 0.0, 0.0]\nintensity = 1.0\nradius = 2.0\n"));
        assert!(err.contains("radius"), "{err}");
        let err = parse_err("exposur = 1.0\n");
        assert!(err.contains("exposur") && err.contains("line 1"), "{err}");
    }

    #[test]
    fn malformed_toml_names_the_line() {
        let err = parse_err("name = \"x\"\n\n[[model]\npath = 1\n");
        assert!(err.contains(PATH) && err.contains("line 3"), "{err}");
        let err = parse_err("exposure = \"bright\"\n");
        assert!(err.contains("line 1"), "{err}");
    }

    #[test]
    fn missing_model_names_scene_and_model() {
        let err = parse_err("[[model]]\npath = \"models/nowhere.obj\"\n");
        assert!(err.contains(PATH), "{err}");
        assert!(err.contains("models/nowhere.obj"), "{err}");
        assert!(err.contains("not found"), "{err}");
        let err = parse_err("[[model]]\npath = \"builtin:teapot\"\n");
        assert!(err.contains("teapot"), "{err}");
    }

    #[test]
    fn bad_light_values() {
        let spot = |inner: &str, outer: &str, intensity: &str| {
            format!(
                "{BOX}[[light]]\ntype = \"spot\"\nname = \"s\"\nposition = [0.0, 1.0, 0.0]\n\
                 direction = [0.0, -1.0, 0.0]\nintensity = {intensity}\n\
                 inner_angle = {inner}\nouter_angle = {outer}\n"
            )
        };
        let err = parse_err(&spot("50.0", "40.0", "1.0"));
        assert!(err.contains("inner_angle") && err.contains("'s'"), "{err}");
        let err = parse_err(&spot("10.0", "180.0", "1.0"));
        assert!(err.contains("outer_angle"), "{err}");
        let err = parse_err(&spot("10.0", "0.0", "1.0"));
        assert!(err.contains("outer_angle"), "{err}");
        let err = parse_err(&spot("10.0", "40.0", "-2.0"));
        assert!(
            err.contains("intensity") && err.contains("negative"),
            "{err}"
        );
        let err = parse_err(&spot("10.0", "40.0", "nan"));
        assert!(err.contains("intensity") && err.contains("NaN"), "{err}");
        let err = parse_err(&spot("nan", "40.0", "1.0"));
        assert!(err.contains("inner_angle"), "{err}");
        let err = parse_err(&format!(
            "{BOX}[[light]]\ntype = \"area\"\nposition = [0.0, 1.0, 0.0]\nintensity = 1.0\n"
        ));
        assert!(err.contains("area") && err.contains("directional"), "{err}");
        let err = parse_err(&format!(
            "{BOX}[[light]]\ntype = \"point\"\nposition = [0.0, 1.0, 0.0]\nintensity = 1.0\nouter_angle = 20.0\n"
        ));
        assert!(err.contains("spot lights only"), "{err}");
        let err = parse_err(&format!(
            "{BOX}[[light]]\ntype = \"directional\"\ndirection = [0.0, 0.0, 0.0]\nintensity = 1.0\n"
        ));
        assert!(err.contains("zero"), "{err}");
        let err = parse_err(&format!(
            "{BOX}[[light]]\ntype = \"point\"\nposition = [0.0, nan, 0.0]\nintensity = 1.0\n"
        ));
        assert!(err.contains("position") && err.contains("NaN"), "{err}");
    }

    #[test]
    fn bad_model_values() {
        let err = parse_err(&format!("{BOX}scale = 0.0\n"));
        assert!(err.contains("scale") && err.contains("zero"), "{err}");
        let err = parse_err(&format!("{BOX}scale = [1.0, 0.0, 1.0]\n"));
        assert!(err.contains("zero"), "{err}");
        let err = parse_err(&format!("{BOX}scale = \"big\"\n"));
        assert!(err.contains("a number or an array"), "{err}");
        let err = parse_err(&format!("{BOX}translate = [0.0, inf, 0.0]\n"));
        assert!(
            err.contains("translate") && err.contains("not finite"),
            "{err}"
        );
        let err = parse_err(&format!(
            "{BOX}rotate = {{ axis = [0.0, 0.0, 0.0], angle = 3.0 }}\n"
        ));
        assert!(err.contains("zero vector"), "{err}");
        let err = parse_err(&format!("{BOX}material = {{ albedo = [2.0, 0.0, 0.0] }}\n"));
        assert!(err.contains("albedo"), "{err}");
        let err = parse_err(&format!("{BOX}size = 3.0\n"));
        assert!(err.contains("ground-plane"), "{err}");
        let err = parse_err(&format!("{BOX}loop = true\n"));
        assert!(err.contains("loop"), "{err}");
    }

    #[test]
    fn bad_camera_values() {
        let camera = |fov: &str, near: &str| {
            format!(
                "{BOX}[[camera]]\nposition = [0.0, 0.0, 1.0]\ntarget = [0.0, 0.0, 0.0]\n\
                 fov = {fov}\nnear = {near}\n"
            )
        };
        for fov in ["0.0", "180.0", "-5.0", "nan"] {
            let err = parse_err(&camera(fov, "0.1"));
            assert!(err.contains("fov"), "{err}");
        }
        let err = parse_err(&camera("40.0", "200.0"));
        assert!(err.contains("near"), "{err}");
    }

    #[test]
    fn model_transform_as_a_matrix() {
        // Rows as written: translate (0.1, 0.2, 0.3), 90 degrees about y, scale 2.
        let rows = "[[0.0, 0.0, 2.0, 0.1], [0.0, 2.0, 0.0, 0.2], [-2.0, 0.0, 0.0, 0.3], \
                    [0.0, 0.0, 0.0, 1.0]]";
        let scene = parse(&format!("{BOX}transform = {rows}\n"), Path::new(PATH)).unwrap();
        let same = parse(
            &format!("{BOX}scale = 2.0\nrotate = [0.0, 90.0, 0.0]\ntranslate = [0.1, 0.2, 0.3]\n"),
            Path::new(PATH),
        )
        .unwrap();
        for (a, b) in scene.objects.iter().zip(&same.objects) {
            assert!(
                a.transform.abs_diff_eq(b.transform, 1e-6),
                "{}",
                a.transform
            );
        }
        let err = parse_err(&format!(
            "{BOX}transform = {rows}\ntranslate = [0.0, 0.0, 0.0]\n"
        ));
        assert!(err.contains("translate"), "{err}");
        let err = parse_err(&format!(
            "{BOX}transform = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], \
             [0.0, 0.0, 1.0, 1.0]]\n"
        ));
        assert!(err.contains("affine"), "{err}");
        let err = parse_err(&format!(
            "{BOX}transform = [[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], \
             [0.0, 0.0, 0.0, 1.0]]\n"
        ));
        assert!(err.contains("singular"), "{err}");
    }

    #[test]
    fn unit_scales_the_whole_world() {
        // The same scene in units of half a metre and in metres.
        let scene = |unit: &str, k: f32| {
            let text = format!(
                "{unit}[[model]]\npath = \"builtin:cornell-box\"\nscale = {s}\n\
                 translate = [{t}, 0.0, 0.0]\n\
                 [[light]]\ntype = \"point\"\nintensity = 1.0\nposition = [{p}, {p}, {p}]\nloop = true\n\
                 [[light.animation]]\ntime = 0.0\n\
                 [[light.animation]]\ntime = 1.0\ntranslate = [{t}, 0.0, 0.0]\n\
                 [[camera]]\nposition = [0.0, 0.0, {c}]\ntarget = [0.0, 0.0, 0.0]\n\
                 near = {n}\nfar = {f}\n",
                s = 2.0 * k,
                t = 1.0 * k,
                p = 0.5 * k,
                c = 4.0 * k,
                n = 0.1 * k,
                f = 20.0 * k,
            );
            parse(&text, Path::new(PATH)).unwrap()
        };
        let feet = scene("unit = 0.5\n", 1.0);
        let metres = scene("", 0.5);
        for (a, b) in feet.objects.iter().zip(&metres.objects) {
            assert!(a.transform.abs_diff_eq(b.transform, 1e-6));
        }
        for t in [0.0, 0.5] {
            let (a, b) = (feet.lights[0].at_time(t), metres.lights[0].at_time(t));
            assert!(a.position.abs_diff_eq(b.position, 1e-6), "{t}: {a:?} {b:?}");
        }
        let (a, b) = (&feet.cameras[0], &metres.cameras[0]);
        assert!(a.position.abs_diff_eq(b.position, 1e-6));
        assert!((a.near - b.near).abs() < 1e-7 && (a.far - b.far).abs() < 1e-5);
        let bounds = |s: &Scene| s.bounds_at(0.0);
        assert!(bounds(&feet).1.abs_diff_eq(bounds(&metres).1, 1e-5));
        for bad in ["0.0", "-1.0", "nan"] {
            let err = parse_err(&format!("unit = {bad}\n{BOX}"));
            assert!(err.contains("unit"), "{err}");
        }
    }

    #[test]
    fn horizontal_field_of_view() {
        let text = |axis: &str| {
            format!(
                "{BOX}[[camera]]\nposition = [0.0, 0.0, 1.0]\ntarget = [0.0, 0.0, 0.0]\n\
                 fov = 60.0\nfov_axis = \"{axis}\"\n"
            )
        };
        let scene = parse(&text("horizontal"), Path::new(PATH)).unwrap();
        let camera = &scene.cameras[0];
        assert_eq!(camera.hfov, Some(60f32.to_radians()));
        // 200x100: the horizontal 60 degrees span 2 tan(30) across, so half as much vertically.
        let view = camera.view(200, 100);
        let vfov = 2.0 * (30f32.to_radians().tan() / 2.0).atan();
        let expected = glam::Mat4::perspective_rh(vfov, 2.0, camera.near, camera.far);
        assert!(view.proj.abs_diff_eq(expected, 1e-6), "{:?}", view.proj);
        let vertical = parse(&text("vertical"), Path::new(PATH)).unwrap();
        assert_eq!(vertical.cameras[0].hfov, None);
        assert_eq!(vertical.cameras[0].vfov, 60f32.to_radians());
        let err = parse_err(&text("diagonal"));
        assert!(err.contains("fov_axis"), "{err}");
    }

    #[test]
    fn scenes_prefix_needs_the_shared_folder() {
        // The folder is passed in rather than set through the environment, which other tests
        // running in parallel read.
        let err = in_scenes_dir(
            "a/b.obj",
            Path::new("/no/such/folder"),
            "model[0]",
            Path::new(PATH),
        )
        .unwrap_err()
        .to_string();
        assert!(
            err.contains(PATH) && err.contains("scenes:a/b.obj"),
            "{err}"
        );
        assert!(
            err.contains(SCENES_ENV) && err.contains("scenes folder"),
            "{err}"
        );
        if crate::scene::scenes_dir().is_dir() {
            let err = parse_err("[[model]]\npath = \"scenes:no-such-scene/x.obj\"\n");
            assert!(
                err.contains("no-such-scene/x.obj") && err.contains("not found"),
                "{err}"
            );
        }
    }

    #[test]
    fn ground_plane_faces_up() {
        let mut plane = ground_plane(Vec2::new(2.0, 3.0));
        super::super::validate(&mut plane).unwrap();
        let mesh = &plane.meshes[0];
        let [a, b, c] = [0, 1, 2].map(|i| mesh.positions[mesh.indices[i] as usize]);
        assert!((b - a).cross(c - a).normalize().dot(Vec3::Y) > 0.999);
        assert_eq!(plane.bounds_at(0.0).1, Vec3::new(1.0, 0.0, 1.5));
    }

    #[test]
    fn documented_example_is_valid() {
        let doc = include_str!("../../../../docs/scene-format.md");
        let start = doc.find("```toml\n").unwrap() + "```toml\n".len();
        let end = start + doc[start..].find("```").unwrap();
        let mut example = doc[start..end].to_string();
        if !crate::scene::scenes_dir().is_dir() {
            example = example.replace("scenes:stanford-bunny/bunny.ply", "builtin:cornell-box");
        }
        // The example's model file only has to exist for the description to be checked.
        let tmp = tempfile::Builder::new()
            .prefix("octolux-doc-example-")
            .tempdir()
            .unwrap();
        let dir = tmp.path();
        std::fs::create_dir_all(dir.join("models")).unwrap();
        std::fs::write(dir.join("models/statue.obj"), "").unwrap();
        std::fs::create_dir_all(dir.join("skies")).unwrap();
        std::fs::copy(
            concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/../../scenes/skies/afternoon.hdr"
            ),
            dir.join("skies/afternoon.hdr"),
        )
        .unwrap();
        let description = describe(&example, &dir.join("example.toml")).unwrap();
        assert_eq!(description.models.len(), 5);
        assert_eq!(description.lights.len(), 3);
        assert_eq!(description.cameras.len(), 1);
        assert_eq!(description.sky.as_ref().map(|s| s.directions), Some(32));
        assert!(description.settings["lpv"].is_table());
    }
}
