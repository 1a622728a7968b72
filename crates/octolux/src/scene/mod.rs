//! The scene model shared by the GPU renderer and the reference path tracer.
//!
//! Units are physical (docs/scene-format.md): lengths in metres, point and spot lights in radiant
//! intensity (W/sr), directional lights in irradiance (W/m^2), emissive surfaces in radiance
//! (W/(m^2 sr)), surfaces Lambertian with BRDF albedo/pi. Colours are linear RGB.
//!
//! A [`Scene`] is static data plus animation tracks; [`Scene::frame`] evaluates everything at
//! one instant into a [`SceneFrame`] that renderers consume.

mod animation;
mod camera;
pub mod cornell;
pub mod file;
mod fingerprint;
mod framing;
pub mod gltf;
pub mod mitsuba;
pub mod obj;
pub mod ply;
mod scenes_dir;
mod sky;
mod texture;
mod validate;

pub use animation::{Keyframe, Track};
pub use camera::{Camera, CameraView};
pub(crate) use framing::intersect_triangle;
pub use framing::ViewSurvey;
pub use scenes_dir::scenes_dir;
pub use sky::{direction_to_uv, uv_to_direction, EnvironmentMap, Sky, SkyRadiance};
pub use texture::{srgb_to_linear, Texture};
pub use validate::{validate, MAX_DEPTH_RATIO, MAX_EXPOSURE};

use crate::limits::{Account, Budget, Resource};
use crate::{Error, Result};
use glam::{Mat4, Vec2, Vec3};
use std::path::Path;

/// A triangle mesh with one material. Normals and UVs are per vertex (same length as
/// `positions`); `indices` holds three entries per triangle.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    /// Name for diagnostics.
    pub name: String,
    /// Object-space positions.
    pub positions: Vec<Vec3>,
    /// Object-space unit normals, one per position.
    pub normals: Vec<Vec3>,
    /// Texture coordinates, one per position (zeros when the source has none).
    pub uvs: Vec<Vec2>,
    /// Triangle list indices into the vertex arrays.
    pub indices: Vec<u32>,
    /// Index into [`Scene::materials`].
    pub material: u32,
}

impl Mesh {
    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }

    /// Fills `normals` with area-weighted vertex normals computed from the triangles. Indices
    /// not in threes or out of range are an error naming the mesh; the normals are then all
    /// +y, so that the mesh stays well-formed for [`validate`] to report.
    pub fn compute_normals(&mut self) -> Result<()> {
        let n = self.positions.len();
        let bad = if !self.indices.len().is_multiple_of(3) {
            Some(format!(
                "{} indices is not a multiple of 3",
                self.indices.len()
            ))
        } else {
            self.indices
                .iter()
                .find(|&&i| i as usize >= n)
                .map(|i| format!("index {i} out of range (the mesh has {n} vertices)"))
        };
        if let Some(problem) = bad {
            self.normals = vec![Vec3::Y; n];
            return Err(Error::scene(&self.name, problem));
        }
        let mut normals = vec![Vec3::ZERO; n];
        for tri in self.indices.chunks_exact(3) {
            let [a, b, c] = [tri[0] as usize, tri[1] as usize, tri[2] as usize];
            let n = (self.positions[b] - self.positions[a])
                .cross(self.positions[c] - self.positions[a]);
            normals[a] += n;
            normals[b] += n;
            normals[c] += n;
        }
        self.normals = normals
            .into_iter()
            .map(|n| n.try_normalize().unwrap_or(Vec3::Y))
            .collect();
        Ok(())
    }
}

/// How a material's alpha (base colour texture alpha x factor alpha) is used.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AlphaMode {
    /// Alpha ignored.
    Opaque,
    /// Texels with alpha below the cutoff are holes (foliage, chains).
    Mask(f32),
}

