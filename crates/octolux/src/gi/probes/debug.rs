//! The probe debug view (`octolux render --view probes`): a probe technique's state read back
//! after a frame and drawn over the rendered image. Probes are small spheres shaded with their
//! own irradiance for the sphere's normal (what a surface facing that way would receive, shown
//! as the radiance of a white surface, E/pi); the octree's leaf cubes are outlines; surfels
//! are dots coloured by their outgoing radiance. Everything is depth-tested against the
//! frame's depth buffer; what lies behind the scene's surfaces is drawn faintly.
//!
//! This is a tool, not a pass of any technique: it reads buffers back (waits for the GPU) and
//! draws on the CPU, so it cannot disturb what it shows.

use super::encoding::COEFFS;
use super::engine::{GpuSurfel, PROBE_VEC4};
use super::{Encoding, ProbesGrid, ProbesOctree};
use crate::gi::GiTechnique;
use crate::gpu::{read_buffer, GpuContext};
use crate::image_io::tone_map_to_srgb8;
use crate::scene::CameraView;
use crate::{Error, Result};
use glam::{UVec3, Vec3, Vec4, Vec4Swizzles};

/// One live probe as the gather sees it.
#[derive(Clone, Debug)]
pub struct ProbeMark {
    /// World position.
    pub position: Vec3,
    /// Its encoding's coefficients.
    pub coeffs: [Vec3; COEFFS],
    /// False where the probe sits inside geometry and the gather leaves it out.
    pub valid: bool,
    /// Radius it is drawn with, in metres (a fifth of its spacing or of its cube's edge).
    pub radius: f32,
}

/// One surfel that hit a front face.
#[derive(Clone, Copy, Debug)]
pub struct SurfelMark {
    /// World position.
    pub position: Vec3,
    /// Outgoing radiance, W/(m^2 sr).
    pub radiance: Vec3,
}

/// A leaf cube of the octree.
#[derive(Clone, Copy, Debug)]
pub struct CellMark {
    /// Lower corner.
    pub lo: Vec3,
    /// Edge length.
    pub edge: f32,
    /// Whether the leaf holds a probe.
    pub has_probe: bool,
}

/// What [`ProbeSnapshot::draw`] draws.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Layers {
    /// The probes.
    pub probes: bool,
    /// The octree's leaf cubes (nothing for the grid).
    pub cells: bool,
    /// The surfels.
    pub surfels: bool,
}

impl Default for Layers {
    fn default() -> Self {
        Layers {
            probes: true,
            cells: true,
            surfels: true,
        }
    }
}

impl std::str::FromStr for Layers {
    type Err = Error;

    /// A comma-separated list of `probes`, `cells`, `surfels` (or `all`).
    fn from_str(s: &str) -> Result<Layers> {
        let mut layers = Layers {
            probes: false,
            cells: false,
            surfels: false,
        };
        for word in s.split(',').map(str::trim) {
            match word {
                "probes" => layers.probes = true,
                "cells" => layers.cells = true,
                "surfels" => layers.surfels = true,
                "all" => layers = Layers::default(),
                other => {
                    return Err(Error::InvalidArgument(format!(
                        "probe view layer '{other}': expected probes, cells, surfels or all"
                    )))
                }
            }
        }
        Ok(layers)
    }
}

/// A probe technique's state, read back from the GPU.
#[derive(Clone, Debug)]
pub struct ProbeSnapshot {
    /// The probes' encoding.
    pub encoding: Encoding,
    /// The live probes.
    pub probes: Vec<ProbeMark>,
    /// The octree's leaf cubes (empty for the grid).
    pub cells: Vec<CellMark>,
    /// The surfels on front faces.
    pub surfels: Vec<SurfelMark>,
}

fn vec4s(bytes: &[u8]) -> Vec<Vec4> {
    bytemuck::cast_slice::<u8, [f32; 4]>(bytes)
        .iter()
        .map(|&v| Vec4::from(v))
        .collect()
}

fn read_all(ctx: &GpuContext, buffer: &wgpu::Buffer) -> Result<Vec<u8>> {
    read_buffer(ctx, buffer, 0, buffer.size())
}

