//! CPU reference path tracer: the ground truth every technique is judged against.
//!
//! It renders exactly what the GPU renderer models, from the same [`Scene`] and [`SceneFrame`]:
//! Lambertian surfaces (BRDF albedo/pi, albedo = `base_color` x base colour texture), emissive
//! surfaces (radiance from the front face, the side the vertex normals point to, or from both
//! with `emission_two_sided`), punctual point and spot lights (W/sr, inverse-square falloff,
//! [`Light::spot_factor`](crate::scene::Light::spot_factor)), directional lights (irradiance
//! `radiant()` arriving from `-direction`) and the sky ([`Scene::sky`]; black without one),
//! which is also what the camera sees where its rays leave the scene. Primary rays go through
//! [`CameraView::ray_direction`](crate::scene::CameraView) so the images line up with the
//! GPU's pixel for pixel.
//!
//! Light transport:
//! - surfaces are two-sided for reflection: the geometric and shading normals are turned
//!   towards the arriving ray; the shading normal is used for cosines, the geometric one for
//!   ray offsets and to reject light from below the true surface;
//! - punctual lights are sampled by next-event estimation with any-hit shadow rays;
//! - emissive triangles and the sky are sampled both ways: next-event estimation (triangles
//!   picked by power and a point uniformly on them, `emitters.rs`; the sky by importance
//!   sampling of its map, `sky.rs`) and the cosine-sampled continuation ray that hits the
//!   emitter or escapes, combined with the power heuristic; at the last vertex of a
//!   bounce-limited path that ray only looks for emitters (as Mitsuba's path integrator does:
//!   light sampling alone leaves shadowed points noisy where a sun draws its samples);
//! - alpha-masked materials are holes (for every ray) where texture alpha x opacity < cutoff,
//!   so a clear (transmissive) material lets every ray through;
//! - Russian roulette from [`ReferenceSettings::roulette_start`] on, with survival probability
//!   equal to the surface albedo's largest channel (at most 0.95), which is unbiased and keeps
//!   the path weight constant in a grey furnace; unlimited paths are cut at
//!   [`crate::transport::MAX_PATH_VERTICES`] vertices, where the remaining energy is below 0.95^256.
//!
//! Light is counted by its reflections between emitter and eye ([`crate::transport`]): light
//! from lights and the sky is followed for [`Transport::max_light_reflections`] reflections,
//! light from emissive surfaces for [`Transport::max_emissive_reflections`] (the same by
//! default; fewer when judging a technique that treats them otherwise).
//!
//! Output split ([`ReferenceImages`]), with path vertices x1 (primary hit), x2, ...:
//! - `direct` = emission of x1 + light arriving at x1 straight from any emitter (lights, sky,
//!   emissive surfaces) reflected there (or the sky itself where the primary ray escapes);
//! - `indirect` = for each bounce k = 1..=n: light arriving at x(k+1) straight from an emitter,
//!   reflected there and carried back to the eye;
//! - `total` = `direct` + `indirect`;
//! - `indirect_irradiance` E = irradiance (W/m^2) arriving at x1 over the shading-normal
//!   hemisphere from the indirect paths, so that `indirect` = albedo/pi x E at every primary
//!   hit of uniform albedo. This is what GI techniques output and compose multiplies by
//!   albedo/pi; compare techniques on E to exclude texture and direct-light differences;
//! - `emitter_irradiance` = irradiance arriving at x1 straight from emissive surfaces (part of
//!   `direct`): a technique whose indirect light carries the emissive surfaces' light
//!   ([`EmissiveSurfaces::OneBounceFewer`]) outputs E + this ([`ReferenceImages::gi_irradiance`]);
//! - `albedo` = the primary hit's albedo (black where the ray misses), averaged over the
//!   pixel's samples, to recompose `direct + albedo/pi x E` like the GPU does.

mod accel;
mod emitters;
mod sampling;
mod sky;

