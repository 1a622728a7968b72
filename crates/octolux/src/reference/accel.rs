//! World-space triangles of one frame in a BVH (obvhs' compressed wide BVH), with closest-hit
//! and any-hit queries that treat alpha-masked texels (and clear materials) as holes.

use crate::scene::{AlphaMode, Scene, SceneFrame, Texture};
use crate::{Error, Result};
use glam::{Vec2, Vec3};
use obvhs::cwbvh::CwBvh;
use std::time::Duration;

/// A material resolved for shading: textures looked up once.
pub(crate) struct ShadeMaterial<'a> {
    pub base_color: Vec3,
    pub texture: Option<&'a Texture>,
    pub emission: Vec3,
    /// Whether the back face emits too.
    pub emission_two_sided: bool,
    /// Coverage factor multiplied with the texture's alpha.
    pub opacity: f32,
    /// Alpha cutoff for masked materials.
    pub cutoff: Option<f32>,
}

/// A triangle prepared for intersection and shading.
#[derive(Clone, Copy)]
pub(crate) struct Tri {
    pub p0: Vec3,
    pub e1: Vec3,
    pub e2: Vec3,
    pub normals: [Vec3; 3],
    pub uvs: [Vec2; 3],
    pub material: u32,
}

impl Tri {
    /// Möller-Trumbore: (t, u, v) for a hit with t in (0, t_max), where the hit point is
    /// p0 + u e1 + v e2.
    #[inline]
    fn intersect(&self, origin: Vec3, dir: Vec3, t_max: f32) -> Option<(f32, f32, f32)> {
        crate::scene::intersect_triangle(self.p0, self.e1, self.e2, origin, dir, t_max)
    }

    /// Unit normal of the winding order (e1 x e2).
    pub fn winding_normal(&self) -> Vec3 {
        self.e1.cross(self.e2).normalize_or(Vec3::Y)
    }

    /// Interpolated vertex normal at barycentrics (u, v) (the winding normal where the vertex
    /// normals cancel out). The front face is the side it points to.
    pub fn interpolated_normal(&self, u: f32, v: f32) -> Vec3 {
        (self.normals[0] * (1.0 - u - v) + self.normals[1] * u + self.normals[2] * v)
            .normalize_or(self.winding_normal())
    }

    /// Interpolated texture coordinates at barycentrics (u, v).
    pub fn uv(&self, u: f32, v: f32) -> Vec2 {
        self.uvs[0] * (1.0 - u - v) + self.uvs[1] * u + self.uvs[2] * v
    }
}

/// A closest hit.
pub(crate) struct Hit {
    pub tri: u32,
    pub t: f32,
    pub u: f32,
    pub v: f32,
}

/// The frame's geometry, ready for ray queries.
pub(crate) struct Accel<'a> {
    pub tris: Vec<Tri>,
    pub materials: Vec<ShadeMaterial<'a>>,
    bvh: Option<CwBvh>,
}

