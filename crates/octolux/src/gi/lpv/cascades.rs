//! Placement of the volumes: the uniform LPV (and the octree's level 0) is fitted to the scene
//! bounds with cubic cells; cascades are nested around a focus point in front of the camera,
//! each snapped to its own cell size so that camera motion moves them by whole cells (no
//! swimming of the light).

use crate::scene::CameraView;
use glam::Vec3;

/// Origin and cell side of an `n`^3 grid of cubic cells enclosing `bounds`, centred on them,
/// with a small margin so surfaces on the bounds are inside.
pub fn fit(bounds: (Vec3, Vec3), n: u32) -> (Vec3, f32) {
    let (lo, hi) = bounds;
    let extent = (hi - lo).max_element().max(1e-3);
    let cell = extent * 1.02 / n as f32;
    let centre = (lo + hi) * 0.5;
    (centre - Vec3::splat(cell * n as f32 * 0.5), cell)
}

/// Origin and cell side of `count` nested cascades of `n`^3 cells. The finest is `extent` wide
/// (0: 1.25 x the largest scene extent, so that its cells are no finer than the VPL spacing
/// of a scene-sized RSM); each coarser one is twice as wide. All are centred on the point of
/// the view ray closest to the scene centre, snapped to their cell size.
pub fn place(
    bounds: (Vec3, Vec3),
    view: &CameraView,
    count: usize,
    n: u32,
    extent: f32,
) -> Vec<(Vec3, f32)> {
    let (lo, hi) = bounds;
    let finest = if extent > 0.0 {
        extent
    } else {
        (hi - lo).max_element().max(1e-3) * 1.25
    };
    let forward = (view.view.inverse().transform_vector3(Vec3::NEG_Z)).normalize_or(Vec3::NEG_Z);
    let centre = (lo + hi) * 0.5;
    let focus = view.position + forward * forward.dot(centre - view.position).max(0.0);
    (0..count)
        .map(|i| {
            let width = finest * (1u32 << i) as f32;
            let cell = width / n as f32;
            let snapped = (focus / cell).round() * cell;
            (snapped - Vec3::splat(cell * (n / 2) as f32), cell)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Camera;

    #[test]
    fn cascades_nest_double_and_snap() {
        let view = Camera {
            position: Vec3::new(0.3, 0.2, 5.0),
            target: Vec3::ZERO,
            ..Camera::default()
        }
        .view(64, 64);
        let bounds = (Vec3::splat(-1.0), Vec3::splat(1.0));
        let c = place(bounds, &view, 3, 16, 0.0);
        assert_eq!(c.len(), 3);
        for i in 0..3 {
            let (origin, cell) = c[i];
            let snapped = origin / cell;
            assert!((snapped - snapped.round()).abs().max_element() < 1e-3);
            if i > 0 {
                assert!((c[i].1 / c[i - 1].1 - 2.0).abs() < 1e-5);
                // The finer cascade lies inside the coarser one.
                let (o, s) = c[i - 1];
                assert!(o.cmpge(origin).all());
                assert!((o + Vec3::splat(16.0 * s))
                    .cmple(origin + Vec3::splat(16.0 * cell))
                    .all());
            }
        }
        let (o, cell) = c[2];
        assert!(o.cmple(bounds.0).all() && (o + Vec3::splat(16.0 * cell)).cmpge(bounds.1).all());
        let (origin, cell) = fit(bounds, 8);
        assert!(origin.cmple(bounds.0).all());
        assert!((origin + Vec3::splat(8.0 * cell)).cmpge(bounds.1).all());
    }
}
