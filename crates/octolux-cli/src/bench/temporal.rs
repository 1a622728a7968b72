//! How a technique behaves over time: **flicker**, the frame-to-frame change of its indirect
//! irradiance at the same surface points, and **lag**, the frames its error takes to settle
//! after the light changes.
//!
//! Flicker is measured on the irradiance E (W/m^2), not the image: direct light and albedo are
//! exact in every technique, so only the GI can flicker, and E of a diffuse surface does not
//! depend on where it is seen from. With the camera still, pixel p is compared with pixel p of
//! the frame before; with the camera moving, the surface point under p is projected into the
//! frame before and E read there (bilinear, from four pixels that all see the same surface:
//! pixels at silhouettes and disocclusions are left out). Where what moves does not light what
//! is seen (a camera flying through a still scene, a light in another room), the reference's E
//! does not change at all, so every change measured is the technique's.

use anyhow::{bail, Context, Result};
use glam::{Vec3, Vec4};
use octolux::image_io::HdrImage;
use octolux::render::Renderer;
use octolux::scene::{CameraView, Scene};
use std::borrow::Cow;
use std::fmt;
use std::str::FromStr;

/// Frames the scene is held still before the still flicker is measured (techniques that
/// converge over frames settle first), and frames flicker is measured over.
pub const FLICKER_SETTLE: u32 = 4;
/// Frame-to-frame changes averaged per flicker figure.
pub const FLICKER_FRAMES: u32 = 4;
/// Frames the scene is held in the state before a lag event (the technique settles).
pub const LAG_SETTLE: u32 = 24;
/// Frames rendered after a lag event; the last one's error is the settled error.
pub const LAG_FRAMES: u32 = 24;
/// A frame after an event is settled when its error is within this fraction of the settled
/// error, plus [`LAG_FLOOR`].
pub const LAG_TOLERANCE: f64 = 0.1;
/// An absolute relMSE within which a frame counts as settled whatever the settled error: after
/// a light switches off and leaves the image black, a technique's settled error is 0 (or a
/// rounding error), and 10 % of it would ask for bit-exact convergence. Far below any
/// technique's error on a lit scene (0.01 and more on the shipped ones).
pub const LAG_FLOOR: f64 = 1e-4;

/// What one frame leaves for the flicker measure: E per pixel and the surface it lies on.
pub struct Snapshot {
    irradiance: Vec<Vec3>,
    /// World position per pixel; None on the background.
    positions: Vec<Option<Vec3>>,
    normals: Vec<Vec3>,
    view: CameraView,
}

impl Snapshot {
    /// The last frame `renderer` rendered.
    pub fn of(renderer: &Renderer) -> Result<Snapshot> {
        let Some(view) = renderer.last_view().cloned() else {
            bail!("internal error: no frame rendered before the flicker snapshot");
        };
        let irradiance = renderer.engine().read_indirect()?.pixels;
        let gbuffer = renderer.read_gbuffer()?;
        let positions = world_positions(&view, &gbuffer.depth);
        Ok(Snapshot {
            irradiance,
            positions,
            normals: gbuffer.normal,
            view,
        })
    }
}

/// World position of every pixel centre from standard depth (1 = background).
fn world_positions(view: &CameraView, depth: &[f32]) -> Vec<Option<Vec3>> {
    let (w, h) = (view.width as usize, view.height as usize);
    (0..w * h)
        .map(|i| {
            let d = depth[i];
            if d >= 1.0 {
                return None;
            }
            let (x, y) = ((i % w) as f32 + 0.5, (i / w) as f32 + 0.5);
            let ndc = Vec4::new(x / w as f32 * 2.0 - 1.0, 1.0 - y / h as f32 * 2.0, d, 1.0);
            let world = view.inv_view_proj * ndc;
            Some(world.truncate() / world.w)
        })
        .collect()
}