/// A Lambertian material with optional emission.
#[derive(Clone, Debug)]
pub struct Material {
    /// Name for diagnostics.
    pub name: String,
    /// Linear base colour (albedo) factor, multiplied with the texture when present.
    pub base_color: Vec3,
    /// Index into [`Scene::textures`]: sRGB base colour, alpha = coverage.
    pub base_color_texture: Option<u32>,
    /// Emitted radiance, W/(m^2 sr), linear RGB.
    pub emission: Vec3,
    /// Whether the back face emits too. By default only the front face does (the side the
    /// vertex normals point to), as glTF and Mitsuba define emission.
    pub emission_two_sided: bool,
    /// Coverage factor multiplied with the texture's alpha (1 = opaque). With
    /// [`AlphaMode::Mask`] a surface whose coverage is below the cutoff is a hole for every
    /// pass: this is how transmissive surfaces (glass, MTL `d`/`Tr`, glTF blend) are treated.
    pub opacity: f32,
    /// How alpha is used.
    pub alpha_mode: AlphaMode,
}

impl Material {
    /// Whether the surface is a hole everywhere, whatever its texture (a clear material:
    /// masked, with an opacity below the cutoff).
    pub fn is_clear(&self) -> bool {
        match self.alpha_mode {
            AlphaMode::Mask(cutoff) => self.opacity < cutoff,
            AlphaMode::Opaque => false,
        }
    }
}

impl Default for Material {
    fn default() -> Self {
        Material {
            name: "default".into(),
            base_color: Vec3::splat(0.8),
            base_color_texture: None,
            emission: Vec3::ZERO,
            emission_two_sided: false,
            opacity: 1.0,
            alpha_mode: AlphaMode::Opaque,
        }
    }
}

/// One placed instance of a set of meshes, optionally animated.
#[derive(Clone, Debug)]
pub struct Object {
    /// Name for diagnostics and scene files.
    pub name: String,
    /// Indices into [`Scene::meshes`].
    pub meshes: Vec<u32>,
    /// Object-to-world transform at rest.
    pub transform: Mat4,
    /// Animation applied on top of `transform` (world = track(t) * transform).
    pub animation: Option<Track>,
}

impl Object {
    /// Object-to-world transform at time `t` seconds.
    pub fn transform_at(&self, t: f32) -> Mat4 {
        match &self.animation {
            Some(track) => track.transform_at(t) * self.transform,
            None => self.transform,
        }
    }
}

/// Kind of light source.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LightKind {
    /// Omnidirectional point light; intensity in W/sr.
    Point,
    /// Spot light; intensity in W/sr on its axis, smooth falloff between the cone angles
    /// (half-angles, radians).
    Spot {
        /// Full intensity inside this half-angle.
        inner_angle: f32,
        /// Zero intensity outside this half-angle.
        outer_angle: f32,
    },
    /// Infinitely distant light; intensity is irradiance in W/m^2 on a surface facing it.
    Directional,
}

/// A punctual light source.
#[derive(Clone, Debug)]
pub struct Light {
    /// Name for diagnostics and scene files.
    pub name: String,
    /// Point, spot or directional.
    pub kind: LightKind,
    /// Linear colour; multiplied by `intensity`.
    pub color: Vec3,
    /// W/sr for point and spot lights, W/m^2 for directional lights.
    pub intensity: f32,
    /// World position (ignored for directional lights).
    pub position: Vec3,
    /// Unit direction the light travels in (spot axis, sun direction).
    pub direction: Vec3,
    /// Animation applied to position and direction.
    pub animation: Option<Track>,
}

impl Light {
    /// A point light at `position` of `color` x `intensity` W/sr.
    pub fn point(position: Vec3, color: Vec3, intensity: f32) -> Light {
        Light {
            name: "point".into(),
            kind: LightKind::Point,
            color,
            intensity,
            position,
            direction: Vec3::NEG_Y,
            animation: None,
        }
    }

    /// A spot light at `position` pointing along `direction`, `color` x `intensity` W/sr on
    /// its axis, full inside the half-angle `inner_angle` and dark outside `outer_angle`
    /// (radians).
    pub fn spot(
        position: Vec3,
        direction: Vec3,
        color: Vec3,
        intensity: f32,
        inner_angle: f32,
        outer_angle: f32,
    ) -> Light {
        Light {
            name: "spot".into(),
            kind: LightKind::Spot {
                inner_angle,
                outer_angle,
            },
            color,
            intensity,
            position,
            direction: direction.normalize_or(Vec3::NEG_Y),
            animation: None,
        }
    }

