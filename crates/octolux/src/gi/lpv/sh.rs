//! CPU spherical-harmonics maths and CPU reference implementations of the LPV kernels
//! (propagation step, octree downsample, index volume, merge, error measures). The GPU shaders
//! implement the same formulas; tests compare the two.
//!
//! Conventions (docs/lpv.md, "Radiometry"): 2 bands, 4 coefficients per colour channel, basis
//! (0.282095, -0.488603 y, 0.488603 z, -0.488603 x). A cell stores the SH projection of a
//! *radiant intensity* distribution I(w) in W/sr, w = direction of travel. Volumes are stored
//! as `[Sh; 3]` (r, g, b) per cell, cell index `x + n (y + n z)`.

use glam::Vec3;

/// Four SH coefficients (bands 0 and 1).
pub type Sh = [f32; 4];
/// One cell: SH per colour channel.
pub type Cell = [Sh; 3];

/// Y_0^0.
pub const SH_C0: f32 = 0.282_094_8;
/// |Y_1^m| / |w|.
pub const SH_C1: f32 = 0.488_602_5;
/// SH projection of max(0, n.w), band 0: pi * SH_C0 = sqrt(pi)/2.
pub const LOBE_C0: f32 = 0.886_226_9;
/// SH projection of max(0, n.w), band 1: 2 pi / 3 * SH_C1 = sqrt(pi/3).
pub const LOBE_C1: f32 = 1.023_326_7;
/// Solid angle of the far face of the neighbouring cell, seen from a cell centre: 4 asin(1/10).
pub const FRONT_SOLID_ANGLE: f32 = 0.400_669_7;
/// Solid angle of each of the four side faces of the neighbouring cell.
pub const SIDE_SOLID_ANGLE: f32 = 0.423_431_35;

/// The six axis directions, in the order the shaders use (+x, -x, +y, -y, +z, -z).
pub const DIRECTIONS: [[i32; 3]; 6] = [
    [1, 0, 0],
    [-1, 0, 0],
    [0, 1, 0],
    [0, -1, 0],
    [0, 0, 1],
    [0, 0, -1],
];

/// SH basis evaluated at unit direction `d`.
pub fn basis(d: Vec3) -> Sh {
    [SH_C0, -SH_C1 * d.y, SH_C1 * d.z, -SH_C1 * d.x]
}

/// SH projection of the clamped cosine lobe max(0, n.w) around unit `n`.
pub fn lobe(n: Vec3) -> Sh {
    [LOBE_C0, -LOBE_C1 * n.y, LOBE_C1 * n.z, -LOBE_C1 * n.x]
}

/// Dot product of two coefficient vectors (= integral of the product of the two functions).
pub fn dot(a: &Sh, b: &Sh) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]
}

/// The function `c` evaluated in direction `d`.
pub fn eval(c: &Sh, d: Vec3) -> f32 {
    dot(c, &basis(d))
}

/// Integral of the function over the sphere: for an intensity distribution, its flux (W).
/// Band 1 integrates to zero.
pub fn flux(c: &Sh) -> f32 {
    c[0] * SH_C0 * 4.0 * std::f32::consts::PI
}

/// SH of the intensity distribution of a Lambertian emitter of flux `phi` with normal `n`:
/// I(w) = phi/pi max(0, n.w), which integrates to `phi`.
pub fn lambertian_emitter(phi: f32, n: Vec3) -> Sh {
    lobe(n).map(|c| c * phi / std::f32::consts::PI)
}

/// Distance in front of a surface, in cells, at which the lookup samples the light: one cell,
/// so that the eight cell centres of the trilinear sample lie in front of the surface's plane
/// and a thin wall's far side, whose cells hold the light on the other side, is not read
/// (001 uses half a cell, which reads the cell behind a wall with weight up to one half).
pub const LOOKUP_OFFSET: f32 = 1.0;

/// Irradiance on a surface with normal `n` in a cell of side `cell` whose intensity is `c`:
/// radiance L = I / cell^2 arriving against `n`, E = integral L(w) max(0, -n.w) dw, clamped
/// at zero (2-band SH can go negative behind a lobe).
pub fn irradiance(c: &Sh, n: Vec3, cell: f32) -> f32 {
    (dot(c, &lobe(-n)) / (cell * cell)).max(0.0)
}