/// The change of E from `before` to `after` at the surface points both frames see:
/// (sum over those pixels and channels of |E_after - E_before|, sum of E_after). The same
/// camera compares pixel with pixel; a moved camera reprojects.
pub fn change(before: &Snapshot, after: &Snapshot) -> (f64, f64) {
    let (mut changed, mut total) = (0.0f64, 0.0f64);
    let same_camera = before.view.view_proj == after.view.view_proj;
    for (i, (position, e)) in after.positions.iter().zip(&after.irradiance).enumerate() {
        let Some(position) = position else { continue };
        let previous = if same_camera {
            before.positions[i].map(|_| before.irradiance[i])
        } else {
            reproject(before, *position, after.normals[i])
        };
        if let Some(previous) = previous {
            changed += (*e - previous).abs().element_sum() as f64;
            total += e.element_sum() as f64;
        }
    }
    (changed, total)
}

/// E of `frame` at world point `x` on a surface of normal `n`: bilinear between the four pixel
/// centres around x's projection, provided each of them sees the same surface (its point within
/// 1 % of the viewing distance of x's plane, its normal within about 8 degrees of x's, so that
/// E is not read across a crease or a normal map's bumps); None
/// otherwise.
fn reproject(frame: &Snapshot, x: Vec3, n: Vec3) -> Option<Vec3> {
    let clip = frame.view.view_proj * x.extend(1.0);
    if clip.w <= 0.0 {
        return None;
    }
    let (w, h) = (frame.view.width as usize, frame.view.height as usize);
    let px = (clip.x / clip.w + 1.0) * 0.5 * w as f32 - 0.5;
    let py = (1.0 - clip.y / clip.w) * 0.5 * h as f32 - 0.5;
    let (x0, y0) = (px.floor(), py.floor());
    if x0 < 0.0 || y0 < 0.0 || x0 as usize + 1 >= w || y0 as usize + 1 >= h {
        return None;
    }
    let (fx, fy) = (px - x0, py - y0);
    let tolerance = 0.01 * (x - frame.view.position).length();
    let mut sum = Vec3::ZERO;
    for (dx, dy, weight) in [
        (0, 0, (1.0 - fx) * (1.0 - fy)),
        (1, 0, fx * (1.0 - fy)),
        (0, 1, (1.0 - fx) * fy),
        (1, 1, fx * fy),
    ] {
        let q = (y0 as usize + dy) * w + x0 as usize + dx;
        let y = frame.positions[q]?;
        if (y - x).dot(n).abs() > tolerance || frame.normals[q].dot(n) < 0.99 {
            return None;
        }
        sum += weight * frame.irradiance[q];
    }
    Some(sum)
}

/// The mean over `times.len()` frames of the relative change of E from the frame before
/// (the first compared with `start`, the renderer's last frame): sum |dE| / sum E, 0 where the
/// technique adds no indirect light.
pub fn flicker(
    renderer: &mut Renderer,
    scene: &Scene,
    start: Snapshot,
    times: &[f32],
) -> Result<f64> {
    let mut previous = start;
    let mut sum = 0.0;
    for &t in times {
        renderer.render(scene, t)?;
        let snapshot = Snapshot::of(renderer)?;
        let (changed, total) = change(&previous, &snapshot);
        if total > 0.0 {
            sum += changed / total;
        }
        previous = snapshot;
    }
    Ok(sum / times.len().max(1) as f64)
}

/// Flicker with nothing moving: the scene held at `t` (camera, lights and objects still, so
/// the reference does not change), settled [`FLICKER_SETTLE`] frames (or the technique's
/// `settle_frames`, where more), then measured over
/// [`FLICKER_FRAMES`]. Zero for a technique whose image is a function of the scene alone.
pub fn still_flicker(renderer: &mut Renderer, scene: &Scene, t: f32) -> Result<f64> {
    // Held still means settled: at least the technique's own count (a probe history fills).
    let settle = FLICKER_SETTLE.max(renderer.technique().settle_frames());
    for _ in 0..settle {
        renderer.render(scene, t)?;
    }
    let start = Snapshot::of(renderer)?;
    flicker(renderer, scene, start, &[t; FLICKER_FRAMES as usize])
}