/// A probe's mark from the probe buffer's `vec4`s.
fn probe_mark(probes: &[Vec4], slot: usize, position: Vec3, radius: f32) -> ProbeMark {
    let base = slot * PROBE_VEC4 as usize;
    ProbeMark {
        position,
        coeffs: std::array::from_fn(|k| probes[base + k].xyz()),
        valid: probes[base + 8].z >= 0.5,
        radius,
    }
}

/// Front-face surfels of the live probe slots (`live[slot]`).
fn surfel_marks(
    surfels: &[GpuSurfel],
    radiance: &[Vec4],
    per_probe: usize,
    live: &[bool],
) -> Vec<SurfelMark> {
    let count = radiance.len().min(surfels.len());
    (0..count)
        .filter(|&s| live.get(s / per_probe).copied().unwrap_or(false))
        .filter_map(|s| {
            let g = surfels[s];
            // State 1: a front-face hit (0: miss, 2: back face).
            (g.state == 1.0).then(|| SurfelMark {
                position: g.position.into(),
                radiance: radiance[s].xyz(),
            })
        })
        .collect()
}

/// Reads the surfel buffers (geometry, radiance) back and keeps the front-face surfels of
/// the live probe slots.
fn read_surfels(
    ctx: &GpuContext,
    (geometry, radiance): (&wgpu::Buffer, &wgpu::Buffer),
    settings: &super::ProbeSettings,
    live: &[bool],
) -> Result<Vec<SurfelMark>> {
    let surfels: Vec<GpuSurfel> = read_all(ctx, geometry)?
        .chunks_exact(std::mem::size_of::<GpuSurfel>())
        .map(bytemuck::pod_read_unaligned)
        .collect();
    Ok(surfel_marks(
        &surfels,
        &vec4s(&read_all(ctx, radiance)?),
        (settings.surfel_count() * settings.surfel_sets()) as usize,
        live,
    ))
}

impl ProbeSnapshot {
    /// Reads the state of `technique`, which must be `probes-grid` or `probes-octree`, after
    /// at least one frame. Waits for the GPU.
    pub fn read(ctx: &GpuContext, technique: &dyn GiTechnique) -> Result<ProbeSnapshot> {
        let any = technique.as_any().ok_or_else(|| not_probes(technique))?;
        if let Some(grid) = any.downcast_ref::<ProbesGrid>() {
            Self::read_grid(ctx, grid)
        } else if let Some(octree) = any.downcast_ref::<ProbesOctree>() {
            Self::read_octree(ctx, octree)
        } else {
            Err(not_probes(technique))
        }
    }

    fn read_grid(ctx: &GpuContext, technique: &ProbesGrid) -> Result<ProbeSnapshot> {
        let grid = technique.grid();
        let probes = vec4s(&read_all(ctx, technique.probe_buffer())?);
        let radius = 0.2 * grid.spacing.min_element();
        let d = grid.dims;
        let marks = (0..grid.count())
            .map(|i| {
                let c = UVec3::new(i % d.x, (i / d.x) % d.y, i / (d.x * d.y));
                probe_mark(&probes, i as usize, grid.position(c), radius)
            })
            .collect();
        let live = vec![true; grid.count() as usize];
        let surfels = read_surfels(ctx, technique.surfel_buffers(), technique.settings(), &live)?;
        Ok(ProbeSnapshot {
            encoding: technique.settings().encoding,
            probes: marks,
            cells: Vec::new(),
            surfels,
        })
    }

