//! A camera for a scene that names none, chosen by looking: candidate views are scored by the
//! share of a coarse grid of rays that meet the front of a surface, the side that is lit and
//! drawn. A view from outside a box open on one side (the Cornell box) then looks through the
//! opening rather than at the back of a wall, and a closed room is seen from inside.
//!
//! The same rays describe what any camera sees ([`Scene::view_survey`]), which is how a render
//! that comes out black explains itself.

use super::{Camera, Scene, SceneFrame};
use glam::Vec3;
use obvhs::cwbvh::CwBvh;
use std::time::Duration;

/// Rays per candidate view: a 32 x 18 grid over the image.
const GRID: (u32, u32) = (32, 18);
/// Share of the rays from the scene's centre that must meet a surface's front for the scene to
/// count as enclosed (a closed room, a courtyard under a roof); then it is seen from inside. A
/// box open on one side (a sixth of the directions) is not.
const ENCLOSED: f32 = 0.95;
/// Rays from the scene's centre for that test.
const ENCLOSURE_RAYS: u32 = 256;
/// A view scoring within this of the best one keeps its place in the order of candidates: the
/// first is the view octolux always took (from +z, a little above).
const TIE: f32 = 0.02;

/// What a camera sees, counted over a grid of rays (see [`Scene::view_survey`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ViewSurvey {
    /// Rays cast.
    pub rays: u32,
    /// Rays that meet no surface.
    pub misses: u32,
    /// Rays that meet the back of a surface (its unlit side, drawn black).
    pub back_faces: u32,
    /// Rays that meet the front of a surface.
    pub front_faces: u32,
}

impl ViewSurvey {
    /// Share of the rays that meet the front of a surface.
    pub fn front_share(&self) -> f32 {
        self.front_faces as f32 / self.rays.max(1) as f32
    }
}

/// The scene's opaque triangles at one time, for ray queries.
struct Rays {
    bvh: Option<CwBvh>,
    /// Per triangle in BVH order: a vertex, two edges and the front-facing normal.
    tris: Vec<[Vec3; 4]>,
}

impl Rays {
    fn build(scene: &Scene, frame: &SceneFrame) -> Rays {
        let mut tris = Vec::new();
        for w in scene.world_triangles(frame) {
            if scene
                .materials
                .get(w.material as usize)
                .is_some_and(|m| m.is_clear())
            {
                continue;
            }
            let [a, b, c] = w.positions;
            let (e1, e2) = (b - a, c - a);
            let winding = e1.cross(e2);
            if !(winding.length_squared() > 0.0 && winding.is_finite()) {
                continue;
            }
            // The front is where the vertex normals point, as the renderers shade it.
            let front = (w.normals[0] + w.normals[1] + w.normals[2]).normalize_or(winding);
            tris.push([a, e1, e2, front]);
        }
        if tris.is_empty() {
            return Rays { bvh: None, tris };
        }
        let prims: Vec<obvhs::triangle::Triangle> = tris
            .iter()
            .map(|&[a, e1, e2, _]| obvhs::triangle::Triangle {
                v0: a.to_array().into(),
                v1: (a + e1).to_array().into(),
                v2: (a + e2).to_array().into(),
            })
            .collect();
        let bvh = obvhs::cwbvh::builder::build_cwbvh_from_tris(
            &prims,
            obvhs::BvhBuildParams::fast_build(),
            &mut Duration::default(),
        );
        let tris = bvh
            .primitive_indices
            .iter()
            .map(|&i| tris[i as usize])
            .collect();
        Rays {
            bvh: Some(bvh),
            tris,
        }
    }

    /// The front-facing normal of the closest triangle along `origin + t dir`, and its distance.
    fn closest(&self, origin: Vec3, dir: Vec3) -> Option<(f32, Vec3)> {
        let bvh = self.bvh.as_ref()?;
        let ray = obvhs::ray::Ray::new(
            origin.to_array().into(),
            dir.to_array().into(),
            0.0,
            f32::INFINITY,
        );
        let mut best = None;
        let mut hit = obvhs::ray::RayHit::none();
        bvh.ray_traverse(ray, &mut hit, |r, id| {
            let [p0, e1, e2, front] = self.tris[id];
            match intersect_triangle(p0, e1, e2, origin, dir, r.tmax) {
                Some((t, _, _)) => {
                    best = Some((t, front));
                    t
                }
                None => f32::INFINITY,
            }
        });
        best
    }

    /// What `camera` sees on a grid of rays.
    fn survey(&self, camera: &Camera) -> ViewSurvey {
        let view = camera.view(GRID.0, GRID.1);
        let mut survey = ViewSurvey::default();
        for y in 0..GRID.1 {
            for x in 0..GRID.0 {
                let dir = view.ray_direction(x as f32 + 0.5, y as f32 + 0.5);
                survey.rays += 1;
                match self.closest(camera.position, dir) {
                    None => survey.misses += 1,
                    Some((_, front)) if front.dot(dir) < 0.0 => survey.front_faces += 1,
                    Some(_) => survey.back_faces += 1,
                }
            }
        }
        survey
    }
}