/// A change of the scene after which lag is measured.
#[derive(Clone, Debug, PartialEq)]
pub enum LagEvent {
    /// The scene held at one time, then at another: whatever animates jumps (a light moves, an
    /// object crosses the light).
    Jump { from: f32, to: f32 },
    /// A light (name or index) switches on (`on`) or off, the scene held at `--time`.
    Switch { light: String, on: bool },
}

impl FromStr for LagEvent {
    type Err = anyhow::Error;

    fn from_str(s: &str) -> Result<LagEvent> {
        let usage = "expected `jump:A..B` (scene times in s), `on:LIGHT` or `off:LIGHT` (a \
                     light's name or index)";
        let Some((kind, rest)) = s.split_once(':') else {
            bail!("lag event '{s}': {usage}");
        };
        match kind {
            "on" | "off" if !rest.trim().is_empty() => Ok(LagEvent::Switch {
                light: rest.trim().to_string(),
                on: kind == "on",
            }),
            "jump" => {
                let times = rest.split_once("..").and_then(|(a, b)| {
                    let (a, b) = (a.trim().parse::<f32>().ok()?, b.trim().parse::<f32>().ok()?);
                    (a.is_finite() && b.is_finite()).then_some((a, b))
                });
                match times {
                    Some((from, to)) => Ok(LagEvent::Jump { from, to }),
                    None => bail!("lag event '{s}': {usage}"),
                }
            }
            _ => bail!("lag event '{s}': {usage}"),
        }
    }
}

impl fmt::Display for LagEvent {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LagEvent::Jump { from, to } => write!(f, "jump:{from}..{to}"),
            LagEvent::Switch { light, on } => {
                write!(f, "{}:{light}", if *on { "on" } else { "off" })
            }
        }
    }
}

/// One state of the scene: the scene (with a light switched off where the event says) and the
/// time it is held at.
pub struct SceneState<'a> {
    pub scene: Cow<'a, Scene>,
    pub time: f32,
}

impl LagEvent {
    /// The states before and after the event; `time` is the bench's `--time`. An unknown light
    /// is an error naming the scene's lights.
    pub fn states<'a>(
        &self,
        scene: &'a Scene,
        time: f32,
    ) -> Result<(SceneState<'a>, SceneState<'a>)> {
        match self {
            LagEvent::Jump { from, to } => Ok((
                SceneState {
                    scene: Cow::Borrowed(scene),
                    time: *from,
                },
                SceneState {
                    scene: Cow::Borrowed(scene),
                    time: *to,
                },
            )),
            LagEvent::Switch { light, on } => {
                let index = light_index(scene, light)?;
                let mut dark = scene.clone();
                dark.lights[index].intensity = 0.0;
                let lit = SceneState {
                    scene: Cow::Borrowed(scene),
                    time,
                };
                let dark = SceneState {
                    scene: Cow::Owned(dark),
                    time,
                };
                Ok(if *on { (dark, lit) } else { (lit, dark) })
            }
        }
    }
}

/// The index of light `which` (its name or index) in `scene`.
fn light_index(scene: &Scene, which: &str) -> Result<usize> {
    let found = match which.parse::<usize>() {
        Ok(i) => (i < scene.lights.len()).then_some(i),
        Err(_) => scene.lights.iter().position(|l| l.name == which),
    };
    found.with_context(|| {
        let names: Vec<String> = scene
            .lights
            .iter()
            .enumerate()
            .map(|(i, l)| format!("{i} '{}'", l.name))
            .collect();
        format!(
            "scene '{}' has no light '{which}' (its lights: {})",
            scene.name,
            if names.is_empty() {
                "none".to_string()
            } else {
                names.join(", ")
            }
        )
    })
}

