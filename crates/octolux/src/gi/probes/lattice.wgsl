// Direction lattices (gi/probes/lattice.rs, its CPU twin `direction`): direction k of n and
// the solid angle it stands for. Pole axis +y. Angles are reduced to [-pi, pi) before sin/cos,
// where WGSL bounds their error.

const LATTICE_PARALLELS: u32 = 8u;
const GOLDEN_TURNS: f32 = 0.38196602;
const TAU: f32 = 6.28318530717959;

fn lattice_reduced_angle(turns: f32) -> f32 {
    let t = select(turns, turns - 1.0, turns >= 0.5);
    return t * TAU;
}

// kind 0: Fibonacci (004 eqs. 2.3-2.4), 1: latitude-longitude (8 parallels).
fn lattice_dir(kind: u32, k: u32, n: u32) -> vec4<f32> {
    if kind == 0u {
        let odd = f32(2u * k + 1u);
        let z = 1.0 - odd / f32(n);
        let turns = fract(odd * (0.5 * GOLDEN_TURNS));
        let phi = lattice_reduced_angle(turns);
        let r = sqrt(max(1.0 - z * z, 0.0));
        return vec4<f32>(r * cos(phi), z, r * sin(phi), 4.0 * 3.14159265358979 / f32(n));
    }
    let meridians = max(n / LATTICE_PARALLELS, 1u);
    let i = k / meridians;
    let j = k % meridians;
    let p = f32(LATTICE_PARALLELS);
    let theta = 3.14159265358979 * (f32(i) + 0.5) / p;
    let phi = lattice_reduced_angle(f32(j) / f32(meridians));
    let s = sin(theta);
    let c = cos(theta);
    let lo = cos(3.14159265358979 * f32(i) / p);
    let hi = cos(3.14159265358979 * f32(i + 1u) / p);
    return vec4<f32>(s * cos(phi), c, s * sin(phi), (lo - hi) * TAU / f32(meridians));
}
