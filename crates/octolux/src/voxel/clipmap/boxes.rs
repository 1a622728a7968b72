//! Box maths of the toroidal levels: which boxes of voxels an update revoxelises. When a level
//! scrolls with the camera, the slabs it newly covers ([`exposed_boxes`], at most three); on
//! a filtered clipmap, the voxels of a coarser level that the finer level stopped covering
//! ([`uncovered_boxes`], which [`covered_box`] and [`box_minus`] compute); around a moving
//! object, every level's box touching its bounds ([`boxes_touching`]). Boxes are half-open
//! `[lo, hi)` in the world-voxel coordinates of their level.

use super::ClipmapSettings;
use glam::{IVec3, Vec3};

/// One box of voxels `[lo, hi)` of one level that an update revoxelised.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct UpdateBox {
    /// Level.
    pub level: u32,
    /// First voxel (world-voxel coordinates of the level).
    pub lo: IVec3,
    /// One past the last voxel.
    pub hi: IVec3,
}

impl UpdateBox {
    /// Voxels in the box.
    pub fn volume(&self) -> u64 {
        let s = (self.hi - self.lo).max(IVec3::ZERO);
        s.x as u64 * s.y as u64 * s.z as u64
    }

    /// Whether the box holds no voxel.
    fn is_empty(&self) -> bool {
        (self.hi - self.lo).cmple(IVec3::ZERO).any()
    }

    /// The part of the box inside the level that starts at `origin` (`res` voxels per axis),
    /// or `None` where they do not overlap.
    pub fn clip_to_level(&self, origin: IVec3, res: i32) -> Option<UpdateBox> {
        let clipped = UpdateBox {
            lo: self.lo.max(origin),
            hi: self.hi.min(origin + IVec3::splat(res)),
            ..*self
        };
        (!clipped.is_empty()).then_some(clipped)
    }

    /// The box cut into slabs of at most `depth` voxels along z (the accumulation scratch
    /// holds that many z layers of a level).
    pub fn z_slices(&self, depth: i32) -> impl Iterator<Item = UpdateBox> + '_ {
        (self.lo.z..self.hi.z)
            .step_by(depth.max(1) as usize)
            .map(move |z| UpdateBox {
                lo: IVec3::new(self.lo.x, self.lo.y, z),
                hi: IVec3::new(self.hi.x, self.hi.y, (z + depth).min(self.hi.z)),
                ..*self
            })
            .filter(|part| part.volume() > 0)
    }
}

/// The voxels of level `level` that lie wholly inside the finer level starting at `fine`
/// (world-voxel coordinates of level `level - 1`): `[ceil(fine / 2), floor((fine + res) / 2))`.
pub fn covered_box(level: u32, fine: IVec3, res: i32) -> UpdateBox {
    UpdateBox {
        level,
        lo: (fine + IVec3::ONE).div_euclid(IVec3::splat(2)),
        hi: (fine + IVec3::splat(res)).div_euclid(IVec3::splat(2)),
    }
}

/// `a` minus `b` (same level) as at most 6 disjoint boxes.
pub fn box_minus(a: UpdateBox, b: UpdateBox) -> Vec<UpdateBox> {
    let lo = a.lo.max(b.lo);
    let hi = a.hi.min(b.hi);
    if a.volume() == 0 {
        return Vec::new();
    }
    if (hi - lo).cmple(IVec3::ZERO).any() {
        return vec![a];
    }
    let mut out = Vec::new();
    let mut rest = a;
    for axis in 0..3 {
        if rest.lo[axis] < lo[axis] {
            let mut slab = rest;
            slab.hi[axis] = lo[axis];
            out.push(slab);
            rest.lo[axis] = lo[axis];
        }
        if rest.hi[axis] > hi[axis] {
            let mut slab = rest;
            slab.lo[axis] = hi[axis];
            out.push(slab);
            rest.hi[axis] = hi[axis];
        }
    }
    out
}

/// The boxes of voxels in the level `[new, new + res)` that `[old, old + res)` did not cover:
/// one slab per axis the level moved along, each excluding the slabs before it (disjoint).
pub fn exposed_boxes(level: u32, old: Option<IVec3>, new: IVec3, res: i32) -> Vec<UpdateBox> {
    let whole = UpdateBox {
        level,
        lo: new,
        hi: new + IVec3::splat(res),
    };
    let Some(old) = old else {
        return vec![whole];
    };
    let delta = new - old;
    if delta.abs().max_element() >= res {
        return vec![whole];
    }
    let mut out = Vec::new();
    let mut rest = whole;
    for a in 0..3 {
        let d = delta[a];
        if d > 0 {
            let mut slab = rest;
            slab.lo[a] = old[a] + res;
            rest.hi[a] = old[a] + res;
            out.push(slab);
        } else if d < 0 {
            let mut slab = rest;
            slab.hi[a] = old[a];
            rest.lo[a] = old[a];
            out.push(slab);
        }
    }
    out
}

