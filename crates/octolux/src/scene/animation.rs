//! Keyframed rigid animation: translation and rotation over time, linearly interpolated
//! (rotations by slerp). Used by objects, lights and cameras alike.

use glam::{Mat4, Quat, Vec3};

/// One key of a [`Track`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Keyframe {
    /// Time in seconds.
    pub time: f32,
    /// Translation at this key.
    pub translation: Vec3,
    /// Rotation at this key (applied before the translation).
    pub rotation: Quat,
}

/// A keyframed rigid transform. Keys are sorted by time; before the first key the first key
/// holds, after the last the last holds, unless `looping`, in which case time wraps around the
/// track's duration.
///
/// ```
/// use glam::{Quat, Vec3};
/// use octolux::scene::{Keyframe, Track};
/// let key = |time, x| Keyframe { time, translation: Vec3::new(x, 0.0, 0.0), rotation: Quat::IDENTITY };
/// let track = Track::new(vec![key(0.0, 0.0), key(2.0, 1.0)], true).unwrap();
/// assert_eq!(track.sample(1.0).0.x, 0.5);
/// assert_eq!(track.sample(3.0).0.x, 0.5); // looping: t = 3 is t = 1
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct Track {
    /// Keys sorted by time (at least one).
    pub keys: Vec<Keyframe>,
    /// Whether time wraps around the last key.
    pub looping: bool,
}

impl Track {
    /// A track from keys in any order (sorted here). Returns `None` for an empty key list.
    pub fn new(mut keys: Vec<Keyframe>, looping: bool) -> Option<Track> {
        if keys.is_empty() {
            return None;
        }
        keys.sort_by(|a, b| a.time.total_cmp(&b.time));
        Some(Track { keys, looping })
    }

    /// The interpolated transform at time `t` seconds.
    pub fn transform_at(&self, t: f32) -> Mat4 {
        let (translation, rotation) = self.sample(t);
        Mat4::from_rotation_translation(rotation, translation)
    }

    /// Interpolated (translation, rotation) at time `t` (a NaN time holds the first key; a
    /// track without keys, which [`crate::scene::validate`] refuses, holds still at the
    /// origin).
    pub fn sample(&self, t: f32) -> (Vec3, Quat) {
        let (Some(&first), Some(&last)) = (self.keys.first(), self.keys.last()) else {
            return (Vec3::ZERO, Quat::IDENTITY);
        };
        let mut t = t;
        let duration = last.time - first.time;
        if self.looping && duration > 0.0 {
            t = first.time + (t - first.time).rem_euclid(duration);
        }
        // A NaN time (an infinite one on a looping track becomes NaN above) holds the first key.
        if t.is_nan() || t <= first.time {
            return (first.translation, first.rotation);
        }
        if t >= last.time {
            return (last.translation, last.rotation);
        }
        let i = self.keys.partition_point(|k| k.time <= t);
        let (a, b) = (self.keys[i - 1], self.keys[i]);
        // Between equal keys the object holds still exactly (slerp's rounding would move it
        // by a few ULPs from one frame to the next, and everything that watches for motion
        // would update).
        if (a.translation, a.rotation) == (b.translation, b.rotation) {
            return (a.translation, a.rotation);
        }
        let s = ((t - a.time) / (b.time - a.time).max(1e-9)).clamp(0.0, 1.0);
        (
            a.translation.lerp(b.translation, s),
            a.rotation.slerp(b.rotation, s),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn non_finite_times_hold_a_key() {
        let key = |time, x| Keyframe {
            time,
            translation: Vec3::new(x, 0.0, 0.0),
            rotation: Quat::IDENTITY,
        };
        for looping in [false, true] {
            let track = Track::new(vec![key(0.0, 1.0), key(2.0, 3.0)], looping).unwrap();
            assert_eq!(track.sample(f32::NAN).0.x, 1.0);
            assert!(track.sample(f32::INFINITY).0.is_finite());
            assert!(track.sample(f32::NEG_INFINITY).0.is_finite());
        }
    }

    #[test]
    fn a_track_without_keys_holds_still() {
        let track = Track {
            keys: Vec::new(),
            looping: true,
        };
        assert_eq!(track.sample(1.0), (Vec3::ZERO, Quat::IDENTITY));
        assert_eq!(track.transform_at(1.0), Mat4::IDENTITY);
    }

    #[test]
    fn interpolates_and_clamps() {
        let track = Track::new(
            vec![
                Keyframe {
                    time: 1.0,
                    translation: Vec3::X,
                    rotation: Quat::IDENTITY,
                },
                Keyframe {
                    time: 0.0,
                    translation: Vec3::ZERO,
                    rotation: Quat::IDENTITY,
                },
            ],
            false,
        )
        .unwrap();
        assert_eq!(track.sample(0.5).0, Vec3::new(0.5, 0.0, 0.0));
        assert_eq!(track.sample(-1.0).0, Vec3::ZERO);
        assert_eq!(track.sample(7.0).0, Vec3::X);
        let looping = Track {
            looping: true,
            ..track
        };
        assert!((looping.sample(1.25).0.x - 0.25).abs() < 1e-6);
    }

    #[test]
    fn equal_keys_hold_still_exactly() {
        // A turned object resting between two equal keys: every time in between gives the
        // same transform bit for bit, so nothing sees it move.
        let rest = Quat::from_rotation_y(0.7);
        let key = |time| Keyframe {
            time,
            translation: Vec3::new(0.4, 0.0, 0.1),
            rotation: rest,
        };
        let track = Track::new(vec![key(0.0), key(3.0)], false).unwrap();
        let first = track.transform_at(0.0);
        for i in 0..300 {
            assert_eq!(
                track.transform_at(i as f32 / 100.0),
                first,
                "t = {}",
                i as f32 / 100.0
            );
        }
    }
}