use crate::image_io::HdrImage;
use crate::scene::{LightKind, Scene, SceneFrame};
use crate::transport::{Bounces, EmissiveSurfaces, Transport};
use crate::{Error, Result};
use accel::{Accel, Hit};
use emitters::EmitterSampler;
use glam::{DVec3, Vec3};
use rayon::prelude::*;
use sampling::{cosine_hemisphere, r2, Rng};
use sky::{power_heuristic, SkySampler};
use std::f32::consts::{FRAC_1_PI, PI};
use std::time::{Duration, Instant};

/// A hash of the reference renderer's own source (this module's files), for caches of its
/// images: a change to the path tracer gives another revision, so a cached reference made by
/// an older one is not taken for a new one. (The scene side, [`Scene::fingerprint`], covers
/// what is rendered.)
pub fn code_revision() -> u64 {
    use std::hash::{DefaultHasher, Hasher};
    const SOURCES: [&str; 5] = [
        include_str!("mod.rs"),
        include_str!("accel.rs"),
        include_str!("emitters.rs"),
        include_str!("sampling.rs"),
        include_str!("sky.rs"),
    ];
    let mut h = DefaultHasher::new();
    for source in SOURCES {
        h.write(source.as_bytes());
    }
    h.finish()
}

/// Settings of a reference render.
#[derive(Clone, Debug)]
pub struct ReferenceSettings {
    /// Samples per pixel to reach.
    pub spp: u32,
    /// Which paths to follow: bounces of every emitter's light.
    pub bounces: Bounces,
    /// How light from emissive surfaces is counted (like any emitter's by default).
    pub emissive: EmissiveSurfaces,
    /// Stop after the pass during which this much time has passed (at least one pass runs).
    pub time_budget: Option<Duration>,
    /// Seed of all random numbers; same seed and settings give the same image whatever the
    /// thread count or pass sizes.
    pub seed: u64,
    /// Number of bounces followed before Russian roulette may end a path.
    pub roulette_start: u32,
    /// Largest number of samples per pixel in one progressive pass (passes start at 1 sample
    /// and double up to this, so a time budget is checked often early on).
    pub max_pass_spp: u32,
}

impl ReferenceSettings {
    /// The transport these settings follow.
    pub fn transport(&self) -> Transport {
        Transport {
            bounces: self.bounces,
            emissive: self.emissive,
        }
    }

    /// Follows `transport`.
    pub fn with_transport(self, transport: Transport) -> ReferenceSettings {
        ReferenceSettings {
            bounces: transport.bounces,
            emissive: transport.emissive,
            ..self
        }
    }
}

impl Default for ReferenceSettings {
    fn default() -> Self {
        ReferenceSettings {
            spp: 64,
            bounces: Bounces::Unlimited,
            emissive: EmissiveSurfaces::LikeLights,
            time_budget: None,
            seed: 0,
            roulette_start: 3,
            max_pass_spp: 16,
        }
    }
}

/// The images of a reference render (all linear HDR, same size).
#[derive(Clone, Debug)]
pub struct ReferenceImages {
    /// Emission seen directly plus light arriving straight from any emitter reflected at the
    /// primary hit.
    pub direct: HdrImage,
    /// Light that bounced at least once more, up to the bounce limit.
    pub indirect: HdrImage,
    /// `direct + indirect`.
    pub total: HdrImage,
    /// Indirect irradiance at the primary hit, W/m^2 (see the module docs).
    pub indirect_irradiance: HdrImage,
    /// Irradiance at the primary hit arriving straight from emissive surfaces, W/m^2 (part of
    /// the direct light).
    pub emitter_irradiance: HdrImage,
    /// Albedo at the primary hit.
    pub albedo: HdrImage,
    /// Samples per pixel actually taken (less than asked for when the time budget ran out).
    pub spp_done: u32,
}

