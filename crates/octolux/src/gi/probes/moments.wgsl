// Depth moments per probe (gi/probes/moments.rs): a MOMENT_RES x MOMENT_RES octahedral map of
// the mean distance and mean squared distance of the probe's surfels, and DDGI's Chebyshev
// visibility of a point from a probe, which reads the maps at binding 8 (MOMENT_TEXELS per
// probe; the pass that builds them writes through its own binding).

import octolux::gi::probes::probes::P;

const MOMENT_RES: u32 = 16u;
const MOMENT_TEXELS: u32 = 256u;

@group(0) @binding(8) var<storage, read> moments: array<vec2<f32>>;

// Octahedral map of unit d onto [-1, 1]^2 (+z on the inner diamond).
fn oct_encode(d: vec3<f32>) -> vec2<f32> {
    let a = d / (abs(d.x) + abs(d.y) + abs(d.z));
    if a.z >= 0.0 {
        return a.xy;
    }
    let s = select(vec2<f32>(-1.0), vec2<f32>(1.0), a.xy >= vec2<f32>(0.0));
    return (vec2<f32>(1.0) - abs(a.yx)) * s;
}

fn oct_decode(e: vec2<f32>) -> vec3<f32> {
    var v = vec3<f32>(e, 1.0 - abs(e.x) - abs(e.y));
    if v.z < 0.0 {
        let s = select(vec2<f32>(-1.0), vec2<f32>(1.0), v.xy >= vec2<f32>(0.0));
        v = vec3<f32>((vec2<f32>(1.0) - abs(v.yx)) * s, v.z);
    }
    return normalize(v);
}

// Direction of texel i's centre.
fn moment_texel_dir(i: u32) -> vec3<f32> {
    let t = vec2<f32>(f32(i % MOMENT_RES), f32(i / MOMENT_RES));
    return oct_decode((t + 0.5) / f32(MOMENT_RES) * 2.0 - 1.0);
}

// Kernel weight of a surfel along d for a texel along t: max(0, t . d)^32.
fn moment_kernel(t: vec3<f32>, d: vec3<f32>) -> f32 {
    let c = max(dot(t, d), 0.0);
    let c2 = c * c;
    let c4 = c2 * c2;
    let c8 = c4 * c4;
    let c16 = c8 * c8;
    return c16 * c16;
}

// Texel (x, y) of a probe's map, outside the map folded back as the octahedron's edges meet:
// across a vertical edge row y becomes R - 1 - y, across a horizontal one column x does.
fn moment_fetch(probe: u32, x: i32, y: i32) -> vec2<f32> {
    let r = i32(MOMENT_RES);
    var ix = x;
    var iy = y;
    if ix < 0 || ix >= r {
        ix = clamp(ix, 0, r - 1);
        iy = r - 1 - iy;
    }
    if iy < 0 || iy >= r {
        iy = clamp(iy, 0, r - 1);
        ix = r - 1 - ix;
    }
    return moments[probe * MOMENT_TEXELS + u32(iy * r + ix)];
}

// The moments along unit d, bilinear between the 4 nearest texel centres.
fn moment_sample(probe: u32, d: vec3<f32>) -> vec2<f32> {
    let f = (oct_encode(d) * 0.5 + 0.5) * f32(MOMENT_RES) - 0.5;
    let i = floor(f);
    let t = f - i;
    let x = i32(i.x);
    let y = i32(i.y);
    let a = mix(moment_fetch(probe, x, y), moment_fetch(probe, x + 1, y), t.x);
    let b = mix(moment_fetch(probe, x, y + 1), moment_fetch(probe, x + 1, y + 1), t.x);
    return mix(a, b, t.y);
}

// DDGI's Chebyshev visibility of point q from the probe at x: 1 up to the mean distance along
// x -> q, beyond it (var / (var + (r - mean)^2))^3 with var = max(E[d^2] - E[d]^2, floor)
// (P.variance_floor); 1 when the moments are off (P.visibility == 0).
fn probe_visibility(probe: u32, x: vec3<f32>, q: vec3<f32>) -> f32 {
    let v = q - x;
    let r = length(v);
    if P.visibility == 0u || r <= 0.0 {
        return 1.0;
    }
    let m = moment_sample(probe, v / r);
    if r <= m.x {
        return 1.0;
    }
    let variance = max(m.y - m.x * m.x, P.variance_floor);
    let e = r - m.x;
    let c = variance / (variance + e * e);
    return c * c * c;
}
