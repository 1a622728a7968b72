//! View-frustum culling for the raster passes (G-buffer, shadow maps, RSMs). A mesh is cut
//! into clusters of consecutive triangles, each with its bounding box; a view draws the index
//! ranges of the clusters that can touch its clip volume, consecutive ones merged into one
//! draw. The triangles keep their order, so what is drawn is what a whole-mesh draw gives,
//! fragment for fragment: a culled cluster would have produced no fragment.
//!
//! On a GPU whose rasteriser is slow next to its compute (the H100/H200), the vertex work of a
//! raster pass is most of its cost, so a spot light's map or a point light's cube face, which
//! see a part of the scene, cost that part instead of the whole scene.

use glam::{Mat4, Vec3, Vec4};
use std::ops::Range;

/// Triangles per cluster: small enough that a view's edge cuts few of them, large enough that
/// the per-view test (a box per cluster, on the CPU) and the draws stay few.
pub(crate) const CLUSTER_TRIANGLES: usize = 256;

/// A run of consecutive triangles of a mesh and the box around their vertices.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Cluster {
    /// Index range in the mesh's index buffer.
    pub first_index: u32,
    pub index_count: u32,
    /// Model-space bounding box.
    pub bounds: (Vec3, Vec3),
}

/// The bounding box of `points` (empty: +inf..-inf, which culling never drops).
pub(crate) fn bounds_of(points: impl IntoIterator<Item = Vec3>) -> (Vec3, Vec3) {
    points.into_iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(p), hi.max(p)),
    )
}

/// Cuts a triangle list into clusters of [`CLUSTER_TRIANGLES`] consecutive triangles (the last
/// may be shorter). Indices past `positions` add nothing to a box.
pub(crate) fn clusters(positions: &[Vec3], indices: &[u32]) -> Vec<Cluster> {
    let triangles = indices.len() / 3;
    (0..triangles.div_ceil(CLUSTER_TRIANGLES))
        .map(|c| {
            let first = c * CLUSTER_TRIANGLES * 3;
            let end = ((c + 1) * CLUSTER_TRIANGLES).min(triangles) * 3;
            Cluster {
                first_index: first as u32,
                index_count: (end - first) as u32,
                bounds: bounds_of(
                    indices[first..end]
                        .iter()
                        .filter_map(|&i| positions.get(i as usize).copied()),
                ),
            }
        })
        .collect()
}

/// The eight corners of `(lo, hi)` in clip space.
fn clip_corners(clip_from_model: Mat4, (lo, hi): (Vec3, Vec3)) -> [Vec4; 8] {
    std::array::from_fn(|i| {
        let p = Vec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        );
        clip_from_model * p.extend(1.0)
    })
}

/// The clip volume's planes (-w <= x, y <= w, 0 <= z <= w), each >= 0 inside.
const PLANES: [fn(Vec4) -> f32; 6] = [
    |c| c.x + c.w,
    |c| c.w - c.x,
    |c| c.y + c.w,
    |c| c.w - c.y,
    |c| c.z,
    |c| c.w - c.z,
];

/// Whether the box `(lo, hi)` transformed by `clip_from_model` lies wholly outside the clip
/// volume: all eight corners beyond one of its planes. Each plane is linear in homogeneous
/// coordinates, so this holds for corners behind the eye too. Boxes that are not finite (an
/// empty mesh) are never outside.
pub(crate) fn outside(clip_from_model: Mat4, bounds: (Vec3, Vec3)) -> bool {
    if !(bounds.0.is_finite() && bounds.1.is_finite()) {
        return false;
    }
    let corners = clip_corners(clip_from_model, bounds);
    PLANES
        .iter()
        .any(|plane| corners.iter().all(|&c| plane(c) < 0.0))
}

/// Whether the box lies wholly inside the clip volume (every corner within every plane): its
/// clusters need no test of their own.
fn inside(clip_from_model: Mat4, bounds: (Vec3, Vec3)) -> bool {
    let corners = clip_corners(clip_from_model, bounds);
    PLANES
        .iter()
        .all(|plane| corners.iter().all(|&c| plane(c) >= 0.0))
}

