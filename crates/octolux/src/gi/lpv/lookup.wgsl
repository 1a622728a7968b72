// Lookup: per G-buffer pixel, trilinear SH sample of the accumulated LPV (manual filtering of
// the cell-centred storage buffer), optional damping against leaks (001 §3.3.1), irradiance
// E = max(0, <c, lobe(-n)>) / s^2 x gain. With several grids (cascades), the finest grid that
// contains the point wins, blended towards the next coarser one over `blend` cells at its
// border.

import octolux::frame::common::{Camera, world_from_depth};
import octolux::gi::lpv::sh::{Grid, Grids, LOOKUP_OFFSET, sh_lobe};

@group(0) @binding(0) var<uniform> cam: Camera;
// Read from a storage buffer: Mesa's lavapipe recompiles (and keeps) a shader whose branches or
// loop bounds depend on a small uniform block every time its pipeline is bound.
@group(0) @binding(1) var<storage, read> grids: Grids;
@group(0) @binding(2) var depth_tex: texture_depth_2d;
@group(0) @binding(3) var normal_tex: texture_2d<f32>;
@group(0) @binding(4) var<storage, read> volume: array<vec4<f32>>;
@group(0) @binding(5) var out_tex: texture_storage_2d<rgba16float, write>;

struct Rgb {
    r: vec4<f32>,
    g: vec4<f32>,
    b: vec4<f32>,
};

fn sample_grid(g: Grid, p: vec3<f32>) -> Rgb {
    let n = i32(g.n);
    let u = clamp((p - g.origin) / g.cell - 0.5, vec3<f32>(0.0), vec3<f32>(f32(n - 1)));
    let i0 = min(vec3<i32>(floor(u)), vec3<i32>(n - 1));
    let f = u - vec3<f32>(i0);
    var out = Rgb(vec4<f32>(0.0), vec4<f32>(0.0), vec4<f32>(0.0));
    for (var k = 0; k < 8; k++) {
        let o = vec3<i32>(k & 1, (k >> 1) & 1, (k >> 2) & 1);
        let c = min(i0 + o, vec3<i32>(n - 1));
        let w3 = select(1.0 - f, f, o == vec3<i32>(1));
        let w = w3.x * w3.y * w3.z;
        let i = (g.offset + u32(c.x + n * (c.y + n * c.z))) * 3u;
        out.r += w * volume[i];
        out.g += w * volume[i + 1u];
        out.b += w * volume[i + 2u];
    }
    return out;
}

// 001 §3.3.1: where the SH and its derivative along the normal point apart, the light comes
// from behind the surface; move the coefficients by `damping` x the derivative.
fn damp(c: vec4<f32>, grad: vec4<f32>) -> vec4<f32> {
    if dot(c, grad) < 0.0 {
        let d = c + grids.damping * grad;
        // Never flip the sign of the band-0 term.
        return select(d, vec4<f32>(0.0), d.x * c.x < 0.0);
    }
    return c;
}

fn irradiance(g: Grid, surface: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let p = surface + n * (LOOKUP_OFFSET * g.cell);
    var c = sample_grid(g, p);
    if grids.damping > 0.0 {
        let front = sample_grid(g, p + n * (0.5 * g.cell));
        let back = sample_grid(g, p - n * (0.5 * g.cell));
        c.r = damp(c.r, front.r - back.r);
        c.g = damp(c.g, front.g - back.g);
        c.b = damp(c.b, front.b - back.b);
    }
    let l = sh_lobe(-n);
    let e = vec3<f32>(dot(c.r, l), dot(c.g, l), dot(c.b, l));
    return max(e, vec3<f32>(0.0)) / (g.cell * g.cell);
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = vec2<u32>(cam.size.xy);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let depth = textureLoad(depth_tex, id.xy, 0);
    if depth >= 1.0 || grids.count == 0u {
        textureStore(out_tex, id.xy, vec4<f32>(0.0, 0.0, 0.0, 1.0));
        return;
    }
    let p = world_from_depth(cam, id.xy, depth);
    let n = normalize(textureLoad(normal_tex, id.xy, 0).xyz);
    // The light reaching a surface is read LOOKUP_OFFSET (one) cell in front of it, so that no
    // cell behind the surface enters the trilinear sample and the surface's own blocking
    // potential at the cell corners does not shadow it.
    var e = irradiance(grids.grids[grids.count - 1u], p, n);
    for (var k = i32(grids.count) - 2; k >= 0; k--) {
        let g = grids.grids[k];
        let u = (p - g.origin) / g.cell - 0.5;
        let inner = min(min(u.x, min(u.y, u.z)), f32(g.n) - 1.0 - max(u.x, max(u.y, u.z)));
        if inner < 0.0 {
            continue;
        }
        let w = clamp(inner / max(grids.blend, 1e-3), 0.0, 1.0);
        e = mix(e, irradiance(g, p, n), w);
    }
    textureStore(out_tex, id.xy, vec4<f32>(e * grids.gain, 1.0));
}
