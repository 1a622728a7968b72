//! Meshes of Mitsuba's analytic shapes in their own (object) space, with Mitsuba's
//! orientation and texture coordinates; the shape's `to_world` becomes the object transform.

use crate::scene::Mesh;
use glam::{Vec2, Vec3};
use std::f32::consts::{PI, TAU};

/// Segments around a sphere, disk or cylinder.
const AROUND: u32 = 32;
/// Segments from pole to pole of a sphere.
const POLE_TO_POLE: u32 = 16;

/// The square [-1, 1]^2 in the z = 0 plane, facing +z; uv = (x + 1, y + 1) / 2.
pub(super) fn rectangle() -> Mesh {
    let corners = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)];
    Mesh {
        name: "rectangle".into(),
        positions: corners.map(|(x, y)| Vec3::new(x, y, 0.0)).to_vec(),
        normals: vec![Vec3::Z; 4],
        uvs: corners
            .map(|(x, y)| Vec2::new((x + 1.0) * 0.5, (y + 1.0) * 0.5))
            .to_vec(),
        indices: vec![0, 1, 2, 0, 2, 3],
        material: 0,
    }
}

/// The cube [-1, 1]^3 with outward normals, four vertices per face.
pub(super) fn cube() -> Mesh {
    let mut mesh = Mesh {
        name: "cube".into(),
        ..Mesh::default()
    };
    for axis in 0..3 {
        for sign in [1.0f32, -1.0] {
            let mut normal = Vec3::ZERO;
            normal[axis] = sign;
            // Two tangents with u x v = normal, so the winding faces outward.
            let mut u = Vec3::ZERO;
            u[(axis + 1) % 3] = 1.0;
            let v = normal.cross(u);
            let base = mesh.positions.len() as u32;
            for (a, b) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                mesh.positions.push(normal + u * a + v * b);
                mesh.normals.push(normal);
                mesh.uvs.push(Vec2::new((a + 1.0) * 0.5, (b + 1.0) * 0.5));
            }
            mesh.indices
                .extend([base, base + 1, base + 2, base, base + 2, base + 3]);
        }
    }
    mesh
}

/// The unit sphere about the origin, poles on the z axis, outward normals;
/// uv = (phi / 2pi, theta / pi) as Mitsuba's sphere.
pub(super) fn sphere() -> Mesh {
    let mut mesh = Mesh {
        name: "sphere".into(),
        ..Mesh::default()
    };
    for j in 0..=POLE_TO_POLE {
        let v = j as f32 / POLE_TO_POLE as f32;
        let theta = v * PI;
        for i in 0..=AROUND {
            let u = i as f32 / AROUND as f32;
            let phi = u * TAU;
            let p = Vec3::new(
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            );
            mesh.positions.push(p);
            mesh.normals.push(p);
            mesh.uvs.push(Vec2::new(u, v));
        }
    }
    let row = AROUND + 1;
    for j in 0..POLE_TO_POLE {
        for i in 0..AROUND {
            let a = j * row + i;
            let (b, c, d) = (a + 1, a + row, a + row + 1);
            // Counter-clockwise seen from outside; the pole rows lose a degenerate triangle.
            if j != 0 {
                mesh.indices.extend([a, c, b]);
            }
            if j != POLE_TO_POLE - 1 {
                mesh.indices.extend([b, c, d]);
            }
        }
    }
    mesh
}

/// The unit disk in the z = 0 plane facing +z.
pub(super) fn disk() -> Mesh {
    let mut mesh = Mesh {
        name: "disk".into(),
        positions: vec![Vec3::ZERO],
        normals: vec![Vec3::Z],
        uvs: vec![Vec2::ZERO],
        ..Mesh::default()
    };
    for i in 0..=AROUND {
        let u = i as f32 / AROUND as f32;
        let phi = u * TAU;
        mesh.positions.push(Vec3::new(phi.cos(), phi.sin(), 0.0));
        mesh.normals.push(Vec3::Z);
        mesh.uvs.push(Vec2::new(1.0, u));
    }
    for i in 0..AROUND {
        mesh.indices.extend([0, i + 1, i + 2]);
    }
    mesh
}

