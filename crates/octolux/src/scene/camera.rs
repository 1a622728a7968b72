//! Pinhole cameras, shared by the GPU renderer and the path tracer so images line up exactly.

use super::Track;
use glam::{Mat4, Vec3};

/// A pinhole camera looking from `position` at `target`.
#[derive(Clone, Debug)]
pub struct Camera {
    /// Name for diagnostics and scene files.
    pub name: String,
    /// Eye position, world space.
    pub position: Vec3,
    /// Point looked at, world space.
    pub target: Vec3,
    /// Up hint.
    pub up: Vec3,
    /// Vertical field of view, radians (unused when `hfov` is set).
    pub vfov: f32,
    /// Horizontal field of view, radians, when the camera is specified that way (as Mitsuba
    /// scenes are by default): the vertical one then follows from the image's aspect ratio.
    pub hfov: Option<f32>,
    /// Near clip distance (m).
    pub near: f32,
    /// Far clip distance (m).
    pub far: f32,
    /// Animation applied to position and target.
    pub animation: Option<Track>,
}

impl Default for Camera {
    fn default() -> Self {
        Camera {
            name: "camera".into(),
            position: Vec3::new(0.0, 0.0, 3.0),
            target: Vec3::ZERO,
            up: Vec3::Y,
            vfov: 45f32.to_radians(),
            hfov: None,
            near: 0.01,
            far: 100.0,
            animation: None,
        }
    }
}

/// The matrices of a camera for one image size.
#[derive(Clone, Copy, Debug)]
pub struct CameraView {
    /// World to view.
    pub view: Mat4,
    /// View to clip (wgpu depth range 0..1).
    pub proj: Mat4,
    /// World to clip.
    pub view_proj: Mat4,
    /// Clip to world.
    pub inv_view_proj: Mat4,
    /// Eye position.
    pub position: Vec3,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
}

impl Camera {
    /// A camera that frames the axis-aligned box `bounds` from the +z side.
    pub fn framing(bounds: (Vec3, Vec3)) -> Camera {
        let (lo, hi) = bounds;
        let center = (lo + hi) * 0.5;
        let radius = ((hi - lo).length() * 0.5).max(1e-3);
        let vfov = 45f32.to_radians();
        let distance = radius / (vfov * 0.5).sin();
        Camera {
            name: "auto".into(),
            position: center + Vec3::new(0.0, radius * 0.2, distance),
            target: center,
            near: (distance - radius).max(distance * 1e-3) * 0.5,
            far: (distance + radius) * 2.0,
            vfov,
            ..Camera::default()
        }
    }

    /// The camera at time `t` (animation applied, `animation` cleared).
    pub fn at_time(&self, t: f32) -> Camera {
        let mut camera = self.clone();
        if let Some(track) = &self.animation {
            let m = track.transform_at(t);
            camera.position = m.transform_point3(self.position);
            camera.target = m.transform_point3(self.target);
        }
        camera.animation = None;
        camera
    }

    /// Matrices for an image of `width` x `height` pixels.
    pub fn view(&self, width: u32, height: u32) -> CameraView {
        let aspect = width.max(1) as f32 / height.max(1) as f32;
        let up = view_up((self.target - self.position).normalize_or_zero(), self.up);
        let view = Mat4::look_at_rh(self.position, self.target, up);
        let vfov = match self.hfov {
            Some(h) => 2.0 * ((h * 0.5).tan() / aspect).atan(),
            None => self.vfov,
        };
        let proj = Mat4::perspective_rh(vfov, aspect, self.near, self.far);
        let view_proj = proj * view;
        CameraView {
            view,
            proj,
            view_proj,
            inv_view_proj: view_proj.inverse(),
            position: self.position,
            width,
            height,
        }
    }
}