    /// A directional light travelling along `direction`, `color` x `irradiance` W/m^2 on a
    /// surface facing it.
    pub fn directional(direction: Vec3, color: Vec3, irradiance: f32) -> Light {
        Light {
            name: "sun".into(),
            kind: LightKind::Directional,
            color,
            intensity: irradiance,
            position: Vec3::ZERO,
            direction: direction.normalize_or(Vec3::NEG_Y),
            animation: None,
        }
    }

    /// Radiant intensity (W/sr) or irradiance (W/m^2) per colour channel.
    pub fn radiant(&self) -> Vec3 {
        self.color * self.intensity
    }

    /// Spot-cone attenuation for a unit direction `dir` leaving the light (1 for non-spots).
    /// Smoothstep in cos(angle) between the outer and inner cone; the GPU shader uses the same.
    pub fn spot_factor(&self, dir: Vec3) -> f32 {
        match self.kind {
            LightKind::Spot {
                inner_angle,
                outer_angle,
            } => spot_attenuation(
                self.direction.dot(dir),
                inner_angle.cos(),
                outer_angle.cos(),
            ),
            _ => 1.0,
        }
    }

    /// The light as it is at time `t` (animation applied, `animation` cleared).
    pub fn at_time(&self, t: f32) -> Light {
        let mut light = self.clone();
        if let Some(track) = &self.animation {
            let m = track.transform_at(t);
            light.position = m.transform_point3(self.position);
            light.direction = m
                .transform_vector3(self.direction)
                .normalize_or(self.direction);
        }
        light.animation = None;
        light
    }
}

/// Spot falloff: smoothstep from `cos_outer` (0) to `cos_inner` (1).
pub fn spot_attenuation(cos_angle: f32, cos_inner: f32, cos_outer: f32) -> f32 {
    let width = (cos_inner - cos_outer).max(1e-6);
    let x = ((cos_angle - cos_outer) / width).clamp(0.0, 1.0);
    x * x * (3.0 - 2.0 * x)
}

/// A complete scene: geometry, materials, lights, cameras, animation and exposure.
#[derive(Clone, Debug, Default)]
pub struct Scene {
    /// Scene name (file name or built-in name) for diagnostics.
    pub name: String,
    /// All meshes; objects refer to them by index.
    pub meshes: Vec<Mesh>,
    /// All materials; meshes refer to them by index.
    pub materials: Vec<Material>,
    /// All textures; materials refer to them by index.
    pub textures: Vec<Texture>,
    /// Placed (possibly animated) instances.
    pub objects: Vec<Object>,
    /// Light sources.
    pub lights: Vec<Light>,
    /// Cameras; renders use the first unless told otherwise.
    pub cameras: Vec<Camera>,
    /// Exposure in stops: pixel values are scaled by 2^exposure before tone mapping.
    pub exposure: f32,
    /// Environment light arriving from infinitely far away (none: the background is black).
    pub sky: Option<Sky>,
    /// What the scene file asks of the renderer beyond the scene itself (a Mitsuba
    /// integrator's depth, a sampler's sample count), so that a render that does otherwise
    /// can say what it uses instead.
    pub requests: Vec<FileRequest>,
}

/// A render setting a scene file asks for.
#[derive(Clone, Debug, PartialEq)]
pub struct FileRequest {
    /// Where it is asked: `file:line:column: <element>`.
    pub at: String,
    /// What is asked.
    pub asked: Asked,
}

/// What a [`FileRequest`] asks for.
#[derive(Clone, Debug, PartialEq)]
pub enum Asked {
    /// A light transport, with the file's own words for it (`max_depth 6`). `None`: emitters
    /// seen only (Mitsuba's `max_depth` 1), which no octolux setting renders.
    Bounces(Option<crate::transport::Bounces>, String),
    /// Samples per pixel.
    Spp(u32),
    /// An integrator octolux does not have (it path-traces, or runs a GI technique).
    Integrator(String),
}

/// One world-space triangle of a [`SceneFrame`], with everything shading needs.
#[derive(Clone, Copy, Debug)]
pub struct WorldTriangle {
    /// World positions.
    pub positions: [Vec3; 3],
    /// World unit normals per vertex.
    pub normals: [Vec3; 3],
    /// Texture coordinates per vertex.
    pub uvs: [Vec2; 3],
    /// Index into [`Scene::materials`].
    pub material: u32,
}