/// An open cylinder of radius 1 from z = 0 to z = 1 with outward normals.
pub(super) fn cylinder() -> Mesh {
    let mut mesh = Mesh {
        name: "cylinder".into(),
        ..Mesh::default()
    };
    for i in 0..=AROUND {
        let u = i as f32 / AROUND as f32;
        let phi = u * TAU;
        let n = Vec3::new(phi.cos(), phi.sin(), 0.0);
        for z in [0.0, 1.0] {
            mesh.positions.push(n + Vec3::Z * z);
            mesh.normals.push(n);
            mesh.uvs.push(Vec2::new(u, z));
        }
    }
    for i in 0..AROUND {
        let a = i * 2;
        mesh.indices.extend([a, a + 2, a + 3, a, a + 3, a + 1]);
    }
    mesh
}

/// Mitsuba's `flip_normals`: normals reversed, and the winding with them.
pub(super) fn flip(mesh: &mut Mesh) {
    for n in &mut mesh.normals {
        *n = -*n;
    }
    for tri in mesh.indices.chunks_exact_mut(3) {
        tri.swap(1, 2);
    }
}

/// Mitsuba's `face_normals`: every triangle gets its own vertices with the face normal.
pub(super) fn face_normals(mesh: &mut Mesh) {
    let n = mesh.positions.len();
    if mesh.indices.iter().any(|&i| i as usize >= n) {
        return; // validation reports the bad index
    }
    let has_uvs = mesh.uvs.len() == n;
    let mut out = Mesh {
        name: mesh.name.clone(),
        material: mesh.material,
        ..Mesh::default()
    };
    for tri in mesh.indices.chunks_exact(3) {
        let p = [tri[0], tri[1], tri[2]].map(|i| mesh.positions[i as usize]);
        let normal = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or(Vec3::Z);
        for (k, &i) in tri.iter().enumerate() {
            out.indices.push(out.positions.len() as u32);
            out.positions.push(p[k]);
            out.normals.push(normal);
            out.uvs.push(if has_uvs {
                mesh.uvs[i as usize]
            } else {
                Vec2::ZERO
            });
        }
    }
    *mesh = out;
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every triangle's winding agrees with its vertex normals, and the normals are unit.
    fn check_outward(mesh: &Mesh) {
        for tri in mesh.indices.chunks_exact(3) {
            let [a, b, c] = [tri[0], tri[1], tri[2]].map(|i| i as usize);
            let p = [a, b, c].map(|i| mesh.positions[i]);
            let face = (p[1] - p[0]).cross(p[2] - p[0]);
            assert!(face.length() > 0.0, "degenerate triangle in {}", mesh.name);
            for i in [a, b, c] {
                assert!((mesh.normals[i].length() - 1.0).abs() < 1e-5);
                assert!(face.dot(mesh.normals[i]) > 0.0, "{} winding", mesh.name);
            }
        }
    }

    #[test]
    fn shapes_face_outward() {
        for mesh in [rectangle(), cube(), sphere(), disk(), cylinder()] {
            check_outward(&mesh);
        }
        let cube = cube();
        assert_eq!(cube.triangle_count(), 12);
        for (p, n) in cube.positions.iter().zip(&cube.normals) {
            assert!(p.abs().max_element() == 1.0 && p.dot(*n) == 1.0);
        }
        let sphere = sphere();
        assert!(sphere
            .positions
            .iter()
            .all(|p| (p.length() - 1.0).abs() < 1e-5));
        let mut flipped = sphere.clone();
        flip(&mut flipped);
        check_outward(&flipped);
        assert!(flipped.normals[40].dot(flipped.positions[40]) < 0.0);
    }

    #[test]
    fn face_normals_unweld() {
        let mut mesh = sphere();
        let tris = mesh.triangle_count();
        face_normals(&mut mesh);
        assert_eq!(mesh.positions.len(), tris * 3);
        check_outward(&mesh);
    }
}