/// Trilinear sample of an `n`^3 cell-centred volume at world point `p` (grid minimum corner
/// `origin`, cell side `cell`), clamped to the outermost cell centres: the CPU reference of the
/// lookup's filtering.
pub fn sample_trilinear(v: &[Cell], n: usize, origin: Vec3, cell: f32, p: Vec3) -> Cell {
    let u = ((p - origin) / cell - Vec3::splat(0.5)).clamp(Vec3::ZERO, Vec3::splat((n - 1) as f32));
    let i0 = u.floor();
    let f = u - i0;
    let mut out = [[0.0f32; 4]; 3];
    for k in 0..8 {
        let o = [k & 1, (k >> 1) & 1, k >> 2];
        let mut w = 1.0;
        let mut c = [0usize; 3];
        for a in 0..3 {
            c[a] = (i0[a] as usize + o[a]).min(n - 1);
            w *= if o[a] == 1 { f[a] } else { 1.0 - f[a] };
        }
        let src = &v[index(n, c[0], c[1], c[2])];
        for ch in 0..3 {
            add_scaled(&mut out[ch], &src[ch], w);
        }
    }
    out
}

/// Solid angle of the axis-aligned rectangle `[x0, x1] x [y0, y1]` in the plane z = `d` (> 0),
/// seen from the origin (exact, by the corner formula).
pub fn rectangle_solid_angle(x0: f64, x1: f64, y0: f64, y1: f64, d: f64) -> f64 {
    let corner = |x: f64, y: f64| (x * y / (d * (x * x + y * y + d * d).sqrt())).atan();
    corner(x1, y1) - corner(x0, y1) - corner(x1, y0) + corner(x0, y0)
}

/// Cell index in an `n`^3 grid.
pub fn index(n: usize, x: usize, y: usize, z: usize) -> usize {
    x + n * (y + n * z)
}

fn add_scaled(acc: &mut Sh, c: &Sh, s: f32) {
    for i in 0..4 {
        acc[i] += c[i] * s;
    }
}

/// Transmittance across the face that cell `c` shares with its neighbour `c - dir`: one minus
/// the blocking potential (average of the four geometry-volume corners of that face) towards
/// the light, clamped to [0, 1]. The geometry volume has `(n+1)^3` cells at LPV cell corners.
pub fn transmittance(gv: &[Sh], n: usize, c: [i32; 3], dir: [i32; 3]) -> f32 {
    let m = n as i32 + 1;
    let mut b = [0.0f32; 4];
    for o in 0..8 {
        let corner = [c[0] + (o & 1), c[1] + ((o >> 1) & 1), c[2] + ((o >> 2) & 1)];
        // On the shared face: the coordinate along `dir` is the one nearer the source.
        let on_face = (0..3).all(|a| dir[a] == 0 || corner[a] == c[a] + (dir[a] < 0) as i32);
        if on_face {
            let i = (corner[0] + m * (corner[1] + m * corner[2])) as usize;
            add_scaled(&mut b, &gv[i], 0.25);
        }
    }
    let d = Vec3::new(dir[0] as f32, dir[1] as f32, dir[2] as f32);
    1.0 - blocking(&b, d)
}

/// Peak of a surfel's 2-band blocking lobe, lobe(n) evaluated along n: 0.25 + 0.5 = 0.75.
pub const BLOCKING_PEAK: f32 = LOBE_C0 * SH_C0 + LOBE_C1 * SH_C1;

/// Fraction in [0, 1] of the light travelling along `d` that the geometry SH `b` (a sum of
/// coverage x lobe(n) terms) blocks. A surface is opaque from both sides, so the lobe is read
/// towards the light and away from it and the larger value counts; it is divided by the
/// lobe's peak so that a face fully covered by a surface facing the light blocks all of it
/// (the 2-band lobe peaks at 0.75, not 1).
pub fn blocking(b: &Sh, d: Vec3) -> f32 {
    (eval(b, -d).max(eval(b, d)) / BLOCKING_PEAK).clamp(0.0, 1.0)
}