/// The error curve after an event and the lag read from it.
pub struct Lag {
    /// relMSE against the after-state's reference, one per frame after the event.
    pub rel_mse: Vec<f64>,
    /// Frames after the event until the error stays within [`LAG_TOLERANCE`] of the settled
    /// error (the last frame's): 0 when the first frame after the event already is.
    pub frames: u32,
}

/// Holds `before` for [`LAG_SETTLE`] frames, then renders `after` for [`LAG_FRAMES`] frames,
/// each judged against `reference` (the after-state's).
pub fn lag(
    renderer: &mut Renderer,
    before: &SceneState,
    after: &SceneState,
    reference: &HdrImage,
) -> Result<Lag> {
    for _ in 0..LAG_SETTLE {
        renderer.render(&before.scene, before.time)?;
    }
    let mut rel_mse = Vec::with_capacity(LAG_FRAMES as usize);
    for _ in 0..LAG_FRAMES {
        renderer.render(&after.scene, after.time)?;
        let image = renderer.read_hdr()?;
        rel_mse.push(octolux::metrics::rel_mse(&image, reference, None)?);
    }
    let frames = settled_after(&rel_mse, LAG_TOLERANCE, LAG_FLOOR);
    Ok(Lag { rel_mse, frames })
}

/// The first index from which every error is within `tolerance` (relative) plus `floor`
/// (absolute) of the last one.
pub fn settled_after(errors: &[f64], tolerance: f64, floor: f64) -> u32 {
    let Some(&settled) = errors.last() else {
        return 0;
    };
    let within = |e: f64| (e - settled).abs() <= tolerance * settled.abs() + floor;
    let unsettled = errors.iter().rposition(|&e| !within(e));
    unsettled.map_or(0, |i| i as u32 + 1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Mat4;
    use octolux::scene::Camera;

    /// A snapshot of a plane z = 0 facing +z seen from `eye`, with E(x) = `e(x)` at each pixel.
    fn plane_snapshot(eye: Vec3, e: impl Fn(Vec3) -> Vec3) -> Snapshot {
        let mut camera = Camera::framing((Vec3::splat(-1.0), Vec3::splat(1.0)));
        camera.position = eye;
        camera.target = Vec3::new(eye.x, eye.y, 0.0);
        let view = camera.view(32, 24);
        let (w, h) = (32usize, 24usize);
        let inverse: Mat4 = view.inv_view_proj;
        let mut positions = Vec::new();
        for i in 0..w * h {
            let (x, y) = ((i % w) as f32 + 0.5, (i / w) as f32 + 0.5);
            let ndc = |d: f32| {
                let p =
                    inverse * Vec4::new(x / w as f32 * 2.0 - 1.0, 1.0 - y / h as f32 * 2.0, d, 1.0);
                p.truncate() / p.w
            };
            // The ray through the pixel centre meets z = 0.
            let (a, b) = (ndc(0.0), ndc(0.5));
            let s = a.z / (a.z - b.z);
            positions.push(Some(a + (b - a) * s));
        }
        Snapshot {
            irradiance: positions.iter().map(|p| e(p.unwrap())).collect(),
            normals: vec![Vec3::Z; w * h],
            positions,
            view,
        }
    }

    #[test]
    fn a_still_field_seen_from_a_moving_camera_does_not_flicker() {
        // E linear in x, so bilinear reprojection reproduces it up to rounding.
        let e = |p: Vec3| Vec3::splat(2.0 + 0.5 * p.x + 0.25 * p.y);
        let a = plane_snapshot(Vec3::new(0.0, 0.0, 3.0), e);
        let b = plane_snapshot(Vec3::new(0.13, -0.07, 3.0), e);
        let (changed, total) = change(&a, &b);
        assert!(total > 0.0);
        assert!(changed / total < 1e-5, "{}", changed / total);
        // Most pixels are compared (the camera moved by a few pixels).
        let compared = total / 2.0 / 3.0 / (32.0 * 24.0);
        assert!(compared > 0.6, "{compared}");
    }

    #[test]
    fn a_field_that_changes_flickers_by_its_relative_change() {
        let a = plane_snapshot(Vec3::new(0.0, 0.0, 3.0), |_| Vec3::ONE);
        let b = plane_snapshot(Vec3::new(0.1, 0.0, 3.0), |_| Vec3::splat(1.1));
        let (changed, total) = change(&a, &b);
        assert!(
            (changed / total - 0.1 / 1.1).abs() < 1e-5,
            "{}",
            changed / total
        );
        // The same camera compares pixel with pixel, exactly.
        let c = plane_snapshot(Vec3::new(0.0, 0.0, 3.0), |_| Vec3::splat(1.25));
        let (changed, total) = change(&a, &c);
        assert_eq!(changed / total, 0.25 * 3.0 * 768.0 / (1.25 * 3.0 * 768.0));
    }

    #[test]
    fn pixels_that_see_another_surface_are_not_compared() {
        let a = plane_snapshot(Vec3::new(0.0, 0.0, 3.0), |_| Vec3::ONE);
        let mut b = plane_snapshot(Vec3::new(0.1, 0.0, 3.0), |_| Vec3::splat(5.0));
        // The frame before saw a different (nearer) surface everywhere.
        let mut a_near = a;
        for p in a_near.positions.iter_mut().flatten() {
            p.z += 0.5;
        }
        let (changed, total) = change(&a_near, &b);
        assert_eq!((changed, total), (0.0, 0.0));
        b.positions.iter_mut().for_each(|p| *p = None);
        assert_eq!(change(&a_near, &b), (0.0, 0.0));
    }

    #[test]
    fn lag_is_the_frames_until_the_error_stays_near_the_settled_one() {
        assert_eq!(settled_after(&[0.5, 0.3, 0.2, 0.105, 0.1], 0.1, 0.0), 3);
        assert_eq!(settled_after(&[0.5, 0.3, 0.2, 0.111, 0.1], 0.1, 0.0), 4);
        assert_eq!(settled_after(&[0.1, 0.1, 0.1], 0.1, 0.0), 0);
        // A frame that strays again after coming close counts as not settled.
        assert_eq!(settled_after(&[0.1, 0.5, 0.1, 0.1], 0.1, 0.0), 2);
        assert_eq!(settled_after(&[], 0.1, 0.0), 0);
        // Settling to a black image: the floor decides.
        assert_eq!(settled_after(&[1.3, 0.1, 1e-3, 5e-5, 1e-11], 0.1, 1e-4), 3);
    }

    #[test]
    fn lag_events_parse_and_print() {
        let jump: LagEvent = "jump:0..1.5".parse().unwrap();
        assert_eq!(jump, LagEvent::Jump { from: 0.0, to: 1.5 });
        assert_eq!(jump.to_string(), "jump:0..1.5");
        let on: LagEvent = "on:ceiling-spot".parse().unwrap();
        assert_eq!(on.to_string(), "on:ceiling-spot");
        for bad in [
            "jump:0",
            "jump:a..1",
            "on:",
            "flash:1",
            "0..1",
            "jump:0..inf",
        ] {
            let error = bad.parse::<LagEvent>().unwrap_err().to_string();
            assert!(error.contains("expected `jump:A..B`"), "{bad}: {error}");
        }
    }

    #[test]
    fn a_switched_light_is_dark_on_one_side_of_the_event() {
        let scene = octolux::scene::cornell::scene();
        let name = scene.lights[0].name.clone();
        let event: LagEvent = format!("on:{name}").parse().unwrap();
        let (before, after) = event.states(&scene, 0.0).unwrap();
        assert_eq!(before.scene.lights[0].intensity, 0.0);
        assert_eq!(after.scene.lights[0].intensity, scene.lights[0].intensity);
        let error = "off:lamp"
            .parse::<LagEvent>()
            .unwrap()
            .states(&scene, 0.0)
            .err()
            .unwrap()
            .to_string();
        assert!(
            error.contains("no light 'lamp'") && error.contains(&name),
            "{error}"
        );
    }
}