/// Möller-Trumbore: (t, u, v) of the hit of `origin + t dir` on the triangle `p0 + u e1 + v e2`
/// with t in (0, t_max). The CPU ray queries (this camera's, the reference path tracer's) share
/// it.
#[inline]
pub(crate) fn intersect_triangle(
    p0: Vec3,
    e1: Vec3,
    e2: Vec3,
    origin: Vec3,
    dir: Vec3,
    t_max: f32,
) -> Option<(f32, f32, f32)> {
    let p = dir.cross(e2);
    let det = e1.dot(p);
    if det.abs() < 1e-12 {
        return None;
    }
    let inv = 1.0 / det;
    let s = origin - p0;
    let u = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = dir.dot(q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = e2.dot(q) * inv;
    (t > 0.0 && t < t_max).then_some((t, u, v))
}

/// `n` directions spread evenly over the sphere (a Fibonacci lattice).
fn sphere_directions(n: u32) -> impl Iterator<Item = Vec3> {
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    (0..n).map(move |i| {
        let y = 1.0 - (2 * i + 1) as f32 / n as f32;
        let r = (1.0 - y * y).max(0.0).sqrt();
        let phi = golden * i as f32;
        Vec3::new(r * phi.cos(), y, r * phi.sin())
    })
}

impl Scene {
    /// Adds a camera named "auto" that looks into the scene ([`Scene::framing_camera`]) when
    /// the scene has none; [`Scene::load`] does this for every file it loads.
    pub fn add_framing_camera(&mut self) {
        if self.cameras.is_empty() && !self.objects.is_empty() {
            let camera = self.framing_camera();
            self.cameras.push(camera);
        }
    }

    /// A camera that looks into the scene at time 0. When rays from the middle of the scene
    /// mostly meet the fronts of surfaces, the scene is enclosed (a room) and the camera
    /// stands inside it, near one wall, looking along the room; otherwise it looks at the
    /// scene from outside, from the side where the most of what it sees faces it (first
    /// choice, on a tie: from +z and a little above, framing the bounds).
    pub fn framing_camera(&self) -> Camera {
        let bounds = self.gi_bounds_at(0.0);
        let rays = Rays::build(self, &self.frame(0.0, usize::MAX));
        let (lo, hi) = bounds;
        let center = (lo + hi) * 0.5;
        let enclosed = {
            let (mut front, mut all) = (0, 0);
            for dir in sphere_directions(ENCLOSURE_RAYS) {
                all += 1;
                if rays
                    .closest(center, dir)
                    .is_some_and(|(_, n)| n.dot(dir) < 0.0)
                {
                    front += 1;
                }
            }
            front as f32 >= ENCLOSED * all as f32
        };
        let candidates: Vec<Camera> = if enclosed {
            inside_views(&rays, bounds)
        } else {
            outside_views(bounds)
        };
        let mut best: Option<(f32, Camera)> = None;
        for camera in candidates {
            let score = rays.survey(&camera).front_share();
            if best.as_ref().is_none_or(|(b, _)| score > b + TIE) {
                best = Some((score, camera));
            }
        }
        best.map_or_else(|| Camera::framing(bounds), |(_, c)| c)
    }

    /// What `camera` sees at time `t`, on a coarse grid of rays: how many meet nothing, the
    /// back of a surface or its front. For explaining an image that comes out black.
    pub fn view_survey(&self, camera: &Camera, t: f32) -> ViewSurvey {
        Rays::build(self, &self.frame(t, usize::MAX)).survey(camera)
    }
}

/// Views from outside: [`Camera::framing`]'s view from +z, then from the seven other
/// horizontal directions 45 degrees apart and from above.
fn outside_views(bounds: (Vec3, Vec3)) -> Vec<Camera> {
    let base = Camera::framing(bounds);
    let center = (bounds.0 + bounds.1) * 0.5;
    let offset = base.position - center;
    let mut views: Vec<Camera> = (0..8)
        .map(|i| {
            let turn = glam::Quat::from_rotation_y(i as f32 * std::f32::consts::FRAC_PI_4);
            Camera {
                position: center + turn * offset,
                ..base.clone()
            }
        })
        .collect();
    views.push(Camera {
        position: center + Vec3::Y * offset.length(),
        up: Vec3::NEG_Z,
        ..base
    });
    views
}

/// Views from inside an enclosed scene: from the middle, backed towards one wall (stopping
/// short of it and of anything in between), looking along each horizontal axis, the longer
/// one first.
fn inside_views(rays: &Rays, bounds: (Vec3, Vec3)) -> Vec<Camera> {
    let (lo, hi) = bounds;
    let center = (lo + hi) * 0.5;
    let size = (hi - lo).max(Vec3::splat(1e-3));
    let along_x = [Vec3::X, Vec3::NEG_X];
    let along_z = [Vec3::Z, Vec3::NEG_Z];
    let order = if size.x > size.z {
        [along_x, along_z]
    } else {
        [along_z, along_x]
    };
    order
        .into_iter()
        .flatten()
        .map(|forward| {
            let room = (size * forward.abs()).element_sum();
            let behind = rays
                .closest(center, -forward)
                .map_or(room * 0.5, |(t, _)| t);
            let position = center - forward * (behind * 0.8);
            let far = size.length() * 2.0;
            Camera {
                name: "auto".into(),
                position,
                target: position + forward,
                vfov: 60f32.to_radians(),
                near: (far * 1e-4).max(1e-3),
                far,
                ..Camera::default()
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::cornell;

    #[test]
    fn the_cornell_box_is_seen_through_its_opening() {
        let mut scene = cornell::scene();
        let authored = scene.cameras.remove(0);
        let camera = scene.framing_camera();
        // The box is open towards its authored camera: the chosen view is on that side.
        let center = {
            let (lo, hi) = scene.bounds_at(0.0);
            (lo + hi) * 0.5
        };
        let towards_opening = (authored.position - center).normalize();
        assert!(
            (camera.position - center).normalize().dot(towards_opening) > 0.7,
            "framed from {} (centre {center}, opening towards {towards_opening})",
            camera.position
        );
        let (lo, hi) = scene.bounds_at(0.0);
        let outside = camera.position.cmplt(lo).any() || camera.position.cmpgt(hi).any();
        assert!(
            outside,
            "an open box is seen from outside: {}",
            camera.position
        );
        let survey = scene.view_survey(&camera, 0.0);
        assert!(survey.front_faces > 0, "{survey:?}");
        assert_eq!(survey.back_faces, 0, "{survey:?}");
        // The view octolux used to take, from +z, sees only the back of the back wall.
        let old = scene.view_survey(&Camera::framing(scene.bounds_at(0.0)), 0.0);
        assert_eq!(old.front_faces, 0, "{old:?}");
    }

    /// A closed box from `lo` to `hi` whose faces point inwards, with no camera.
    fn closed_room(lo: Vec3, hi: Vec3) -> Scene {
        let mut positions = Vec::new();
        let mut normals = Vec::new();
        let mut indices = Vec::new();
        for axis in 0..3 {
            for side in [0.0f32, 1.0] {
                // Two corners spanning the face, and the inward normal.
                let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
                let mut inward = Vec3::ZERO;
                inward[axis] = if side == 0.0 { 1.0 } else { -1.0 };
                let corner = |a: f32, b: f32| {
                    let mut p = lo;
                    p[axis] = if side == 0.0 { lo[axis] } else { hi[axis] };
                    p[u] = lo[u] + a * (hi[u] - lo[u]);
                    p[v] = lo[v] + b * (hi[v] - lo[v]);
                    p
                };
                let base = positions.len() as u32;
                positions.extend([
                    corner(0.0, 0.0),
                    corner(1.0, 0.0),
                    corner(1.0, 1.0),
                    corner(0.0, 1.0),
                ]);
                normals.extend([inward; 4]);
                // Wind each triangle so that its geometric normal points inwards too.
                let e = (positions[base as usize + 1] - positions[base as usize])
                    .cross(positions[base as usize + 2] - positions[base as usize]);
                if e.dot(inward) > 0.0 {
                    indices.extend([base, base + 1, base + 2, base, base + 2, base + 3]);
                } else {
                    indices.extend([base, base + 2, base + 1, base, base + 3, base + 2]);
                }
            }
        }
        let mut scene = Scene::default();
        scene.materials.push(crate::scene::Material::default());
        scene.meshes.push(crate::scene::Mesh {
            name: "room".into(),
            uvs: vec![glam::Vec2::ZERO; positions.len()],
            positions,
            normals,
            indices,
            material: 0,
        });
        scene.objects.push(crate::scene::Object {
            name: "room".into(),
            meshes: vec![0],
            transform: glam::Mat4::IDENTITY,
            animation: None,
        });
        scene
    }

    #[test]
    fn a_closed_room_is_seen_from_inside() {
        let (lo, hi) = (Vec3::new(-2.0, 0.0, -3.0), Vec3::new(2.0, 3.0, 3.0));
        let scene = closed_room(lo, hi);
        // The view octolux used to take sees only the back of the near wall.
        let old = Camera::framing(scene.bounds_at(0.0));
        let before = scene.view_survey(&old, 0.0);
        assert_eq!(before.front_faces, 0, "{before:?}");
        let camera = scene.framing_camera();
        let inside = camera.position.cmpgt(lo).all() && camera.position.cmplt(hi).all();
        assert!(inside, "camera at {} outside the room", camera.position);
        let survey = scene.view_survey(&camera, 0.0);
        assert_eq!(survey.front_faces, survey.rays, "{survey:?}");
    }

    #[test]
    fn a_scene_with_a_camera_keeps_it() {
        let mut scene = cornell::scene();
        let before = scene.cameras.clone();
        scene.add_framing_camera();
        assert_eq!(scene.cameras.len(), before.len());
        scene.cameras.clear();
        scene.add_framing_camera();
        assert_eq!(scene.cameras.len(), 1);
        assert_eq!(scene.cameras[0].name, "auto");
    }
}