/// SH that the flux `phi` crossing the face with normal `f`, seen from the neighbour's centre in
/// direction `w`, is re-emitted as: `directional` x the beam along `w` (the 2-band projection
/// of all of it travelling along `w`: phi x basis(w)) plus (1 - `directional`) x a Lambertian
/// lobe about the face normal (phi / pi x lobe(f), 001's re-projection). Both carry exactly
/// `phi` (equal band 0); they differ only in how much direction the light keeps.
pub fn reemit(phi: f32, f: Vec3, w: Vec3, directional: f32) -> Sh {
    let l = lobe(f);
    let b = basis(w);
    std::array::from_fn(|k| {
        phi * ((1.0 - directional) * l[k] / std::f32::consts::PI + directional * b[k])
    })
}

/// One propagation step (gather form) on an `n`^3 grid: every cell collects, from each of its
/// six neighbours, the flux the neighbour's intensity sends through the five faces of the cell
/// it does not share, Phi_f = I(w_f) dw_f, and re-emits it ([`reemit`] with `directional`).
/// Light leaving the grid is lost. `gv` (optional) occludes.
pub fn propagate_step(src: &[Cell], n: usize, gv: Option<&[Sh]>, directional: f32) -> Vec<Cell> {
    let mut dst = vec![[[0.0f32; 4]; 3]; n * n * n];
    let inside = |c: [i32; 3]| c.iter().all(|&v| v >= 0 && v < n as i32);
    for z in 0..n {
        for y in 0..n {
            for x in 0..n {
                let c = [x as i32, y as i32, z as i32];
                let mut out = [[0.0f32; 4]; 3];
                for dir in DIRECTIONS {
                    let s = [c[0] - dir[0], c[1] - dir[1], c[2] - dir[2]];
                    if !inside(s) {
                        continue;
                    }
                    let source = &src[index(n, s[0] as usize, s[1] as usize, s[2] as usize)];
                    let t = gv.map_or(1.0, |g| transmittance(g, n, c, dir));
                    let d = Vec3::new(dir[0] as f32, dir[1] as f32, dir[2] as f32);
                    for face in DIRECTIONS {
                        let f = Vec3::new(face[0] as f32, face[1] as f32, face[2] as f32);
                        if f == -d {
                            continue;
                        }
                        let (w, dw) = if f == d {
                            (d, FRONT_SOLID_ANGLE)
                        } else {
                            ((d + 0.5 * f).normalize(), SIDE_SOLID_ANGLE)
                        };
                        for ch in 0..3 {
                            let phi = eval(&source[ch], w) * dw * t;
                            add_scaled(&mut out[ch], &reemit(phi, f, w, directional), 1.0);
                        }
                    }
                }
                dst[index(n, x, y, z)] = out;
            }
        }
    }
    dst
}

/// Flux per channel that one propagation step sends out of the grid (through the faces of
/// neighbours that lie outside it), without occlusion.
pub fn boundary_outflow(src: &[Cell], n: usize) -> [f64; 3] {
    let mut out = [0.0f64; 3];
    let inside = |c: [i32; 3]| c.iter().all(|&v| v >= 0 && v < n as i32);
    for z in 0..n {
        for y in 0..n {
            for x in 0..n {
                let s = [x as i32, y as i32, z as i32];
                for dir in DIRECTIONS {
                    let c = [s[0] + dir[0], s[1] + dir[1], s[2] + dir[2]];
                    if inside(c) {
                        continue;
                    }
                    let d = Vec3::new(dir[0] as f32, dir[1] as f32, dir[2] as f32);
                    for face in DIRECTIONS {
                        let f = Vec3::new(face[0] as f32, face[1] as f32, face[2] as f32);
                        if f == -d {
                            continue;
                        }
                        let (w, dw) = if f == d {
                            (d, FRONT_SOLID_ANGLE)
                        } else {
                            ((d + 0.5 * f).normalize(), SIDE_SOLID_ANGLE)
                        };
                        for (ch, o) in out.iter_mut().enumerate() {
                            let c = &src[index(n, x, y, z)][ch];
                            *o += (eval(c, w) * dw) as f64;
                        }
                    }
                }
            }
        }
    }
    out
}