/// The index ranges of a mesh (`index_count` indices, box `bounds`, `clusters`) to draw through
/// `clip_from_model` (None: no culling, the whole mesh), consecutive visible clusters merged.
pub(crate) fn visible_ranges(
    clip_from_model: Option<Mat4>,
    bounds: (Vec3, Vec3),
    clusters: &[Cluster],
    index_count: u32,
) -> Vec<Range<u32>> {
    let whole = || std::iter::once(0..index_count).collect();
    let Some(clip) = clip_from_model else {
        return whole();
    };
    if outside(clip, bounds) {
        return Vec::new();
    }
    if clusters.len() <= 1 || !bounds.0.is_finite() || inside(clip, bounds) {
        return whole();
    }
    let mut ranges: Vec<Range<u32>> = Vec::new();
    for c in clusters.iter().filter(|c| !outside(clip, c.bounds)) {
        let range = c.first_index..c.first_index + c.index_count;
        match ranges.last_mut() {
            Some(last) if last.end == range.start => last.end = range.end,
            _ => ranges.push(range),
        }
    }
    ranges
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn culling_keeps_what_touches_the_view_and_drops_what_cannot() {
        let proj = Mat4::perspective_rh(1.0, 1.0, 0.1, 10.0);
        let view = Mat4::look_at_rh(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y);
        let vp = proj * view;
        let unit = (Vec3::splat(-0.5), Vec3::splat(0.5));
        let at = |p: Vec3| vp * Mat4::from_translation(p);
        assert!(!outside(at(Vec3::new(0.0, 0.0, -5.0)), unit), "in front");
        assert!(
            outside(at(Vec3::new(0.0, 0.0, 5.0)), unit),
            "behind the eye"
        );
        assert!(outside(at(Vec3::new(0.0, 0.0, -20.0)), unit), "beyond far");
        assert!(
            outside(at(Vec3::new(30.0, 0.0, -5.0)), unit),
            "far to the side"
        );
        // Straddling the eye (corners in front and behind) is kept.
        assert!(!outside(
            at(Vec3::ZERO),
            (Vec3::splat(-2.0), Vec3::splat(2.0))
        ));
        // Just touching the side plane from outside is kept (the test is strict).
        let edge = (1.0f32 * 0.5).tan() * 5.0;
        assert!(!outside(at(Vec3::new(edge + 0.5, 0.0, -5.0)), unit));
        // Degenerate bounds (empty mesh) are never culled.
        assert!(!outside(vp, (Vec3::INFINITY, Vec3::NEG_INFINITY)));
    }

    /// A 64 x 64 grid of quads on the floor (y = 0), rows of quads in order: 8192 triangles.
    fn floor_grid() -> (Vec<Vec3>, Vec<u32>) {
        let n = 64u32;
        let positions: Vec<Vec3> = (0..=n)
            .flat_map(|z| (0..=n).map(move |x| Vec3::new(x as f32, 0.0, z as f32)))
            .collect();
        let mut indices = Vec::new();
        for z in 0..n {
            for x in 0..n {
                let i = z * (n + 1) + x;
                indices.extend([i, i + n + 1, i + 1, i + 1, i + n + 1, i + n + 2]);
            }
        }
        (positions, indices)
    }

    #[test]
    fn clusters_cover_every_triangle_once_in_order() {
        let (positions, indices) = floor_grid();
        let cs = clusters(&positions, &indices);
        assert_eq!(cs.len(), 8192usize.div_ceil(CLUSTER_TRIANGLES));
        let mut next = 0;
        for c in &cs {
            assert_eq!(c.first_index, next);
            next += c.index_count;
            let tri = &indices[c.first_index as usize..(c.first_index + c.index_count) as usize];
            for &i in tri {
                let p = positions[i as usize];
                assert!(p.cmpge(c.bounds.0).all() && p.cmple(c.bounds.1).all());
            }
        }
        assert_eq!(next as usize, indices.len());
        // A list that is not a multiple of the cluster size keeps its tail.
        let cs = clusters(&positions, &indices[..(CLUSTER_TRIANGLES + 1) * 3]);
        assert_eq!(cs.len(), 2);
        assert_eq!(cs[1].index_count, 3);
    }

    /// Every triangle with a point inside the view is drawn (vertices and centroid tested
    /// against the clip volume), and a view of a corner of the floor draws a small part.
    #[test]
    fn visible_ranges_draw_every_triangle_the_view_sees() {
        let (positions, indices) = floor_grid();
        let cs = clusters(&positions, &indices);
        let bounds = bounds_of(positions.iter().copied());
        let count = indices.len() as u32;
        let views = [
            // A spot light above a corner, looking down.
            Mat4::perspective_rh(1.2, 1.0, 0.1, 100.0)
                * Mat4::look_at_rh(Vec3::new(8.0, 6.0, 8.0), Vec3::new(8.0, 0.0, 8.0), Vec3::Z),
            // Grazing along the floor from its middle.
            Mat4::perspective_rh(0.8, 1.5, 0.1, 40.0)
                * Mat4::look_at_rh(
                    Vec3::new(32.0, 1.0, 32.0),
                    Vec3::new(60.0, 0.0, 40.0),
                    Vec3::Y,
                ),
            // An orthographic sun over all of it.
            Mat4::orthographic_rh(-50.0, 50.0, -50.0, 50.0, 0.1, 100.0)
                * Mat4::look_at_rh(
                    Vec3::new(32.0, 50.0, 32.0),
                    Vec3::new(32.0, 0.0, 32.0),
                    Vec3::Z,
                ),
        ];
        let mut drawn_fractions = Vec::new();
        for vp in views {
            let ranges = visible_ranges(Some(vp), bounds, &cs, count);
            let drawn = |t: u32| ranges.iter().any(|r| r.contains(&(3 * t)));
            for t in 0..count / 3 {
                let tri: Vec<Vec3> = (0..3)
                    .map(|k| positions[indices[(3 * t + k) as usize] as usize])
                    .collect();
                let centroid = (tri[0] + tri[1] + tri[2]) / 3.0;
                let seen = tri.iter().chain([&centroid]).any(|&p| {
                    let c = vp * p.extend(1.0);
                    PLANES.iter().all(|plane| plane(c) >= 0.0)
                });
                assert!(!seen || drawn(t), "triangle {t} is seen but not drawn");
            }
            // Ranges are ordered, disjoint and merged.
            for w in ranges.windows(2) {
                assert!(w[0].end < w[1].start);
            }
            let total: u32 = ranges.iter().map(|r| r.end - r.start).sum();
            drawn_fractions.push(total as f32 / count as f32);
        }
        assert!(drawn_fractions[0] < 0.25, "{drawn_fractions:?}");
        assert!(drawn_fractions[1] < 0.75, "{drawn_fractions:?}");
        assert_eq!(drawn_fractions[2], 1.0, "the sun sees all of it");
        // No view: everything; an empty mesh: drawn whole (nothing to cull).
        let all = visible_ranges(None, bounds, &cs, count);
        assert_eq!((all.len(), all[0].start, all[0].end), (1, 0, count));
    }
}
