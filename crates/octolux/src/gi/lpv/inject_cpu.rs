//! CPU twin of the injection passes (`inject.wgsl`): the same VPLs, surfels and cells from the
//! same RSM and G-buffer data, summed in f64 in any order. Tests compare the GPU volumes with it.
//!
//! Two kinds of GPU/CPU difference are inherent and are returned with the sums, so that a test
//! can bound them instead of loosening a tolerance blindly:
//! - rounding: each term is a few f32 operations (another compiler may fuse or reorder them), so
//!   the comparison allows a relative error of the sum of the terms' magnitudes (`magnitude`);
//! - decisions: a VPL or surfel whose position lies within [`AMBIGUOUS`] cells of the boundary
//!   between two cells may land in either on another adapter. Its magnitude goes into `slack`
//!   of the cell the CPU chose and of the cells across the boundaries it is near.

use super::sh::{self, Cell, Sh};
use super::GpuGrids;
use crate::frame::rsm::RsmImage;
use glam::{Mat4, UVec2, Vec3, Vec4};

/// Distance (in cells) from a cell boundary under which a cell decision counts as ambiguous.
pub const AMBIGUOUS: f32 = 1e-3;

/// One injected quantity (a light coefficient or a geometry coefficient) as the CPU sums it.
#[derive(Clone, Copy, Debug, Default)]
pub struct Sum {
    /// The sum of the terms.
    pub value: f64,
    /// The sum of the terms' magnitudes.
    pub magnitude: f64,
    /// The magnitude of ambiguous terms in this cell's neighbourhood.
    pub slack: f64,
}

/// The injected volumes: `light` per cell of every grid (12 sums: channel-major, 4 coefficients
/// each), geometry per corner cell of every grid for the RSM and camera sources (4 sums each).
#[derive(Clone, Debug)]
pub struct Injected {
    /// Light sums, `cells x 12`.
    pub light: Vec<[Sum; 12]>,
    /// Geometry from the RSMs, `gv_total x 4`.
    pub gv_rsm: Vec<[Sum; 4]>,
    /// Geometry from the camera, `gv_total x 4`.
    pub gv_camera: Vec<[Sum; 4]>,
}

/// The camera as the camera geometry injection sees it.
#[derive(Clone, Copy, Debug)]
pub struct CameraInput {
    /// Clip to world.
    pub inv_view_proj: Mat4,
    /// Eye position.
    pub position: Vec3,
    /// Image size in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
}

/// The G-buffer as the camera geometry injection reads it.
pub struct GBufferInput<'a> {
    /// Depth-buffer values, row-major.
    pub depth: &'a [f32],
    /// World normals, row-major.
    pub normal: &'a [Vec3],
}

fn world_from_depth(cam: &CameraInput, px: UVec2, depth: f32) -> Vec3 {
    let uv =
        (px.as_vec2() + 0.5) * glam::Vec2::new(1.0 / cam.width as f32, 1.0 / cam.height as f32);
    let ndc = Vec4::new(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0, depth, 1.0);
    let w = cam.inv_view_proj * ndc;
    w.truncate() / w.w
}

/// Per axis, the cell offsets another adapter may choose for position `x` (in cells) decided by
/// `floor` (boundaries at integers) or `round` (at half-integers): 0, and -1 or +1 when `x` is
/// within [`AMBIGUOUS`] of the boundary on that side. None when no axis is near a boundary.
fn near_boundary(x: Vec3, half: bool) -> Option<[[i32; 2]; 3]> {
    let shifted = if half { x + 0.5 } else { x };
    let f = shifted - shifted.floor();
    let mut out = [[0; 2]; 3];
    let mut any = false;
    for axis in 0..3 {
        if f[axis] < AMBIGUOUS {
            out[axis][1] = -1;
            any = true;
        } else if f[axis] > 1.0 - AMBIGUOUS {
            out[axis][1] = 1;
            any = true;
        }
    }
    any.then_some(out)
}

/// Where an ambiguous term went: its grid's first cell, the chosen cell, the grid side and the
/// candidate offsets per axis.
type Candidates = (usize, [i32; 3], i32, [[i32; 2]; 3]);

/// An ambiguous term: where it went and its magnitudes.
type Ambiguous<const K: usize> = (Candidates, [f64; K]);

struct Accumulator<const K: usize> {
    sums: Vec<[Sum; K]>,
    ambiguous: Vec<Ambiguous<K>>,
}