/// A scene evaluated at one instant: object transforms, lights and camera.
#[derive(Clone, Debug)]
pub struct SceneFrame {
    /// Time in seconds.
    pub time: f32,
    /// Object-to-world transform of each object, in [`Scene::objects`] order.
    pub object_transforms: Vec<Mat4>,
    /// Lights with animation applied.
    pub lights: Vec<Light>,
    /// The camera with animation applied.
    pub camera: Camera,
}

impl Scene {
    /// Whether any material emits light (an emissive surface).
    pub fn has_emissive_surfaces(&self) -> bool {
        self.materials
            .iter()
            .any(|m| m.emission.max_element() > 0.0)
    }

    /// Loads a scene or model file, choosing the loader by extension: `.toml` (scene file),
    /// `.xml` (Mitsuba 3 scene), `.gltf`/`.glb`, `.obj`, `.ply`, `.ply.gz`, within the default
    /// [`Budget`]. The result is validated. A scene without a camera gets one that looks into
    /// it ([`Scene::add_framing_camera`]).
    pub fn load(path: impl AsRef<Path>) -> Result<Scene> {
        Self::load_within(path, Budget::default())
    }

    /// [`Scene::load`] within `budget`: a scene that would pull in more triangles, instances,
    /// file reads, bytes or includes is an error naming the budget it passed.
    pub fn load_within(path: impl AsRef<Path>, budget: Budget) -> Result<Scene> {
        let mut scene = Self::load_model_within(path, &Account::new(budget))?;
        scene.add_framing_camera();
        Ok(scene)
    }

    /// Like [`Scene::load`] without the camera: for models that a scene file places.
    pub fn load_model(path: impl AsRef<Path>) -> Result<Scene> {
        Self::load_model_within(path, &Account::default())
    }

    /// [`Scene::load_model`], charging what the model pulls in to `account`; the whole model
    /// must fit the account's budget of triangles and instances.
    pub fn load_model_within(path: impl AsRef<Path>, account: &Account) -> Result<Scene> {
        let path = path.as_ref();
        if !path.exists() {
            return Err(Error::io(
                path,
                std::io::Error::new(std::io::ErrorKind::NotFound, "file not found"),
            ));
        }
        let name = path
            .file_name()
            .map(|s| s.to_string_lossy().to_lowercase())
            .unwrap_or_default();
        let mut scene = if name.ends_with(".toml") {
            file::load_within(path, account)?.0
        } else if name.ends_with(".xml") {
            mitsuba::load_within(path, account)?
        } else if name.ends_with(".gltf") || name.ends_with(".glb") {
            gltf::load_within(path, account)?
        } else if name.ends_with(".obj") {
            obj::load_within(path, account)?
        } else if name.ends_with(".ply") || name.ends_with(".ply.gz") {
            ply::load_within(path, account)?
        } else {
            return Err(Error::parse(
                path,
                "unknown scene format (expected .toml, .xml, .gltf, .glb, .obj, .ply or .ply.gz)",
            ));
        };
        // Scene files and Mitsuba scenes charge each placement as they add it; a single model
        // (a glTF whose nodes share a mesh, say) is checked whole here.
        let budget = account.budget();
        let (objects, triangles) = (scene.objects.len() as u64, scene.triangle_count() as u64);
        for (resource, count, cap) in [
            (Resource::Instances, objects, budget.instances),
            (Resource::Triangles, triangles, budget.triangles),
        ] {
            if count > cap {
                return Err(Error::parse(
                    path,
                    format!(
                        "the model has {} {}, more than the budget of {}; if it is meant to be \
                         this large, raise the budget with `--budget {}=N` \
                         (octolux::limits::Budget in the library)",
                        crate::limits::grouped(count),
                        resource.name(),
                        crate::limits::grouped(cap),
                        resource.name()
                    ),
                ));
            }
        }
        account.check()?;
        validate(&mut scene)?;
        Ok(scene)
    }

    /// Total triangle count over all object instances.
    pub fn triangle_count(&self) -> usize {
        self.objects
            .iter()
            .flat_map(|o| o.meshes.iter())
            .filter_map(|&m| self.meshes.get(m as usize))
            .map(Mesh::triangle_count)
            .sum()
    }