/// On a filtered clipmap whose levels moved from origins `old` to `new`: the voxels of each
/// coarser level that the finer level covered (so they were filtered from it) and covers no
/// longer, within the coarser level's old and new extents. They get voxelized on their own
/// again.
pub fn uncovered_boxes(
    settings: &ClipmapSettings,
    old: &[Option<IVec3>],
    new: &[Option<IVec3>],
) -> Vec<UpdateBox> {
    let res = settings.resolution as i32;
    let mut out = Vec::new();
    for l in 1..settings.levels as usize {
        let (Some(was), Some(now), Some(here)) = (old[l - 1], new[l - 1], old[l]) else {
            continue;
        };
        let there = new[l].unwrap_or(here);
        let level = UpdateBox {
            level: l as u32,
            lo: here.max(there),
            hi: (here + IVec3::splat(res)).min(there + IVec3::splat(res)),
        };
        let left = covered_box(l as u32, was, res);
        let clipped = UpdateBox {
            lo: left.lo.max(level.lo),
            hi: left.hi.min(level.hi),
            ..left
        };
        if clipped.is_empty() {
            continue;
        }
        out.extend(box_minus(clipped, covered_box(l as u32, now, res)));
    }
    out
}

/// The boxes of every level (first voxels `origins`, levels not yet placed skipped) that
/// cover the world-space box `[lo, hi]` with one voxel of margin, since touching counts,
/// clipped to each level's extent.
pub fn boxes_touching(
    settings: &ClipmapSettings,
    origins: &[Option<IVec3>],
    lo: Vec3,
    hi: Vec3,
) -> Vec<UpdateBox> {
    if !(lo.is_finite() && hi.is_finite()) {
        return Vec::new();
    }
    let res = settings.resolution as i32;
    let placed = origins.iter().enumerate();
    placed
        .filter_map(|(l, origin)| {
            let v = settings.level_voxel(l as u32);
            let around = UpdateBox {
                level: l as u32,
                lo: (lo / v).floor().as_ivec3() - IVec3::ONE,
                hi: (hi / v).floor().as_ivec3() + IVec3::splat(2),
            };
            around.clip_to_level((*origin)?, res)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exposed_boxes_are_the_new_minus_the_old_region() {
        let res = 8;
        let old = IVec3::new(3, -2, 5);
        for delta in [
            IVec3::new(2, 0, 0),
            IVec3::new(-3, 1, 0),
            IVec3::new(1, -1, 7),
            IVec3::new(0, 0, 0),
            IVec3::new(9, 0, 0),
        ] {
            let new = old + delta;
            let boxes = exposed_boxes(0, Some(old), new, res);
            let inside = |p: IVec3, o: IVec3| p.cmpge(o).all() && p.cmplt(o + res).all();
            for z in new.z..new.z + res {
                for y in new.y..new.y + res {
                    for x in new.x..new.x + res {
                        let p = IVec3::new(x, y, z);
                        let hits = boxes
                            .iter()
                            .filter(|b| p.cmpge(b.lo).all() && p.cmplt(b.hi).all())
                            .count();
                        let exposed = !inside(p, old) || delta.abs().max_element() >= res;
                        assert_eq!(hits, exposed as usize, "{p} for delta {delta}");
                    }
                }
            }
        }
        assert_eq!(exposed_boxes(2, None, old, res).len(), 1);
    }

    #[test]
    fn z_slices_cover_the_box_in_order() {
        let b = UpdateBox {
            level: 1,
            lo: IVec3::new(0, -2, -3),
            hi: IVec3::new(4, 5, 8),
        };
        let parts: Vec<UpdateBox> = b.z_slices(4).collect();
        let z: Vec<(i32, i32)> = parts.iter().map(|p| (p.lo.z, p.hi.z)).collect();
        assert_eq!(z, [(-3, 1), (1, 5), (5, 8)]);
        assert_eq!(parts.iter().map(UpdateBox::volume).sum::<u64>(), b.volume());
    }
}
