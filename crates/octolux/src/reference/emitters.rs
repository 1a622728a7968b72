//! Next-event estimation towards emissive triangles: a triangle is picked with probability
//! proportional to its power, a point uniformly on it, and the sample's density per solid angle
//! is what multiple importance sampling weighs against cosine sampling.

use super::accel::{Accel, Tri};
use super::sampling::{cumulative, search};
use glam::{Vec2, Vec3};

/// The frame's emissive triangles as a distribution over their power.
pub(crate) struct EmitterSampler {
    /// Indices into [`Accel::tris`] of the triangles that emit.
    emitters: Vec<u32>,
    /// Cumulative probability over `emitters` (`emitters.len() + 1` entries).
    cdf: Vec<f32>,
    /// Per [`Accel::tris`] entry: the probability of picking it divided by its area, the
    /// density per unit area of a sampled point on it (0 for triangles that do not emit).
    area_pdf: Vec<f32>,
}

/// A point sampled on an emitter, seen from a shading point.
pub(crate) struct EmitterSample {
    /// Unit direction from the shading point towards the point.
    pub wi: Vec3,
    /// Distance to the point.
    pub distance: f32,
    /// Radiance the point sends towards the shading point (zero from a face that does not
    /// emit, or from a masked-out texel).
    pub radiance: Vec3,
    /// Density of the sample per solid angle at the shading point.
    pub pdf: f32,
}

/// Area of a triangle.
fn area(tri: &Tri) -> f32 {
    0.5 * tri.e1.cross(tri.e2).length()
}

impl EmitterSampler {
    /// The distribution over `accel`'s emissive triangles, or None when nothing emits.
    /// A triangle's power is its emitted radiance (channel sum) x area x emitting faces.
    pub fn new(accel: &Accel) -> Option<EmitterSampler> {
        let power = |tri: &Tri| {
            let m = &accel.materials[tri.material as usize];
            let sides = if m.emission_two_sided { 2.0 } else { 1.0 };
            m.emission.element_sum() as f64 * area(tri) as f64 * sides
        };
        let emitters: Vec<u32> = (0..accel.tris.len() as u32)
            .filter(|&i| power(&accel.tris[i as usize]) > 0.0)
            .collect();
        let cdf = cumulative(
            emitters.iter().map(|&i| power(&accel.tris[i as usize])),
            emitters.len(),
        )?;
        let mut area_pdf = vec![0.0; accel.tris.len()];
        for (k, &i) in emitters.iter().enumerate() {
            // The probability search() really gives the triangle, so that sampling and the
            // density MIS uses agree exactly.
            area_pdf[i as usize] = (cdf[k + 1] - cdf[k]) / area(&accel.tris[i as usize]);
        }
        Some(EmitterSampler {
            emitters,
            cdf,
            area_pdf,
        })
    }

    /// Samples a point on an emitter as seen from `position`, with `pick` choosing the
    /// triangle and `u` the point on it.
    pub fn sample(&self, accel: &Accel, position: Vec3, pick: f32, u: Vec2) -> EmitterSample {
        let index = self.emitters[search(&self.cdf, pick)];
        let tri = &accel.tris[index as usize];
        // Uniform barycentrics (1 - sqrt(a), sqrt(a) (1 - b), sqrt(a) b).
        let s = u.x.sqrt();
        let (bu, bv) = (s * (1.0 - u.y), s * u.y);
        let point = tri.p0 + tri.e1 * bu + tri.e2 * bv;
        let to = point - position;
        let distance = to.length();
        let none = EmitterSample {
            wi: Vec3::Y,
            distance: 0.0,
            radiance: Vec3::ZERO,
            pdf: 0.0,
        };
        if distance.is_nan() || distance <= 0.0 {
            return none;
        }
        let wi = to / distance;
        let pdf = self.solid_angle_pdf(accel, index, wi, distance);
        if pdf <= 0.0 {
            return none;
        }
        EmitterSample {
            wi,
            distance,
            radiance: accel.emitted(tri, bu, bv, wi),
            pdf,
        }
    }

    /// Density per solid angle with which [`EmitterSampler::sample`] picks the point at
    /// `distance` along unit `dir` on triangle `tri` (0 if it does not emit).
    pub fn solid_angle_pdf(&self, accel: &Accel, tri: u32, dir: Vec3, distance: f32) -> f32 {
        let area_pdf = self.area_pdf[tri as usize];
        if area_pdf <= 0.0 {
            return 0.0;
        }
        let t = &accel.tris[tri as usize];
        let cos = t.e1.cross(t.e2).normalize_or_zero().dot(dir).abs();
        if cos <= 0.0 {
            return 0.0;
        }
        area_pdf * distance * distance / cos
    }
}