    /// Whether anything in the scene moves.
    pub fn is_animated(&self) -> bool {
        self.objects.iter().any(|o| o.animation.is_some())
            || self.lights.iter().any(|l| l.animation.is_some())
            || self.cameras.iter().any(|c| c.animation.is_some())
    }

    /// The scene at time `t` seconds, seen through camera `camera` (clamped to the last one; a
    /// default camera framing the scene bounds if there is none).
    /// Scales the whole world by `s` about the origin (a scene authored in other units: feet
    /// are 0.3048): object placements, light and camera positions, near and far planes, and the
    /// translations of their animations. Light intensities and directions are unchanged.
    pub fn scale_world(&mut self, s: f32) {
        let scale_track = |track: &mut Option<Track>| {
            if let Some(track) = track {
                for key in &mut track.keys {
                    key.translation *= s;
                }
            }
        };
        for object in &mut self.objects {
            object.transform = Mat4::from_scale(Vec3::splat(s)) * object.transform;
            scale_track(&mut object.animation);
        }
        for light in &mut self.lights {
            light.position *= s;
            scale_track(&mut light.animation);
        }
        for camera in &mut self.cameras {
            camera.position *= s;
            camera.target *= s;
            camera.near *= s;
            camera.far *= s;
            scale_track(&mut camera.animation);
        }
    }

    /// The index of camera `which`: a camera's index or its name. A scene without cameras is
    /// framed automatically and has only camera 0. Anything else is an error that lists the
    /// scene's cameras.
    pub fn camera_index(&self, which: &str) -> Result<usize> {
        let which = which.trim();
        let found = match which.parse::<usize>() {
            Ok(i) => Some(i),
            Err(_) => self.cameras.iter().position(|c| c.name == which),
        };
        match found {
            Some(i) => self.check_camera(i).map(|()| i),
            None => Err(self.no_camera(which)),
        }
    }

    /// Ok when the scene has camera `index` (a scene without cameras has camera 0 only).
    pub fn check_camera(&self, index: usize) -> Result<()> {
        if index < self.cameras.len().max(1) {
            Ok(())
        } else {
            Err(self.no_camera(&index.to_string()))
        }
    }

    fn no_camera(&self, which: &str) -> Error {
        let list = if self.cameras.is_empty() {
            "none (it is framed automatically: camera 0)".to_string()
        } else {
            self.cameras
                .iter()
                .enumerate()
                .map(|(i, c)| format!("{i} '{}'", c.name))
                .collect::<Vec<_>>()
                .join(", ")
        };
        Error::InvalidArgument(format!(
            "scene '{}' has no camera '{which}'; its cameras: {list}",
            self.name
        ))
    }

    /// The scene at time `t` seen from camera `camera` (the last camera when `camera` is out
    /// of range; [`Scene::camera_index`] checks a user's choice first).
    pub fn frame(&self, t: f32, camera: usize) -> SceneFrame {
        SceneFrame {
            time: t,
            object_transforms: self.objects.iter().map(|o| o.transform_at(t)).collect(),
            lights: self.lights.iter().map(|l| l.at_time(t)).collect(),
            camera: self.camera_at(t, camera),
        }
    }

    /// Camera `camera` at time `t` (the last camera when out of range, a camera framing the
    /// scene when it has none), as [`Scene::frame`] holds it.
    pub fn camera_at(&self, t: f32, camera: usize) -> Camera {
        match self
            .cameras
            .get(camera.min(self.cameras.len().saturating_sub(1)))
        {
            Some(c) => c.at_time(t),
            None => Camera::framing(self.bounds_at(t)),
        }
    }

    /// World-space axis-aligned bounds (min, max) of all geometry at time `t`.
    pub fn bounds_at(&self, t: f32) -> (Vec3, Vec3) {
        self.bounds_where(t, |_| true)
    }

    /// [`Scene::bounds_at`] of the objects `keep` accepts.
    pub fn bounds_where(&self, t: f32, keep: impl Fn(&Object) -> bool) -> (Vec3, Vec3) {
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for object in self.objects.iter().filter(|o| keep(o)) {
            let m = object.transform_at(t);
            for &mesh in &object.meshes {
                let Some(mesh) = self.meshes.get(mesh as usize) else {
                    continue;
                };
                for &p in &mesh.positions {
                    let w = m.transform_point3(p);
                    lo = lo.min(w);
                    hi = hi.max(w);
                }
            }
        }
        if lo.x > hi.x {
            (Vec3::ZERO, Vec3::ZERO)
        } else {
            (lo, hi)
        }
    }