impl ReferenceImages {
    /// The irradiance a GI technique outputs under `emissive`: the indirect irradiance, plus
    /// the emissive surfaces' direct irradiance where the technique carries it in its indirect
    /// light ([`EmissiveSurfaces::OneBounceFewer`]).
    pub fn gi_irradiance(&self, emissive: EmissiveSurfaces) -> HdrImage {
        let mut e = self.indirect_irradiance.clone();
        if emissive == EmissiveSurfaces::OneBounceFewer {
            for (p, q) in e.pixels.iter_mut().zip(&self.emitter_irradiance.pixels) {
                *p += *q;
            }
        }
        e
    }
}

/// Renders `frame` of `scene` at `width` x `height`. `progress(done, total)` is called after
/// every pass with the samples per pixel done so far and the target.
pub fn render(
    scene: &Scene,
    frame: &SceneFrame,
    width: u32,
    height: u32,
    settings: &ReferenceSettings,
    progress: &dyn Fn(u32, u32),
) -> Result<ReferenceImages> {
    crate::image_io::check_image_size(width, height)?;
    if settings.spp == 0 {
        return Err(Error::InvalidArgument("spp must be at least 1".into()));
    }
    let start = Instant::now();
    let accel = Accel::build(scene, frame)?;
    let transport = settings.transport();
    let tracer = Tracer {
        emitters: EmitterSampler::new(&accel),
        accel,
        sky: scene
            .sky
            .as_ref()
            .filter(|s| !s.is_black())
            .map(SkySampler::new),
        frame,
        max_light_reflections: transport.max_light_reflections(),
        max_emissive_reflections: transport.max_emissive_reflections(),
        roulette_start: settings.roulette_start,
    };
    let view = frame.camera.view(width, height);
    let (w, h) = (width as usize, height as usize);
    let mut accum = vec![Accum::default(); w * h];
    let mut done = 0u32;
    let mut pass = 1u32;
    while done < settings.spp {
        let n = pass.min(settings.spp - done);
        accum.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
            for (x, acc) in row.iter_mut().enumerate() {
                let pixel = (y * w + x) as u64;
                let shift = Rng::new(settings.seed, pixel, u64::MAX).next_vec2();
                for s in done..done + n {
                    let mut rng = Rng::new(settings.seed, pixel, s as u64);
                    let jitter = r2(s, shift);
                    let dir = view.ray_direction(x as f32 + jitter.x, y as f32 + jitter.y);
                    acc.add(&tracer.trace(view.position, dir, &mut rng));
                }
            }
        });
        done += n;
        progress(done, settings.spp);
        pass = (pass * 2).min(settings.max_pass_spp.max(1));
        if settings
            .time_budget
            .is_some_and(|budget| start.elapsed() >= budget)
        {
            break;
        }
    }
    let scale = 1.0 / done as f64;
    let image = |f: &dyn Fn(&Accum) -> DVec3| HdrImage {
        width,
        height,
        pixels: accum.iter().map(|a| (f(a) * scale).as_vec3()).collect(),
    };
    let direct = image(&|a| a.direct);
    let indirect = image(&|a| a.indirect);
    let total = HdrImage {
        width,
        height,
        pixels: direct
            .pixels
            .iter()
            .zip(&indirect.pixels)
            .map(|(d, i)| *d + *i)
            .collect(),
    };
    Ok(ReferenceImages {
        indirect_irradiance: image(&|a| a.irradiance),
        emitter_irradiance: image(&|a| a.emitter_irradiance),
        albedo: image(&|a| a.albedo),
        direct,
        indirect,
        total,
        spp_done: done,
    })
}

/// Per-pixel sums (f64 so long renders do not lose small samples).
#[derive(Clone, Default)]
struct Accum {
    direct: DVec3,
    indirect: DVec3,
    irradiance: DVec3,
    emitter_irradiance: DVec3,
    albedo: DVec3,
}

impl Accum {
    fn add(&mut self, s: &PathSample) {
        self.direct += s.direct.as_dvec3();
        self.indirect += s.indirect.as_dvec3();
        self.irradiance += s.irradiance.as_dvec3();
        self.emitter_irradiance += s.emitter_irradiance.as_dvec3();
        self.albedo += s.albedo.as_dvec3();
    }
}