impl<const K: usize> Accumulator<K> {
    fn new(cells: usize) -> Self {
        Accumulator {
            sums: vec![[Sum::default(); K]; cells],
            ambiguous: Vec::new(),
        }
    }

    fn add(&mut self, cell: usize, terms: [f64; K], ambiguous: Option<Candidates>) {
        for (s, t) in self.sums[cell].iter_mut().zip(terms) {
            s.value += t;
            s.magnitude += t.abs();
        }
        if let Some(candidates) = ambiguous {
            self.ambiguous.push((candidates, terms.map(f64::abs)));
        }
    }

    fn finish(mut self) -> Vec<[Sum; K]> {
        for ((first, c, m, offsets), mags) in std::mem::take(&mut self.ambiguous) {
            for dz in offsets[2] {
                for dy in offsets[1] {
                    for dx in offsets[0] {
                        let q = [c[0] + dx, c[1] + dy, c[2] + dz];
                        if q.iter().any(|&v| v < 0 || v >= m) {
                            continue;
                        }
                        let i = first + (q[0] + m * (q[1] + m * q[2])) as usize;
                        for (s, mag) in self.sums[i].iter_mut().zip(mags) {
                            s.slack += mag;
                        }
                    }
                }
            }
        }
        self.sums
    }
}

/// Injects the RSM layers `rsm` and the G-buffer `gbuffer` seen by `camera` into `grids`, as
/// `inject.wgsl` does (one VPL per stride^2 block split at depth discontinuities, blocking
/// potentials at cell corners, the G-buffer sampled every `camera_stride` pixels).
pub fn inject(
    grids: &GpuGrids,
    cells: usize,
    rsm: &[RsmImage],
    camera: &CameraInput,
    gbuffer: &GBufferInput,
) -> Injected {
    let grids_in_use = &grids.grids[..grids.count as usize];
    let gv_total = grids.gv_total as usize;
    let mut light = Accumulator::<12>::new(cells);
    let mut gv_rsm = Accumulator::<4>::new(gv_total);
    let mut gv_camera = Accumulator::<4>::new(gv_total);
    let pi = std::f32::consts::PI;

    let inject_vpl = |light: &mut Accumulator<12>, pos: Vec3, n: Vec3, flux: Vec3| {
        let lobe = sh::lobe(n).map(|c| c / pi);
        for g in grids_in_use
            .iter()
            .filter(|g| g.flags & super::FLAG_INJECT != 0)
        {
            let origin = Vec3::from(g.origin);
            let x = (pos + 0.5 * g.cell * n - origin) / g.cell;
            let c = x.floor().as_ivec3();
            let m = g.n as i32;
            if c.min_element() < 0 || c.max_element() >= m {
                continue;
            }
            let cell = g.offset as usize + (c.x + m * (c.y + m * c.z)) as usize;
            let mut terms = [0.0f64; 12];
            for ch in 0..3 {
                for k in 0..4 {
                    terms[ch * 4 + k] = (flux[ch] * lobe[k]) as f64;
                }
            }
            let ambiguous =
                near_boundary(x, false).map(|o| (g.offset as usize, c.to_array(), m, o));
            light.add(cell, terms, ambiguous);
        }
    };

    // As `inject_surfel`: a grid of surfel stride k takes source (x, y) where it heads a k x k
    // block, with the block's area.
    let blocking = |acc: &mut Accumulator<4>, (sx, sy): (u32, u32), p: Vec3, n: Vec3, area: f32| {
        for g in grids_in_use {
            let s = g.surfel_stride();
            if sx % s != 0 || sy % s != 0 {
                continue;
            }
            let area = area * (s * s) as f32;
            let origin = Vec3::from(g.origin);
            let x = (p - origin) / g.cell;
            let corner = x.round().as_ivec3();
            let m = g.n as i32 + 1;
            if corner.min_element() < 0 || corner.max_element() >= m {
                continue;
            }
            let first = g.gv_offset as usize;
            let i = first + (corner.x + m * (corner.y + m * corner.z)) as usize;
            let b = sh::lobe(n).map(|c| (c * (area / (g.cell * g.cell)).min(1.0)) as f64);
            let ambiguous = near_boundary(x, true).map(|o| (first, corner.to_array(), m, o));
            acc.add(i, b, ambiguous);
        }
    };

    // Light: the cell-merged VPL of each block, as `inject_light`.
    let radius = grids_in_use
        .iter()
        .filter(|g| g.flags & super::FLAG_INJECT != 0)
        .map(|g| g.cell)
        .fold(1e30f32, f32::min);
    for (layer, image) in rsm.iter().enumerate() {
        // A layer drawn at half the side (what it shows moved) is read with half the stride:
        // the same blocks (`half_layer` in inject.wgsl).
        let half = layer < 256 && grids.half_layers[layer / 32] >> (layer % 32) & 1 != 0;
        let full_stride = grids.stride.max(1);
        let (size, stride) = match half {
            true => (image.size / 2, (full_stride / 2).max(1)),
            false => (image.size, full_stride),
        };
        let row = image.size;
        let texel = |x: u32, y: u32| {
            let i = (y * row + x) as usize;
            let (pm, nn, f) = (image.position[i], image.normal[i], image.flux[i]);
            let flux = Vec3::new(f[0], f[1], f[2]) * pm[3];
            (
                pm[3] > 0.0,
                Vec3::new(pm[0], pm[1], pm[2]),
                Vec3::new(nn[0], nn[1], nn[2]),
                flux,
                pm[3] * nn[3],
            )
        };
        let blocks = image.size.div_ceil(full_stride);
        for by in 0..blocks {
            for bx in 0..blocks {
                let mut reference = None;
                let (mut flux, mut pos, mut nrm, mut weight) =
                    (Vec3::ZERO, Vec3::ZERO, Vec3::ZERO, 0.0f32);
                for sy in 0..stride {
                    for sx in 0..stride {
                        let (x, y) = (bx * stride + sx, by * stride + sy);
                        if x >= size || y >= size {
                            continue;
                        }
                        let (valid, p, n, f, _) = texel(x, y);
                        let w = f.x + f.y + f.z;
                        if !valid || w <= 0.0 {
                            continue;
                        }
                        let r = *reference.get_or_insert(p);
                        if p.distance(r) > radius {
                            inject_vpl(&mut light, p, n, f);
                            continue;
                        }
                        flux += f;
                        pos += p * w;
                        nrm += n * w;
                        weight += w;
                    }
                }
                if weight > 0.0 && nrm.length_squared() >= 1e-12 {
                    inject_vpl(&mut light, pos / weight, nrm.normalize(), flux);
                }
            }
        }
        // Geometry from every RSM texel, as `inject_gv_rsm`.
        for y in 0..size {
            for x in 0..size {
                let (valid, p, n, _, area) = texel(x, y);
                if valid {
                    blocking(&mut gv_rsm, (x, y), p, n, area);
                }
            }
        }
    }

    // Geometry from the G-buffer, one sample per block, as `inject_gv_camera`.
    let s = grids.camera_stride.max(1);
    for by in 0..camera.height.div_ceil(s) {
        for bx in 0..camera.width.div_ceil(s) {
            let first = UVec2::new(bx * s, by * s);
            let last = (first + UVec2::splat(s)).min(UVec2::new(camera.width, camera.height));
            let block = last - first;
            let px = first + block / 2;
            let i = (px.y * camera.width + px.x) as usize;
            let depth = gbuffer.depth[i];
            if depth >= 1.0 {
                continue;
            }
            let p = world_from_depth(camera, px, depth);
            let n = gbuffer.normal[i].normalize();
            let dx = world_from_depth(camera, px + UVec2::new(1, 0), depth) - p;
            let dy = world_from_depth(camera, px + UVec2::new(0, 1), depth) - p;
            let across = dx.cross(dy);
            let plane_area = across.length();
            let ray = (p - camera.position).normalize();
            let axis = across / plane_area.max(1e-20);
            let pixel_area = plane_area * axis.dot(ray).abs() / n.dot(ray).abs().max(0.1);
            blocking(
                &mut gv_camera,
                (bx, by),
                p,
                n,
                pixel_area * (block.x * block.y) as f32,
            );
        }
    }

    Injected {
        light: light.finish(),
        gv_rsm: gv_rsm.finish(),
        gv_camera: gv_camera.finish(),
    }
}

/// The light sums as cells (f32).
pub fn light_cells(injected: &Injected) -> Vec<Cell> {
    injected
        .light
        .iter()
        .map(|c| std::array::from_fn(|ch| std::array::from_fn(|k| c[ch * 4 + k].value as f32)))
        .collect()
}

/// The max-combination of the two geometry sources by band-0 blocking, as `combine_gv`.
pub fn combined_geometry(injected: &Injected) -> Vec<Sh> {
    injected
        .gv_rsm
        .iter()
        .zip(&injected.gv_camera)
        .map(|(a, b)| {
            let pick = if b[0].value > a[0].value { b } else { a };
            pick.map(|s| s.value as f32)
        })
        .collect()
}