/// Total flux per channel held by a volume.
pub fn total_flux(v: &[Cell]) -> [f64; 3] {
    let mut t = [0.0f64; 3];
    for cell in v {
        for ch in 0..3 {
            t[ch] += flux(&cell[ch]) as f64;
        }
    }
    t
}

/// Octree downsample (000, eq. 2): each cell of the `n/2` grid is the average of its eight
/// children in the `n` grid.
pub fn downsample(fine: &[Cell], n: usize) -> Vec<Cell> {
    let h = (n / 2).max(1);
    let mut out = vec![[[0.0f32; 4]; 3]; h * h * h];
    for z in 0..h {
        for y in 0..h {
            for x in 0..h {
                let o = &mut out[index(h, x, y, z)];
                for k in 0..8 {
                    let (cx, cy, cz) = (2 * x + (k & 1), 2 * y + ((k >> 1) & 1), 2 * z + (k >> 2));
                    let child = &fine[index(n, cx.min(n - 1), cy.min(n - 1), cz.min(n - 1))];
                    for ch in 0..3 {
                        add_scaled(&mut o[ch], &child[ch], 0.125);
                    }
                }
            }
        }
    }
    out
}

/// Levels of the index volume I_i (000 §3.1) from level-0 occupancy (`n`^3 flags): level i
/// holds `i` where the level-i cell or one of its 26 neighbours contains geometry, else
/// `l - 1`. Geometry close to a cell thus selects a fine level there, empty space a coarse one.
pub fn index_levels(occupied: &[bool], n: usize) -> Vec<Vec<u32>> {
    let l = n.trailing_zeros() as usize + 1;
    let mut occ = occupied.to_vec();
    let mut levels = Vec::with_capacity(l);
    for i in 0..l {
        let m = n >> i;
        if i > 0 {
            let fine = occ;
            let f = m * 2;
            occ = vec![false; m * m * m];
            for z in 0..m {
                for y in 0..m {
                    for x in 0..m {
                        occ[index(m, x, y, z)] = (0..8).any(|k| {
                            fine[index(
                                f,
                                2 * x + (k & 1),
                                2 * y + ((k >> 1) & 1),
                                2 * z + (k >> 2),
                            )]
                        });
                    }
                }
            }
        }
        let mut level = vec![(l - 1) as u32; m * m * m];
        for z in 0..m as i32 {
            for y in 0..m as i32 {
                for x in 0..m as i32 {
                    let mut near = false;
                    for dz in -1..=1 {
                        for dy in -1..=1 {
                            for dx in -1..=1 {
                                let (a, b, c) = (x + dx, y + dy, z + dz);
                                let m = m as i32;
                                if (0..m).contains(&a) && (0..m).contains(&b) && (0..m).contains(&c)
                                {
                                    near |= occ[(a + m * (b + m * c)) as usize];
                                }
                            }
                        }
                    }
                    if near {
                        level[index(m, x as usize, y as usize, z as usize)] = i as u32;
                    }
                }
            }
        }
        levels.push(level);
    }
    levels
}

/// The index volume I(x) = min_i I_i(x / 2^i) (000, eq. 1).
pub fn index_at(levels: &[Vec<u32>], n: usize, x: usize, y: usize, z: usize) -> u32 {
    levels
        .iter()
        .enumerate()
        .map(|(i, l)| l[index(n >> i, x >> i, y >> i, z >> i)])
        .min()
        .unwrap_or(0)
}

/// Merge (000 §3.4): M(x) = S(x) = O_I(x)(x / 2^I(x)), scaled by 2^I to level-0 units: the
/// levels hold averages (eq. 2), and light on level i travels 2^i level-0 cells per step, so
/// its accumulated intensity per unit of travel is 2^i times smaller than level 0's.
pub fn merge(levels: &[Vec<Cell>], index_levels: &[Vec<u32>], n: usize) -> Vec<Cell> {
    let mut out = vec![[[0.0f32; 4]; 3]; n * n * n];
    for z in 0..n {
        for y in 0..n {
            for x in 0..n {
                let i = index_at(index_levels, n, x, y, z) as usize;
                let m = n >> i;
                let scale = (1u32 << i) as f32;
                let src = &levels[i][index(m, x >> i, y >> i, z >> i)];
                out[index(n, x, y, z)] = src.map(|c| c.map(|v| v * scale));
            }
        }
    }
    out
}