    fn read_octree(ctx: &GpuContext, technique: &ProbesOctree) -> Result<ProbeSnapshot> {
        let [tree, info, _, _] = technique.octree().buffers();
        let nodes: Vec<i32> = bytemuck::cast_slice(&read_all(ctx, tree)?).to_vec();
        let info = vec4s(&read_all(ctx, info)?);
        let probes = vec4s(&read_all(ctx, technique.probe_buffer())?);
        let (lo, size) = technique.root();
        let live: Vec<bool> = info.iter().map(|i| i.w >= 0.0).collect();
        let marks = info
            .iter()
            .enumerate()
            .filter(|(_, i)| i.w >= 0.0)
            .map(|(slot, i)| {
                let edge = size * 2f32.powi(-(i.w as i32));
                probe_mark(&probes, slot, i.xyz(), 0.2 * edge)
            })
            .collect();
        let mut cells = Vec::new();
        leaf_cells(
            &nodes,
            0,
            lo,
            size,
            0,
            technique.octree().rule().max_depth,
            &mut cells,
        );
        let surfels = read_surfels(ctx, technique.surfel_buffers(), technique.settings(), &live)?;
        Ok(ProbeSnapshot {
            encoding: technique.settings().encoding,
            probes: marks,
            cells,
            surfels,
        })
    }

    /// Probes whose gather value is used (not inside geometry).
    pub fn valid_probes(&self) -> usize {
        self.probes.iter().filter(|p| p.valid).count()
    }

    /// Draws the chosen layers over `rgb` (8-bit sRGB, rows top to bottom, the size of
    /// `view`), depth-tested against `depth` (the frame's depth-buffer values, 1 = nothing).
    /// Colours are tone-mapped like the frame, with exposure `exposure` (EV).
    pub fn draw(
        &self,
        view: &CameraView,
        depth: &[f32],
        rgb: &mut [u8],
        exposure: f32,
        layers: Layers,
    ) -> Result<()> {
        let (w, h) = (view.width as usize, view.height as usize);
        if depth.len() != w * h || rgb.len() != w * h * 3 {
            return Err(Error::InvalidArgument(format!(
                "probe view: a {}x{} image needs {} depth values and {} bytes, got {} and {}",
                w,
                h,
                w * h,
                w * h * 3,
                depth.len(),
                rgb.len()
            )));
        }
        let mut canvas = Canvas {
            view,
            depth,
            rgb,
            scale: exposure.exp2(),
        };
        if layers.cells {
            for cell in &self.cells {
                let colour = if cell.has_probe {
                    Vec3::new(1.0, 0.8, 0.1)
                } else {
                    Vec3::new(0.35, 0.45, 0.6)
                };
                canvas.cube(cell.lo, cell.edge, colour);
            }
        }
        if layers.surfels {
            for s in &self.surfels {
                let colour = canvas.display(s.radiance);
                canvas.dot(s.position, colour);
            }
        }
        if layers.probes {
            // Far to near, so that nearer spheres cover farther ones.
            let mut order: Vec<(f32, &ProbeMark)> = self
                .probes
                .iter()
                .map(|p| (p.position.distance(view.position), p))
                .collect();
            order.sort_by(|a, b| b.0.total_cmp(&a.0));
            for (_, probe) in order {
                canvas.probe(probe, self.encoding);
            }
        }
        Ok(())
    }
}

fn not_probes(technique: &dyn GiTechnique) -> Error {
    Error::InvalidArgument(format!(
        "the probe view shows probes-grid or probes-octree, not '{}'",
        technique.name()
    ))
}

/// Appends the leaf cubes under `node` (cube `lo`, `edge`, at `depth`).
fn leaf_cells(
    nodes: &[i32],
    node: usize,
    lo: Vec3,
    edge: f32,
    depth: u32,
    max_depth: u32,
    out: &mut Vec<CellMark>,
) {
    let Some(&v) = nodes.get(node) else {
        return;
    };
    if v <= 0 || depth >= max_depth {
        // A leaf: 0 without a probe, -(slot + 1) with one (octree.rs).
        out.push(CellMark {
            lo,
            edge,
            has_probe: v < 0,
        });
        return;
    }
    let half = edge * 0.5;
    for octant in 0..8u32 {
        let offset = Vec3::new(
            (octant & 1) as f32,
            ((octant >> 1) & 1) as f32,
            ((octant >> 2) & 1) as f32,
        ) * half;
        let child = v as usize + 1 + octant as usize;
        leaf_cells(nodes, child, lo + offset, half, depth + 1, max_depth, out);
    }
}