/// What one camera path contributes.
#[derive(Default)]
struct PathSample {
    direct: Vec3,
    indirect: Vec3,
    irradiance: Vec3,
    emitter_irradiance: Vec3,
    albedo: Vec3,
}

/// A shading point.
struct Surface {
    position: Vec3,
    /// Geometric normal, facing the arriving ray.
    geometric: Vec3,
    /// Shading normal, on the same side as `geometric`.
    shading: Vec3,
    albedo: Vec3,
    emission: Vec3,
}

struct Tracer<'a> {
    accel: Accel<'a>,
    sky: Option<SkySampler<'a>>,
    emitters: Option<EmitterSampler>,
    frame: &'a SceneFrame,
    /// Reflections followed of the lights' and the sky's light (1 = direct).
    max_light_reflections: u32,
    /// Reflections followed of emissive surfaces' light (0 = seen only).
    max_emissive_reflections: u32,
    roulette_start: u32,
}

/// Irradiance arriving at a shading point straight from the emitters, by kind.
#[derive(Default)]
struct Arriving {
    /// From punctual lights and the sky.
    lights: Vec3,
    /// From emissive surfaces.
    emissive: Vec3,
}

/// Ray origin offset: relative to the coordinates' magnitude so it works at any scene scale.
fn offset(p: Vec3, n: Vec3) -> Vec3 {
    p + n * (1e-5 * (1.0 + p.abs().max_element()))
}