impl<'a> Accel<'a> {
    /// Builds the BVH over the frame's world triangles. Degenerate triangles are dropped.
    pub fn build(scene: &'a Scene, frame: &SceneFrame) -> Result<Accel<'a>> {
        let materials = scene
            .materials
            .iter()
            .map(|m| {
                let texture = match m.base_color_texture {
                    Some(i) => Some(scene.textures.get(i as usize).ok_or_else(|| {
                        Error::scene(
                            &scene.name,
                            format!("material '{}' refers to missing texture {i}", m.name),
                        )
                    })?),
                    None => None,
                };
                Ok(ShadeMaterial {
                    base_color: m.base_color,
                    texture,
                    emission: m.emission,
                    emission_two_sided: m.emission_two_sided,
                    opacity: m.opacity,
                    cutoff: match m.alpha_mode {
                        AlphaMode::Mask(c) => Some(c),
                        AlphaMode::Opaque => None,
                    },
                })
            })
            .collect::<Result<Vec<_>>>()?;
        let mut tris = Vec::new();
        for w in scene.world_triangles(frame) {
            if w.material as usize >= materials.len() {
                return Err(Error::scene(
                    &scene.name,
                    format!("triangle refers to missing material {}", w.material),
                ));
            }
            if scene.materials[w.material as usize].is_clear() {
                continue;
            }
            let [a, b, c] = w.positions;
            let (e1, e2) = (b - a, c - a);
            let area2 = e1.cross(e2).length();
            if !(area2 > 0.0 && area2.is_finite()) {
                continue;
            }
            tris.push(Tri {
                p0: a,
                e1,
                e2,
                normals: w.normals,
                uvs: w.uvs,
                material: w.material,
            });
        }
        if tris.is_empty() {
            return Ok(Accel {
                tris,
                materials,
                bvh: None,
            });
        }
        let obvhs_tris: Vec<obvhs::triangle::Triangle> = tris
            .iter()
            .map(|t| {
                let [a, b, c] = [t.p0, t.p0 + t.e1, t.p0 + t.e2];
                obvhs::triangle::Triangle {
                    v0: a.to_array().into(),
                    v1: b.to_array().into(),
                    v2: c.to_array().into(),
                }
            })
            .collect();
        let bvh = obvhs::cwbvh::builder::build_cwbvh_from_tris(
            &obvhs_tris,
            obvhs::BvhBuildParams::medium_build(),
            &mut Duration::default(),
        );
        // Lay the triangles out in BVH leaf order so traversal indexes them directly.
        let ordered = bvh
            .primitive_indices
            .iter()
            .map(|&i| tris[i as usize])
            .collect();
        Ok(Accel {
            tris: ordered,
            materials,
            bvh: Some(bvh),
        })
    }

    /// Whether the surface of `tri` at barycentrics (u, v) is a hole (masked-out texel).
    #[inline]
    pub fn is_hole(&self, tri: &Tri, u: f32, v: f32) -> bool {
        let m = &self.materials[tri.material as usize];
        match m.cutoff {
            Some(cutoff) => {
                let alpha = m.texture.map_or(1.0, |tex| tex.sample(tri.uv(u, v)).w);
                alpha * m.opacity < cutoff
            }
            None => false,
        }
    }

    /// Radiance that `tri` emits at barycentrics (u, v) towards a ray travelling along unit
    /// `dir`: from the front face (the side the vertex normals point to, as glTF and Mitsuba
    /// have it) or from both with `emission_two_sided`; nothing from a masked-out texel.
    pub fn emitted(&self, tri: &Tri, u: f32, v: f32, dir: Vec3) -> Vec3 {
        let m = &self.materials[tri.material as usize];
        if m.emission == Vec3::ZERO || self.is_hole(tri, u, v) {
            return Vec3::ZERO;
        }
        if m.emission_two_sided || tri.interpolated_normal(u, v).dot(dir) < 0.0 {
            m.emission
        } else {
            Vec3::ZERO
        }
    }

    /// Closest non-hole hit along `origin + t dir`, t in (0, t_max).
    pub fn closest(&self, origin: Vec3, dir: Vec3, t_max: f32) -> Option<Hit> {
        let bvh = self.bvh.as_ref()?;
        let ray = obvhs::ray::Ray::new(origin.to_array().into(), dir.to_array().into(), 0.0, t_max);
        let mut best: Option<Hit> = None;
        let mut hit = obvhs::ray::RayHit::none();
        bvh.ray_traverse(ray, &mut hit, |r, id| {
            let tri = &self.tris[id];
            match tri.intersect(origin, dir, r.tmax) {
                Some((t, u, v)) if !self.is_hole(tri, u, v) => {
                    best = Some(Hit {
                        tri: id as u32,
                        t,
                        u,
                        v,
                    });
                    t
                }
                _ => f32::INFINITY,
            }
        });
        best
    }

    /// Whether nothing blocks `origin + t dir` for t in (0, t_max).
    pub fn unoccluded(&self, origin: Vec3, dir: Vec3, t_max: f32) -> bool {
        let Some(bvh) = self.bvh.as_ref() else {
            return true;
        };
        let ray = obvhs::ray::Ray::new(origin.to_array().into(), dir.to_array().into(), 0.0, t_max);
        bvh.ray_traverse_miss(ray, |_, id| {
            let tri = &self.tris[id];
            match tri.intersect(origin, dir, t_max) {
                Some((t, u, v)) if !self.is_hole(tri, u, v) => t,
                _ => f32::INFINITY,
            }
        })
    }
}