/// The image being drawn on.
struct Canvas<'a> {
    view: &'a CameraView,
    depth: &'a [f32],
    rgb: &'a mut [u8],
    scale: f32,
}

/// Share of a colour kept where the mark lies behind the scene.
const HIDDEN: f32 = 0.25;

impl Canvas<'_> {
    fn display(&self, radiance: Vec3) -> Vec3 {
        let [r, g, b] = tone_map_to_srgb8(radiance * self.scale);
        Vec3::new(r as f32, g as f32, b as f32) / 255.0
    }

    /// Pixel coordinates (continuous) and clip w of a world point; None behind the eye.
    fn project(&self, p: Vec3) -> Option<(f32, f32, f32)> {
        let clip = self.view.view_proj * p.extend(1.0);
        if clip.w <= 1e-6 {
            return None;
        }
        let ndc = clip.xyz() / clip.w;
        let x = (ndc.x * 0.5 + 0.5) * self.view.width as f32;
        let y = (0.5 - ndc.y * 0.5) * self.view.height as f32;
        Some((x, y, clip.w))
    }

    /// Whether world point `p`, which projects into pixel (x, y), is in front of the scene's
    /// surface there (within 1 % of its distance, so that marks on surfaces show).
    fn visible(&self, x: usize, y: usize, p: Vec3) -> bool {
        let w = self.view.width as usize;
        let d = self.depth[y * w + x];
        if d >= 1.0 {
            return true;
        }
        let surface = self.view.world_point(x as f32 + 0.5, y as f32 + 0.5, d);
        p.distance(self.view.position) <= surface.distance(self.view.position) * 1.01
    }

    /// Blends `colour` into pixel (x, y) with weight `alpha`.
    fn put(&mut self, x: usize, y: usize, colour: Vec3, alpha: f32) {
        let i = (y * self.view.width as usize + x) * 3;
        for (c, v) in self.rgb[i..i + 3].iter_mut().zip(colour.to_array()) {
            let old = *c as f32 / 255.0;
            *c = ((old + (v - old) * alpha).clamp(0.0, 1.0) * 255.0 + 0.5) as u8;
        }
    }

    fn inside(&self, x: f32, y: f32) -> Option<(usize, usize)> {
        (x >= 0.0 && y >= 0.0 && x < self.view.width as f32 && y < self.view.height as f32)
            .then_some((x as usize, y as usize))
    }

    /// A depth-tested point mark (one pixel).
    fn dot(&mut self, p: Vec3, colour: Vec3) {
        let Some((x, y, _)) = self.project(p) else {
            return;
        };
        if let Some((x, y)) = self.inside(x, y) {
            let alpha = if self.visible(x, y, p) { 1.0 } else { HIDDEN };
            self.put(x, y, colour, alpha);
        }
    }

    /// A depth-tested segment, one sample per pixel along its longer screen axis.
    fn line(&mut self, a: Vec3, b: Vec3, colour: Vec3) {
        let (Some(pa), Some(pb)) = (self.project(a), self.project(b)) else {
            // Segments that reach behind the eye are left out (cells around the camera).
            return;
        };
        let steps = (pb.0 - pa.0)
            .abs()
            .max((pb.1 - pa.1).abs())
            .ceil()
            .clamp(1.0, 8192.0);
        for i in 0..=steps as u32 {
            let t = i as f32 / steps;
            // Perspective-correct point along the segment for screen parameter t.
            let tw = t / pb.2 / ((1.0 - t) / pa.2 + t / pb.2);
            let p = a.lerp(b, tw);
            let (x, y) = (pa.0 + (pb.0 - pa.0) * t, pa.1 + (pb.1 - pa.1) * t);
            if let Some((x, y)) = self.inside(x, y) {
                let alpha = if self.visible(x, y, p) { 1.0 } else { HIDDEN };
                self.put(x, y, colour, alpha);
            }
        }
    }

    fn cube(&mut self, lo: Vec3, edge: f32, colour: Vec3) {
        let corner = |i: u32| {
            lo + Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32) * edge
        };
        for i in 0..8u32 {
            for axis in [1u32, 2, 4] {
                if i & axis == 0 {
                    self.line(corner(i), corner(i | axis), colour);
                }
            }
        }
    }

    /// A sphere of the probe's radius, each pixel shaded with the probe's irradiance for the
    /// sphere's normal there, as E/pi; probes left out of the gather get a red rim.
    fn probe(&mut self, probe: &ProbeMark, encoding: Encoding) {
        let Some((cx, cy, cw)) = self.project(probe.position) else {
            return;
        };
        // Screen radius from the vertical focal length: proj[1][1] = 1 / tan(fov / 2).
        let focal = self.view.proj.y_axis.y * 0.5 * self.view.height as f32;
        let r = (probe.radius * focal / cw).clamp(2.0, 24.0);
        let to_eye = (self.view.position - probe.position).normalize_or_zero();
        let view_inv = self.view.view.inverse();
        let (right, up) = (
            view_inv.x_axis.xyz().normalize_or_zero(),
            view_inv.y_axis.xyz().normalize_or_zero(),
        );
        let (x0, x1) = ((cx - r).floor().max(0.0), (cx + r).ceil());
        let (y0, y1) = ((cy - r).floor().max(0.0), (cy + r).ceil());
        for y in y0 as usize..(y1.max(0.0) as usize).min(self.view.height as usize) {
            for x in x0 as usize..(x1.max(0.0) as usize).min(self.view.width as usize) {
                let u = (x as f32 + 0.5 - cx) / r;
                let v = (cy - (y as f32 + 0.5)) / r;
                let rr = u * u + v * v;
                if rr > 1.0 {
                    continue;
                }
                let n = (right * u + up * v + to_eye * (1.0 - rr).sqrt()).normalize_or_zero();
                let colour = if !probe.valid && rr > 0.6 {
                    Vec3::new(0.9, 0.1, 0.1)
                } else {
                    let e = encoding.irradiance(&probe.coeffs, n);
                    self.display(e / std::f32::consts::PI)
                };
                let alpha = if self.visible(x, y, probe.position) {
                    1.0
                } else {
                    HIDDEN
                };
                self.put(x, y, colour, alpha);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Mat4;

    fn view(width: u32, height: u32) -> CameraView {
        let position = Vec3::new(0.0, 0.0, 5.0);
        let view = Mat4::look_at_rh(position, Vec3::ZERO, Vec3::Y);
        let proj =
            Mat4::perspective_rh(60f32.to_radians(), width as f32 / height as f32, 0.1, 100.0);
        let view_proj = proj * view;
        CameraView {
            view,
            proj,
            view_proj,
            inv_view_proj: view_proj.inverse(),
            position,
            width,
            height,
        }
    }

    fn white_probe(position: Vec3, valid: bool) -> ProbeMark {
        // SH L1 of a uniform radiance 1 from six opposite directions: band 1 cancels.
        let mut coeffs = [Vec3::ZERO; COEFFS];
        for d in [
            Vec3::X,
            Vec3::NEG_X,
            Vec3::Y,
            Vec3::NEG_Y,
            Vec3::Z,
            Vec3::NEG_Z,
        ] {
            Encoding::ShL1.add(&mut coeffs, Vec3::ONE, d, 4.0 * std::f32::consts::PI / 6.0);
        }
        ProbeMark {
            position,
            coeffs,
            valid,
            radius: 0.5,
        }
    }

    fn pixel(rgb: &[u8], w: u32, x: u32, y: u32) -> [u8; 3] {
        let i = ((y * w + x) * 3) as usize;
        [rgb[i], rgb[i + 1], rgb[i + 2]]
    }

    #[test]
    fn a_probe_lands_at_its_projection_and_hides_behind_the_scene() {
        let (w, h) = (64, 48);
        let view = view(w, h);
        let snapshot = ProbeSnapshot {
            encoding: Encoding::ShL1,
            probes: vec![white_probe(Vec3::ZERO, true)],
            cells: Vec::new(),
            surfels: Vec::new(),
        };
        // Nothing in front: the centre pixel takes the probe's colour, the corner stays black.
        let mut rgb = vec![0u8; (w * h * 3) as usize];
        let open = vec![1.0f32; (w * h) as usize];
        snapshot
            .draw(&view, &open, &mut rgb, 0.0, Layers::default())
            .unwrap();
        // Uniform radiance 1 gives E = pi, shown as E/pi = 1: the tone-mapped value of 1.
        let expected = tone_map_to_srgb8(Vec3::ONE);
        assert_eq!(pixel(&rgb, w, w / 2, h / 2), expected);
        assert_eq!(pixel(&rgb, w, 0, 0), [0, 0, 0]);
        // A wall at 2 m from the eye (the probe is at 5 m): the probe is drawn faintly.
        let wall = view.view_proj.project_point3(Vec3::new(0.0, 0.0, 3.0)).z;
        let mut rgb = vec![0u8; (w * h * 3) as usize];
        snapshot
            .draw(
                &view,
                &vec![wall; (w * h) as usize],
                &mut rgb,
                0.0,
                Layers::default(),
            )
            .unwrap();
        let faint = pixel(&rgb, w, w / 2, h / 2);
        let full = expected[0] as f32;
        assert!(
            (faint[0] as f32 - full * HIDDEN).abs() <= 1.0,
            "{faint:?} vs {expected:?}"
        );
    }

    #[test]
    fn invalid_probes_get_a_red_rim_and_cells_are_outlined() {
        let (w, h) = (64, 48);
        let view = view(w, h);
        let snapshot = ProbeSnapshot {
            encoding: Encoding::ShL1,
            probes: vec![white_probe(Vec3::ZERO, false)],
            cells: vec![CellMark {
                lo: Vec3::splat(-1.0),
                edge: 2.0,
                has_probe: true,
            }],
            surfels: vec![SurfelMark {
                position: Vec3::new(0.0, 0.0, 1.0),
                radiance: Vec3::new(1.0, 0.0, 0.0),
            }],
        };
        let mut rgb = vec![0u8; (w * h * 3) as usize];
        let open = vec![1.0f32; (w * h) as usize];
        let only = |s: &str| s.parse::<Layers>().unwrap();
        snapshot
            .draw(&view, &open, &mut rgb, 0.0, only("cells"))
            .unwrap();
        // The cube's front face spans x in -1..1 at z = 1: its left edge is lit, the centre not.
        let left = view.view_proj.project_point3(Vec3::new(-1.0, 0.0, 1.0));
        let lx = ((left.x * 0.5 + 0.5) * w as f32) as u32;
        assert_ne!(pixel(&rgb, w, lx, h / 2), [0, 0, 0]);
        assert_eq!(pixel(&rgb, w, w / 2, h / 2), [0, 0, 0]);
        // The surfel at the centre is drawn red.
        snapshot
            .draw(&view, &open, &mut rgb, 0.0, only("surfels"))
            .unwrap();
        let s = pixel(&rgb, w, w / 2, h / 2);
        assert!(s[0] > 0 && s[1] == 0 && s[2] == 0, "{s:?}");
        // The invalid probe: its rim is red, its centre white.
        snapshot
            .draw(&view, &open, &mut rgb, 0.0, only("probes"))
            .unwrap();
        let rim = (0..w).find(|&x| pixel(&rgb, w, x, h / 2) == [230, 26, 26]);
        assert!(rim.is_some());
        assert_eq!(pixel(&rgb, w, w / 2, h / 2), tone_map_to_srgb8(Vec3::ONE));
    }

    #[test]
    fn layers_parse_and_bad_sizes_are_errors() {
        assert_eq!("all".parse::<Layers>().unwrap(), Layers::default());
        assert!("probes,voxels".parse::<Layers>().is_err());
        let snapshot = ProbeSnapshot {
            encoding: Encoding::ShL1,
            probes: Vec::new(),
            cells: Vec::new(),
            surfels: Vec::new(),
        };
        let mut rgb = vec![0u8; 3];
        assert!(snapshot
            .draw(&view(4, 4), &[1.0; 16], &mut rgb, 0.0, Layers::default())
            .is_err());
    }
}