/// The error measures of 000 §4.1 over levels 1..l-1: average over all elements of the max-norm
/// difference between O_i and the downsample of O_{i-1} (absolute, and relative to |O_i|).
/// Elements whose max norm is zero are skipped in the relative error.
pub fn octree_errors(levels: &[Vec<Cell>], n: usize) -> (f64, f64) {
    let (mut abs, mut rel, mut count) = (0.0f64, 0.0f64, 0usize);
    for i in 1..levels.len() {
        let expected = downsample(&levels[i - 1], n >> (i - 1));
        for (o, e) in levels[i].iter().zip(&expected) {
            let mut diff = 0.0f32;
            let mut norm = 0.0f32;
            for ch in 0..3 {
                for k in 0..4 {
                    diff = diff.max((o[ch][k] - e[ch][k]).abs());
                    norm = norm.max(o[ch][k].abs());
                }
            }
            abs += diff as f64;
            if norm > 0.0 {
                rel += (diff / norm) as f64;
            }
            count += 1;
        }
    }
    let c = count.max(1) as f64;
    (abs / c, rel / c)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// Numeric integral over the sphere with a latitude-longitude midpoint rule.
    fn integrate(f: impl Fn(Vec3) -> f64) -> f64 {
        let (nt, np) = (400, 800);
        let mut sum = 0.0;
        for i in 0..nt {
            let theta = (i as f64 + 0.5) * PI / nt as f64;
            for j in 0..np {
                let phi = (j as f64 + 0.5) * 2.0 * PI / np as f64;
                let d = Vec3::new(
                    (theta.sin() * phi.cos()) as f32,
                    (theta.sin() * phi.sin()) as f32,
                    theta.cos() as f32,
                );
                sum += f(d) * theta.sin() * (PI / nt as f64) * (2.0 * PI / np as f64);
            }
        }
        sum
    }

    #[test]
    fn basis_is_orthonormal() {
        for a in 0..4 {
            for b in 0..4 {
                let v = integrate(|d| (basis(d)[a] * basis(d)[b]) as f64);
                let expected = if a == b { 1.0 } else { 0.0 };
                assert!((v - expected).abs() < 1e-3, "<Y{a},Y{b}> = {v}");
            }
        }
    }

    #[test]
    fn clamped_cosine_lobe_matches_quadrature_and_closed_form() {
        assert!((LOBE_C0 as f64 - PI.sqrt() / 2.0).abs() < 1e-6);
        assert!((LOBE_C1 as f64 - (PI / 3.0).sqrt()).abs() < 1e-6);
        let n = Vec3::new(0.3, -0.5, 0.8).normalize();
        let l = lobe(n);
        for (k, &expected) in l.iter().enumerate() {
            let v = integrate(|d| (n.dot(d).max(0.0) * basis(d)[k]) as f64);
            assert!(
                (v - expected as f64).abs() < 1e-3,
                "coefficient {k}: {v} vs {expected}"
            );
        }
        // A Lambertian emitter of flux 2 integrates to 2.
        assert!((flux(&lambertian_emitter(2.0, n)) - 2.0).abs() < 1e-5);
    }

    #[test]
    fn face_solid_angles_are_exact_and_cover_a_third_of_the_sphere() {
        // Source cell centre at the origin, destination cell [0.5, 1.5] along z.
        let front = rectangle_solid_angle(-0.5, 0.5, -0.5, 0.5, 1.5);
        let side = rectangle_solid_angle(0.5, 1.5, -0.5, 0.5, 0.5);
        assert!((front - 4.0 * (0.1f64).asin()).abs() < 1e-12);
        assert!((front - FRONT_SOLID_ANGLE as f64).abs() < 1e-7);
        assert!((side - SIDE_SOLID_ANGLE as f64).abs() < 1e-7, "side {side}");
        // Six neighbours x (front + 4 sides) = 4 pi: propagation conserves band-0 flux.
        assert!((6.0 * (front + 4.0 * side) - 4.0 * PI).abs() < 1e-12);
    }

    #[test]
    fn a_fully_covering_surface_blocks_from_both_sides() {
        let wall = lobe(Vec3::X);
        // Head-on from either side: opaque; grazing: the 2-band lobe's isotropic third.
        assert!((blocking(&wall, Vec3::X) - 1.0).abs() < 1e-6);
        assert!((blocking(&wall, -Vec3::X) - 1.0).abs() < 1e-6);
        assert!((blocking(&wall, Vec3::Y) - 1.0 / 3.0).abs() < 1e-6);
        // Partial coverage scales it; nothing blocks nothing.
        let half = wall.map(|c| c * 0.5);
        assert!((blocking(&half, -Vec3::X) - 0.5).abs() < 1e-6);
        assert_eq!(blocking(&[0.0; 4], Vec3::Z), 0.0);
    }

    #[test]
    fn reemission_carries_the_face_flux_and_keeps_direction_when_directional() {
        let (f, w) = (Vec3::X, Vec3::new(2.0, 1.0, 0.0).normalize());
        for directional in [0.0, 0.3, 1.0] {
            let c = reemit(2.0, f, w, directional);
            assert!((flux(&c) - 2.0).abs() < 1e-5, "{directional}");
        }
        // The beam's band 1 points along w, the Lambertian lobe's along the face normal.
        let beam = reemit(1.0, f, w, 1.0);
        let b1 = Vec3::new(-beam[3], -beam[1], beam[2]).normalize();
        assert!(b1.dot(w) > 0.9999);
        let lambert = reemit(1.0, f, w, 0.0);
        let l1 = Vec3::new(-lambert[3], -lambert[1], lambert[2]).normalize();
        assert!(l1.dot(f) > 0.9999);
    }

    #[test]
    fn cpu_propagation_conserves_flux_in_an_open_grid() {
        let n = 6;
        let mut v = vec![[[0.0f32; 4]; 3]; n * n * n];
        v[index(n, 2, 3, 1)][0] = lambertian_emitter(1.0, Vec3::new(0.2, 0.9, -0.4).normalize());
        v[index(n, 4, 4, 4)][2] = lambertian_emitter(0.5, Vec3::X);
        for step in 0..8 {
            let out = boundary_outflow(&v, n);
            let before = total_flux(&v);
            // Either re-emission carries the same flux.
            v = propagate_step(&v, n, None, if step % 2 == 0 { 0.0 } else { 1.0 });
            let after = total_flux(&v);
            for ch in 0..3 {
                assert!((after[ch] + out[ch] - before[ch]).abs() < 1e-5 * (1.0 + before[ch]));
            }
        }
    }

    #[test]
    fn octree_index_and_merge_pick_fine_levels_near_geometry() {
        let n = 8;
        let mut occ = vec![false; n * n * n];
        occ[index(n, 6, 6, 6)] = true;
        let levels = index_levels(&occ, n);
        assert_eq!(levels.len(), 4);
        assert_eq!(index_at(&levels, n, 6, 6, 6), 0);
        assert_eq!(index_at(&levels, n, 5, 5, 5), 0);
        assert_eq!(index_at(&levels, n, 4, 4, 4), 1);
        assert_eq!(index_at(&levels, n, 1, 1, 1), 2);
        let mut o0 = vec![[[0.0f32; 4]; 3]; n * n * n];
        o0[index(n, 1, 1, 1)][1] = [8.0, 0.0, 0.0, 0.0];
        let o1 = downsample(&o0, n);
        assert_eq!(o1[0][1][0], 1.0);
        let o2 = downsample(&o1, n / 2);
        let o3 = downsample(&o2, n / 4);
        let merged = merge(&[o0, o1, o2, o3], &levels, n);
        assert_eq!(merged[index(n, 6, 6, 6)][1][0], 0.0);
        // (1,1,1) samples level 2 cell (0,0,0) = 8/64, scaled by 2^2 to level-0 units.
        assert!((merged[index(n, 1, 1, 1)][1][0] - 0.5).abs() < 1e-7);
    }
}