impl Tracer<'_> {
    fn surface(&self, hit: &Hit, origin: Vec3, dir: Vec3) -> Surface {
        let tri = &self.accel.tris[hit.tri as usize];
        let material = &self.accel.materials[tri.material as usize];
        let (u, v) = (hit.u, hit.v);
        let winding = tri.winding_normal();
        let interpolated = tri.interpolated_normal(u, v);
        let geometric = if winding.dot(dir) > 0.0 {
            -winding
        } else {
            winding
        };
        let shading = if interpolated.dot(geometric) < 0.0 {
            -interpolated
        } else {
            interpolated
        };
        let albedo = match material.texture {
            Some(tex) => material.base_color * tex.sample(tri.uv(u, v)).truncate(),
            None => material.base_color,
        };
        Surface {
            position: origin + dir * hit.t,
            geometric,
            shading,
            albedo,
            emission: self.accel.emitted(tri, u, v, dir),
        }
    }

    /// Irradiance at `s` arriving straight from the lights and the sky (with `lights`) and
    /// from emissive surfaces (with `emissive`). The sky and the emissive surfaces are sampled
    /// by next-event estimation, their samples weighted by the power heuristic against cosine
    /// sampling; the caller adds the other half when its cosine-sampled ray escapes or hits an
    /// emitter.
    fn arriving(&self, s: &Surface, rng: &mut Rng, lights: bool, emissive: bool) -> Arriving {
        let mut out = Arriving::default();
        let origin = offset(s.position, s.geometric);
        if emissive {
            out.emissive = self.emitter_irradiance_sample(s, origin, rng);
        }
        if !lights {
            return out;
        }
        out.lights = self.sky_irradiance_sample(s, origin, rng);
        for light in &self.frame.lights {
            let (wi, distance, arriving) = match light.kind {
                LightKind::Directional => {
                    let wi = -light.direction.normalize_or(Vec3::NEG_Y);
                    (wi, f32::INFINITY, light.radiant())
                }
                LightKind::Point | LightKind::Spot { .. } => {
                    let to = light.position - s.position;
                    let d2 = to.length_squared();
                    if d2 <= 0.0 {
                        continue;
                    }
                    let d = d2.sqrt();
                    let wi = to / d;
                    let spot = light.spot_factor(-wi);
                    (wi, d, light.radiant() * (spot / d2))
                }
            };
            let cos = s.shading.dot(wi);
            if cos <= 0.0 || s.geometric.dot(wi) <= 0.0 || arriving.max_element() <= 0.0 {
                continue;
            }
            let t_max = if distance.is_finite() {
                // Stop short of the light; the offset origin is slightly closer already.
                (light.position - origin).length() * (1.0 - 1e-5)
            } else {
                f32::INFINITY
            };
            if self.accel.unoccluded(origin, wi, t_max) {
                out.lights += arriving * cos;
            }
        }
        out
    }

    /// One next-event sample of the sky's irradiance at `s` (W/m^2, shadowed).
    fn sky_irradiance_sample(&self, s: &Surface, origin: Vec3, rng: &mut Rng) -> Vec3 {
        let Some(sky) = &self.sky else {
            return Vec3::ZERO;
        };
        let (wi, radiance, pdf) = sky.sample(rng.next_vec2());
        let cos = s.shading.dot(wi);
        if pdf <= 0.0 || cos <= 0.0 || s.geometric.dot(wi) <= 0.0 || radiance == Vec3::ZERO {
            return Vec3::ZERO;
        }
        if !self.accel.unoccluded(origin, wi, f32::INFINITY) {
            return Vec3::ZERO;
        }
        radiance * (cos * power_heuristic(pdf, cos * FRAC_1_PI) / pdf)
    }

    /// One next-event sample of the emissive triangles' irradiance at `s` (W/m^2, shadowed).
    fn emitter_irradiance_sample(&self, s: &Surface, origin: Vec3, rng: &mut Rng) -> Vec3 {
        let Some(emitters) = &self.emitters else {
            return Vec3::ZERO;
        };
        let pick = rng.next_f32();
        let e = emitters.sample(&self.accel, s.position, pick, rng.next_vec2());
        let cos = s.shading.dot(e.wi);
        if e.pdf <= 0.0 || cos <= 0.0 || s.geometric.dot(e.wi) <= 0.0 || e.radiance == Vec3::ZERO {
            return Vec3::ZERO;
        }
        // Stop short of the emitter, so that neither it nor a coplanar neighbour shadows it.
        let t_max = (s.position + e.wi * e.distance - origin).length() * (1.0 - 1e-4);
        if !self.accel.unoccluded(origin, e.wi, t_max) {
            return Vec3::ZERO;
        }
        e.radiance * (cos * power_heuristic(e.pdf, cos * FRAC_1_PI) / e.pdf)
    }

    /// Sky radiance along a cosine-sampled direction `dir` from `s` that left the scene,
    /// weighted against the sky's next-event sample taken at `s`.
    fn escaped(&self, s: &Surface, dir: Vec3) -> Vec3 {
        let Some(sky) = &self.sky else {
            return Vec3::ZERO;
        };
        let pdf_cos = s.shading.dot(dir).max(0.0) * FRAC_1_PI;
        sky.sky.radiance(dir) * power_heuristic(pdf_cos, sky.pdf(dir))
    }

    /// Emission of `next`, hit by a cosine-sampled ray along `dir` from `s`, weighted against
    /// the emitters' next-event sample taken at `s`.
    fn emission_hit(&self, s: &Surface, dir: Vec3, hit: &Hit, next: &Surface) -> Vec3 {
        let Some(emitters) = &self.emitters else {
            return Vec3::ZERO;
        };
        if next.emission == Vec3::ZERO {
            return Vec3::ZERO;
        }
        let pdf_cos = s.shading.dot(dir).max(0.0) * FRAC_1_PI;
        let pdf_light = emitters.solid_angle_pdf(&self.accel, hit.tri, dir, hit.t);
        next.emission * power_heuristic(pdf_cos, pdf_light)
    }

    fn trace(&self, origin: Vec3, dir: Vec3, rng: &mut Rng) -> PathSample {
        let mut out = PathSample::default();
        let Some(hit) = self.accel.closest(origin, dir, f32::INFINITY) else {
            // The camera sees the sky.
            if let Some(sky) = &self.sky {
                out.direct = sky.sky.radiance(dir);
            }
            return out;
        };
        let mut s = self.surface(&hit, origin, dir);
        out.albedo = s.albedo;
        out.direct = s.emission;
        // Light reflected at x_j has been reflected j times on its way to the eye: at x1 it is
        // direct light, further on indirect. Every vertex shares its emitters between
        // next-event estimation and a cosine-sampled ray (MIS); at the deepest vertex that ray
        // only looks for emitters, and the path ends there.
        let deepest = self
            .max_light_reflections
            .max(self.max_emissive_reflections);
        // Radiance arriving at x1 from the vertices beyond it.
        let mut incoming = Vec3::ZERO;
        // Radiance leaving x_j -> radiance arriving at x1 (j >= 2).
        let mut weight = Vec3::ONE;
        for j in 1..=deepest {
            let lights = j <= self.max_light_reflections;
            let emissive = j <= self.max_emissive_reflections;
            let last = j == deepest;
            // Russian roulette ends paths at random, which 1 / survival pays.
            let mut survival = 1.0;
            // At the last vertex the ray only looks for emitters: none to find, no ray.
            let mut follow =
                !last || (lights && self.sky.is_some()) || (emissive && self.emitters.is_some());
            if !last && j > self.roulette_start {
                survival = s.albedo.max_element().min(0.95);
                follow = survival > 0.0 && rng.next_f32() < survival;
            }
            // Beyond x1 light arriving at a black surface goes nowhere (at x1 it is still part
            // of the irradiance images).
            let arriving = if j == 1 || s.albedo != Vec3::ZERO {
                self.arriving(&s, rng, lights, emissive)
            } else {
                Arriving::default()
            };
            // Radiance arriving at s along the continuation ray straight from an emitter.
            let mut emitted = Vec3::ZERO;
            let mut emitted_by_surfaces = Vec3::ZERO;
            let mut next = None;
            if follow {
                let dir = cosine_hemisphere(s.shading, rng.next_vec2());
                // Below the true surface the shading normal leans away; such light is lost.
                if dir.dot(s.geometric) > 0.0 {
                    let origin = offset(s.position, s.geometric);
                    match self.accel.closest(origin, dir, f32::INFINITY) {
                        None if lights => emitted = self.escaped(&s, dir) / survival,
                        None => {}
                        Some(hit) => {
                            let n = self.surface(&hit, origin, dir);
                            if emissive {
                                emitted_by_surfaces =
                                    self.emission_hit(&s, dir, &hit, &n) / survival;
                                emitted += emitted_by_surfaces;
                            }
                            if !last {
                                next = Some(n);
                            }
                        }
                    }
                }
            }
            // Lambertian: albedo/pi x irradiance, and albedo x radiance along a cosine-sampled
            // ray (BRDF x cos / pdf = albedo).
            let reflected =
                s.albedo * (FRAC_1_PI * (arriving.lights + arriving.emissive) + emitted);
            if j == 1 {
                out.direct += reflected;
                out.emitter_irradiance = arriving.emissive + PI * emitted_by_surfaces;
            } else {
                incoming += weight * reflected;
            }
            let Some(n) = next else {
                break;
            };
            if j > 1 {
                weight *= s.albedo;
            }
            weight /= survival;
            if weight.max_element() <= 0.0 {
                break;
            }
            s = n;
        }
        out.indirect = out.albedo * incoming;
        out.irradiance = PI * incoming;
        out
    }
}

/// Ray queries against a frame's geometry through the reference's own BVH, so that other ray
/// tracers (the probes' GPU BVH, the voxel walks) can be compared with it.
pub struct RayQueries<'a>(Accel<'a>);

impl<'a> RayQueries<'a> {
    /// Builds the reference's BVH over `frame`'s world triangles (clear materials and
    /// degenerate triangles left out, as the reference renders them).
    pub fn build(scene: &'a Scene, frame: &SceneFrame) -> Result<RayQueries<'a>> {
        Accel::build(scene, frame).map(RayQueries)
    }

    /// The distance to the closest hit from `origin` along the unit vector `dir` within
    /// `t_max`, if any.
    pub fn closest_distance(&self, origin: Vec3, dir: Vec3, t_max: f32) -> Option<f32> {
        self.0.closest(origin, dir, t_max).map(|h| h.t)
    }
}
