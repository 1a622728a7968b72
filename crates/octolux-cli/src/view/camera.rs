//! The fly camera: WASD to move, a mouse drag to look, Q/E (or Ctrl/Space) down and up, the
//! mouse wheel for speed; it starts at a scene camera and R returns to it.

use glam::Vec3;
use octolux::scene::Camera;
use std::collections::HashSet;
use winit::keyboard::KeyCode;

/// Radians of turn per pixel of mouse drag.
const LOOK_PER_PIXEL: f32 = 0.004;
/// Factor of speed per wheel notch.
const SPEED_STEP: f32 = 1.2;
/// Pitch stays this far from straight up or down, where yaw would be undefined.
const PITCH_LIMIT: f32 = 1.55;

/// A camera that flies freely; the scene's up vector stays up.
#[derive(Clone, Debug)]
pub struct FlyCamera {
    /// The scene camera it started from (field of view, clip planes and up are kept).
    base: Camera,
    /// Horizontal reference direction (unit, perpendicular to `up`): yaw 0.
    ahead: Vec3,
    up: Vec3,
    position: Vec3,
    yaw: f32,
    pitch: f32,
    /// Metres per second.
    pub speed: f32,
    held: HashSet<KeyCode>,
}

impl FlyCamera {
    /// A fly camera at `camera` (a scene camera already evaluated at a time), moving at a speed
    /// that crosses `scene_size` metres in four seconds.
    pub fn new(camera: &Camera, scene_size: f32) -> FlyCamera {
        let up = camera.up.normalize_or(Vec3::Y);
        let forward = (camera.target - camera.position).normalize_or(-Vec3::Z);
        let flat = forward - up * forward.dot(up);
        // Looking straight along `up`: any horizontal direction serves as yaw 0.
        let ahead = flat
            .try_normalize()
            .unwrap_or_else(|| up.any_orthonormal_vector());
        FlyCamera {
            base: camera.clone(),
            ahead,
            up,
            position: camera.position,
            yaw: 0.0,
            pitch: forward
                .dot(up)
                .clamp(-1.0, 1.0)
                .asin()
                .clamp(-PITCH_LIMIT, PITCH_LIMIT),
            speed: (scene_size / 4.0).max(1e-3),
            held: HashSet::new(),
        }
    }

    /// Unit view direction.
    pub fn forward(&self) -> Vec3 {
        let left = self.up.cross(self.ahead);
        let horizontal = self.ahead * self.yaw.cos() + left * self.yaw.sin();
        horizontal * self.pitch.cos() + self.up * self.pitch.sin()
    }

    /// The scene camera for this pose (no animation).
    pub fn camera(&self) -> Camera {
        Camera {
            position: self.position,
            target: self.position + self.forward(),
            up: self.up,
            animation: None,
            ..self.base.clone()
        }
    }

    /// A key went down (true) or up (false); returns whether the camera uses that key.
    pub fn key(&mut self, code: KeyCode, down: bool) -> bool {
        if direction_of(code).is_none() {
            return false;
        }
        if down {
            self.held.insert(code);
        } else {
            self.held.remove(&code);
        }
        true
    }

    /// Forgets held keys (the window lost focus: their release would never arrive).
    pub fn release_keys(&mut self) {
        self.held.clear();
    }

    /// Turns by a mouse drag of (`dx`, `dy`) pixels (right and down positive).
    pub fn look(&mut self, dx: f32, dy: f32) {
        self.yaw -= dx * LOOK_PER_PIXEL;
        self.pitch = (self.pitch - dy * LOOK_PER_PIXEL).clamp(-PITCH_LIMIT, PITCH_LIMIT);
    }

    /// Scales the speed by `notches` wheel notches (positive: faster).
    pub fn wheel(&mut self, notches: f32) {
        self.speed = (self.speed * SPEED_STEP.powf(notches)).clamp(1e-4, 1e5);
    }

    /// Moves along the held keys for `dt` seconds; returns whether it moved.
    pub fn advance(&mut self, dt: f32) -> bool {
        let forward = self.forward();
        let right = forward.cross(self.up).normalize_or_zero();
        let mut step = Vec3::ZERO;
        for code in &self.held {
            if let Some((f, r, u)) = direction_of(*code) {
                step += forward * f + right * r + self.up * u;
            }
        }
        if step == Vec3::ZERO || dt <= 0.0 {
            return false;
        }
        self.position += step.normalize() * self.speed * dt;
        true
    }
}

/// (forward, right, up) of a movement key.
fn direction_of(code: KeyCode) -> Option<(f32, f32, f32)> {
    Some(match code {
        KeyCode::KeyW | KeyCode::ArrowUp => (1.0, 0.0, 0.0),
        KeyCode::KeyS | KeyCode::ArrowDown => (-1.0, 0.0, 0.0),
        KeyCode::KeyD | KeyCode::ArrowRight => (0.0, 1.0, 0.0),
        KeyCode::KeyA | KeyCode::ArrowLeft => (0.0, -1.0, 0.0),
        KeyCode::KeyE | KeyCode::Space => (0.0, 0.0, 1.0),
        KeyCode::KeyQ | KeyCode::ControlLeft | KeyCode::ControlRight => (0.0, 0.0, -1.0),
        _ => return None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn start() -> Camera {
        Camera {
            position: Vec3::new(0.0, 1.0, 3.0),
            target: Vec3::new(0.0, 1.0, 0.0),
            ..Camera::default()
        }
    }

    #[test]
    fn starts_at_the_scene_camera() {
        let fly = FlyCamera::new(&start(), 4.0);
        let c = fly.camera();
        assert!((c.position - start().position).length() < 1e-6);
        let dir = (c.target - c.position).normalize();
        assert!((dir - Vec3::NEG_Z).length() < 1e-5, "{dir}");
        assert_eq!(c.vfov, start().vfov);
        assert_eq!(fly.speed, 1.0);
    }

    #[test]
    fn keys_move_in_view_space_and_the_wheel_scales_speed() {
        let mut fly = FlyCamera::new(&start(), 4.0);
        assert!(fly.key(KeyCode::KeyW, true));
        assert!(!fly.key(KeyCode::KeyZ, true));
        assert!(fly.advance(0.5));
        assert!((fly.camera().position - Vec3::new(0.0, 1.0, 2.5)).length() < 1e-5);
        fly.key(KeyCode::KeyW, false);
        fly.key(KeyCode::KeyD, true);
        fly.wheel(1.0);
        fly.advance(1.0);
        // Right of a camera looking down -z is +x; one notch is 1.2x the speed.
        assert!((fly.camera().position - Vec3::new(1.2, 1.0, 2.5)).length() < 1e-5);
        fly.release_keys();
        assert!(!fly.advance(1.0));
        fly.key(KeyCode::KeyE, true);
        fly.advance(1.0);
        assert!((fly.camera().position.y - 2.2).abs() < 1e-5);
    }

    #[test]
    fn looking_turns_and_stops_short_of_the_poles() {
        let mut fly = FlyCamera::new(&start(), 4.0);
        // A quarter turn to the right: from -z to +x.
        fly.look(std::f32::consts::FRAC_PI_2 / LOOK_PER_PIXEL, 0.0);
        assert!(
            (fly.forward() - Vec3::X).length() < 1e-4,
            "{}",
            fly.forward()
        );
        fly.look(0.0, -1e6);
        assert!(fly.forward().y < 1.0 && fly.forward().y > 0.99);
        let c = fly.camera();
        assert!(c.target.is_finite());
    }
}