/// The up vector for a view along unit `forward`: `hint` unless it is (nearly) parallel to
/// `forward` or zero, otherwise the world axis least aligned with `forward`, which is never
/// parallel to it.
pub(crate) fn view_up(forward: Vec3, hint: Vec3) -> Vec3 {
    let hint = hint.normalize_or_zero();
    if forward.cross(hint).length() >= 1e-4 {
        return hint;
    }
    let a = forward.abs();
    if a.y <= a.x && a.y <= a.z {
        Vec3::Y
    } else if a.z <= a.x {
        Vec3::Z
    } else {
        Vec3::X
    }
}

impl CameraView {
    /// Unit direction of the primary ray through image position (`x`, `y`) in pixels, where
    /// (0, 0) is the top-left corner of the image and (0.5, 0.5) the centre of the first pixel.
    pub fn ray_direction(&self, x: f32, y: f32) -> Vec3 {
        let ndc_x = x / self.width as f32 * 2.0 - 1.0;
        let ndc_y = 1.0 - y / self.height as f32 * 2.0;
        // From the projection's focal lengths and the view's rotation rather than by
        // unprojecting a point on the far plane, which loses all precision when far / near is
        // large.
        let in_view = Vec3::new(ndc_x / self.proj.x_axis.x, ndc_y / self.proj.y_axis.y, -1.0);
        (glam::Mat3::from_mat4(self.view).transpose() * in_view).normalize()
    }

    /// World position seen at image position (`x`, `y`) in pixels (as [`Self::ray_direction`])
    /// whose depth-buffer value is `depth` (0..1, as the G-buffer holds it).
    pub fn world_point(&self, x: f32, y: f32, depth: f32) -> Vec3 {
        let ndc_x = x / self.width as f32 * 2.0 - 1.0;
        let ndc_y = 1.0 - y / self.height as f32 * 2.0;
        self.inv_view_proj
            .project_point3(Vec3::new(ndc_x, ndc_y, depth))
    }

    /// The world position at every pixel's centre of a depth buffer of this view's size
    /// (row by row, as [`crate::render::GBufferImages::depth`]), `None` where it holds the
    /// background (depth 1).
    pub fn world_points(&self, depth: &[f32]) -> Vec<Option<Vec3>> {
        let width = self.width.max(1) as usize;
        depth
            .iter()
            .enumerate()
            .map(|(i, &d)| {
                let (x, y) = ((i % width) as f32 + 0.5, (i / width) as f32 + 0.5);
                (d < 1.0).then(|| self.world_point(x, y, d))
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rays_are_exact_whatever_the_depth_range() {
        let camera = Camera {
            position: Vec3::new(0.3, 0.2, -1.0),
            target: Vec3::new(0.1, 0.3, 0.0),
            ..Camera::default()
        };
        let view = camera.view(64, 32);
        let far_plane = |x: f32, y: f32| {
            let ndc = Vec3::new(x / 64.0 * 2.0 - 1.0, 1.0 - y / 32.0 * 2.0, 1.0);
            (view.inv_view_proj.project_point3(ndc) - view.position).normalize()
        };
        for (x, y) in [(0.5, 0.5), (32.0, 16.0), (63.5, 2.5)] {
            assert!((view.ray_direction(x, y) - far_plane(x, y)).length() < 1e-5);
        }
        let deep = Camera {
            near: 1e-4,
            far: 1e4,
            ..camera
        }
        .view(64, 32);
        for (x, y) in [(0.5, 0.5), (32.0, 16.0), (63.5, 2.5)] {
            let d = deep.ray_direction(x, y);
            assert!((d - view.ray_direction(x, y)).length() < 1e-5, "{d}");
        }
    }

    #[test]
    fn an_up_parallel_to_the_view_gets_a_fallback_that_is_not() {
        for forward in [Vec3::Y, Vec3::NEG_Y, Vec3::Z, Vec3::NEG_Z, Vec3::X] {
            let camera = Camera {
                position: Vec3::ZERO,
                target: forward,
                up: forward,
                ..Camera::default()
            };
            let view = camera.view(8, 8);
            assert!(view.view.is_finite(), "looking along {forward}");
            let d = view.ray_direction(4.0, 4.0);
            assert!((d - forward).length() < 1e-3, "{forward}: {d}");
        }
    }
}