    /// Bounds for GI structures at time `t`: [`Scene::bounds_at`] without far outliers.
    ///
    /// Volumes, octrees, probe grids and clipmap extents are fitted to the scene; one triangle
    /// a kilometre beside a room would spread them over the whole extent and leave the room a
    /// few cells. Along each axis the triangles' extents are marked in 64 bins over the current
    /// bounds; where empty bins split them into clusters and the cluster holding the most
    /// triangle area is less than 1/8 of the extent, the bounds shrink to the triangles touching
    /// that cluster, and the axes are looked at again (up to 8 times). Geometry without such a
    /// gap (every shipped scene) keeps exactly [`Scene::bounds_at`].
    pub fn gi_bounds_at(&self, t: f32) -> (Vec3, Vec3) {
        const BINS: usize = 64;
        let full = self.bounds_at(t);
        let mut tris: Vec<(Vec3, Vec3, f32)> = Vec::new();
        for object in &self.objects {
            let m = object.transform_at(t);
            for &mesh in &object.meshes {
                let Some(mesh) = self.meshes.get(mesh as usize) else {
                    continue;
                };
                for tri in mesh.indices.chunks_exact(3) {
                    let p: [Vec3; 3] = std::array::from_fn(|k| {
                        let i = tri[k] as usize;
                        m.transform_point3(mesh.positions.get(i).copied().unwrap_or_default())
                    });
                    let area = 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length();
                    tris.push((p[0].min(p[1]).min(p[2]), p[0].max(p[1]).max(p[2]), area));
                }
            }
        }
        let (mut lo, mut hi) = full;
        let mut keep: Vec<bool> = vec![true; tris.len()];
        for _ in 0..8 {
            let mut shrunk = false;
            for axis in 0..3 {
                let (a, b) = (lo[axis], hi[axis]);
                let extent = b - a;
                if extent.is_nan() || extent <= 0.0 {
                    continue;
                }
                let bin = |x: f32| (((x - a) / extent * BINS as f32) as usize).min(BINS - 1);
                let mut area = [0.0f64; BINS];
                let mut covered = [false; BINS];
                for (k, (tlo, thi, ta)) in tris.iter().enumerate() {
                    if !keep[k] {
                        continue;
                    }
                    let (i0, i1) = (bin(tlo[axis]), bin(thi[axis]));
                    covered[i0..=i1].iter_mut().for_each(|c| *c = true);
                    area[i0] += *ta as f64;
                }
                // Clusters: runs of covered bins; the one with the most area.
                let mut best = (0usize, 0usize, -1.0f64);
                let mut i = 0;
                while i < BINS {
                    if !covered[i] {
                        i += 1;
                        continue;
                    }
                    let start = i;
                    let mut sum = 0.0;
                    while i < BINS && covered[i] {
                        sum += area[i];
                        i += 1;
                    }
                    if sum > best.2 {
                        best = (start, i - 1, sum);
                    }
                }
                if (best.1 - best.0 + 1) * 8 > BINS {
                    continue;
                }
                let (c0, c1) = (best.0, best.1);
                let (mut nlo, mut nhi) =
                    (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
                for (k, (tlo, thi, _)) in tris.iter().enumerate() {
                    if keep[k] {
                        keep[k] = bin(tlo[axis]) <= c1 && bin(thi[axis]) >= c0;
                        if keep[k] {
                            nlo = nlo.min(*tlo);
                            nhi = nhi.max(*thi);
                        }
                    }
                }
                if nlo.x <= nhi.x {
                    (lo, hi) = (nlo, nhi);
                    shrunk = true;
                }
            }
            if !shrunk {
                break;
            }
        }
        (lo, hi)
    }

    /// [`Scene::gi_bounds_at`] over the animation: at rest and, for animated objects, at 256
    /// instants over their tracks' key range (a moving object outside a structure fitted to
    /// the scene would not be in it). Without far outliers, the bounds of all geometry at those
    /// instants; with them, the trimmed bounds at rest grown by the animated objects only.
    pub fn gi_bounds_over_animation(&self) -> (Vec3, Vec3) {
        let trimmed = self.gi_bounds_at(0.0);
        let outliers = trimmed != self.bounds_at(0.0);
        let (mut lo, mut hi) = trimmed;
        let keys = self
            .objects
            .iter()
            .filter_map(|o| o.animation.as_ref())
            .flat_map(|track| track.keys.iter().map(|k| k.time));
        let (t0, t1) = keys.fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), t| {
            (a.min(t), b.max(t))
        });
        if t0 < t1 {
            for i in 0..=256 {
                let t = t0 + (t1 - t0) * i as f32 / 256.0;
                let (l, h) = if outliers {
                    self.bounds_where(t, |o| o.animation.is_some())
                } else {
                    self.bounds_at(t)
                };
                if (l, h) != (Vec3::ZERO, Vec3::ZERO) {
                    lo = lo.min(l);
                    hi = hi.max(h);
                }
            }
        }
        (lo, hi)
    }

    /// All triangles in world space for a frame (for the path tracer and voxelizers).
    pub fn world_triangles(&self, frame: &SceneFrame) -> Vec<WorldTriangle> {
        self.world_triangles_where(frame, |_| true)
    }

    /// [`Scene::world_triangles`] of the objects `keep` accepts only, in the same order.
    pub fn world_triangles_where(
        &self,
        frame: &SceneFrame,
        keep: impl Fn(&Object) -> bool,
    ) -> Vec<WorldTriangle> {
        let mut out = Vec::new();
        for (object, m) in self.objects.iter().zip(&frame.object_transforms) {
            if !keep(object) {
                continue;
            }
            let normal_matrix = m.inverse().transpose();
            // Unvalidated data (a scene built by hand) must not panic here: meshes and
            // triangles that point past their data are left out, missing normals face +y.
            for mesh in object
                .meshes
                .iter()
                .filter_map(|&i| self.meshes.get(i as usize))
            {
                let n = mesh.positions.len();
                for tri in mesh.indices.chunks_exact(3) {
                    let v = [tri[0] as usize, tri[1] as usize, tri[2] as usize];
                    if v.iter().any(|&i| i >= n) {
                        continue;
                    }
                    out.push(WorldTriangle {
                        positions: v.map(|i| m.transform_point3(mesh.positions[i])),
                        normals: v.map(|i| {
                            normal_matrix
                                .transform_vector3(mesh.normals.get(i).copied().unwrap_or(Vec3::Y))
                                .normalize_or(Vec3::Y)
                        }),
                        uvs: v.map(|i| mesh.uvs.get(i).copied().unwrap_or(Vec2::ZERO)),
                        material: mesh.material,
                    });
                }
            }
        }
        out
    }

    /// True if some light or emissive material can illuminate the scene.
    pub fn has_light(&self) -> bool {
        self.lights
            .iter()
            .any(|l| l.intensity > 0.0 && l.color.max_element() > 0.0)
            || self
                .materials
                .iter()
                .any(|m| m.emission.max_element() > 0.0)
            || self.sky.as_ref().is_some_and(|s| !s.is_black())
    }

    /// Appends `other`'s meshes, materials and textures, re-indexing, and returns the indices
    /// of `other`'s meshes in `self`. Objects, lights and cameras of `other` are also appended,
    /// and its sky is taken when `self` has none.
    pub fn merge(&mut self, other: Scene) -> Vec<u32> {
        let material_base = self.materials.len() as u32;
        let texture_base = self.textures.len() as u32;
        let mesh_base = self.meshes.len() as u32;
        self.textures.extend(other.textures);
        self.materials
            .extend(other.materials.into_iter().map(|mut m| {
                m.base_color_texture = m.base_color_texture.map(|t| t + texture_base);
                m
            }));
        let mesh_ids: Vec<u32> = (0..other.meshes.len() as u32)
            .map(|i| i + mesh_base)
            .collect();
        self.meshes.extend(other.meshes.into_iter().map(|mut m| {
            m.material += material_base;
            m
        }));
        self.objects.extend(other.objects.into_iter().map(|mut o| {
            o.meshes.iter_mut().for_each(|m| *m += mesh_base);
            o
        }));
        self.lights.extend(other.lights);
        self.cameras.extend(other.cameras);
        if self.sky.is_none() {
            self.sky = other.sky;
        }
        mesh_ids
    }
}
