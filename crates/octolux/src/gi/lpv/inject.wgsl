// Injection: RSM texels become VPLs (one per stride x stride block, carrying the block's flux)
// injected as Lambertian SH lobes half a cell along their normal; RSM texels and G-buffer
// samples become surfels whose blocking potential A cos / s^2 goes into the geometry volumes
// (cells at LPV cell corners). A grid whose cells are k times the finest grid's (the octree's
// coarser levels, the outer cascades) takes one surfel per k x k block of texels or camera
// samples, standing for the block (k^2 times the area): each of its cells still gathers as
// many surfels as a finest cell, and the surfels a frame injects no longer grow with the
// number of levels.
//
// Sums are 64-bit fixed point, two u32 words per value added with integer atomics and a carry:
// a float sum by compare-exchange loops serialises when thousands of threads hit the same few
// cells (a wall's texels all land in a handful of cells), and its result depends on the order.
// Integer atomics cost the same under contention as without, and integer sums do not depend on
// their order, so every adapter gets the same volume. `resolve_light` and `combine_gv` turn the
// sums back into floats for propagation.

import octolux::frame::common::{Camera, PI, world_from_depth};
import octolux::gi::lpv::sh::{Grid, Grids, sh_lobe};
import octolux::gpu::work::count_work;

// Work counts (`INJECT_WORK` in inject.rs), per invocation until `count_inject_work`: RSM
// texels read, VPLs injected into a grid, surfels injected into a grid, atomic additions.
var<private> inject_work: vec4<u32>;

fn count_inject_work() {
    count_work(0u, inject_work.x);
    count_work(1u, inject_work.y);
    count_work(2u, inject_work.z);
    count_work(3u, inject_work.w);
}

// Read from a storage buffer: Mesa's lavapipe recompiles (and keeps) a shader whose branches or
// loop bounds depend on a small uniform block every time its pipeline is bound.

@group(0) @binding(0) var<storage, read> grids: Grids;
@group(0) @binding(1) var rsm_position: texture_2d_array<f32>;
@group(0) @binding(2) var rsm_normal: texture_2d_array<f32>;
@group(0) @binding(3) var rsm_flux: texture_2d_array<f32>;
// Low and high words of the 64-bit sums in separate buffers, so each is no larger than a float
// volume (adapters limit the size of one binding).
@group(0) @binding(4) var<storage, read_write> light_lo: array<atomic<u32>>;
@group(0) @binding(12) var<storage, read_write> light_hi: array<atomic<u32>>;
@group(0) @binding(5) var<storage, read_write> gv_lo: array<atomic<u32>>;
@group(0) @binding(13) var<storage, read_write> gv_hi: array<atomic<u32>>;
@group(0) @binding(6) var<uniform> cam: Camera;
@group(0) @binding(7) var depth_tex: texture_depth_2d;
@group(0) @binding(8) var normal_tex: texture_2d<f32>;
@group(0) @binding(9) var<storage, read> sums_lo: array<u32>;
@group(0) @binding(14) var<storage, read> sums_hi: array<u32>;
@group(0) @binding(10) var<storage, read_write> gv_out: array<vec4<f32>>;
@group(0) @binding(11) var<storage, read_write> light_out: array<f32>;

// Fixed-point scale of the geometry sums: one surfel blocks at most |1.0233| per coefficient,
// so 2^31 surfels fit the signed 64-bit range.
const GV_SCALE: f32 = 4294967296.0;
const TWO_32: f32 = 4294967296.0;

// x rounded to an integer, as a two's complement 64-bit (lo, hi). Every step is exact for
// |x| < 2^63: floor(m / 2^32) and m - hi 2^32 only drop or keep bits of m.
fn to_fixed(x: f32) -> vec2<u32> {
    let m = round(abs(x));
    let hi = floor(m / TWO_32);
    let lo = u32(m - hi * TWO_32);
    let h = u32(hi);
    if x >= 0.0 {
        return vec2<u32>(lo, h);
    }
    // Two's complement negation of (lo, h).
    let nlo = ~lo + 1u;
    return vec2<u32>(nlo, ~h + select(0u, 1u, nlo == 0u));
}

// The 64-bit value (lo, hi) as a float.
fn from_fixed(v: vec2<u32>) -> f32 {
    if (v.y & 0x80000000u) == 0u {
        return f32(v.y) * TWO_32 + f32(v.x);
    }
    let nlo = ~v.x + 1u;
    let nhi = ~v.y + select(0u, 1u, nlo == 0u);
    return -(f32(nhi) * TWO_32 + f32(nlo));
}

// Adds a 64-bit value to sum i: the low word first, then the high word with the carry out of
// the low one. Exact once every addition of the pass is done.
fn add_light(i: u32, v: f32) {
    let f = to_fixed(v * grids.light_scale);
    if f.x == 0u && f.y == 0u {
        return;
    }
    let old = atomicAdd(&light_lo[i], f.x);
    atomicAdd(&light_hi[i], f.y + select(0u, 1u, old + f.x < old));
    inject_work.w += 2u;
}

fn add_gv(i: u32, v: f32) {
    let f = to_fixed(v * GV_SCALE);
    if f.x == 0u && f.y == 0u {
        return;
    }
    let old = atomicAdd(&gv_lo[i], f.x);
    atomicAdd(&gv_hi[i], f.y + select(0u, 1u, old + f.x < old));
    inject_work.w += 2u;
}

// RSM texel: world position, unit normal facing the light, reflected flux (W) and surfel
// area (m^2). position.w holds the texel's measure m (solid angle, or area across the beam
// for orthographic maps), flux target = albedo x intensity (or x irradiance), normal.w the
// ratio area / m.
struct Texel {
    valid: bool,
    p: vec3<f32>,
    n: vec3<f32>,
    flux: vec3<f32>,
    area: f32,
};

fn rsm_texel(t: vec2<u32>, layer: u32) -> Texel {
    let pm = textureLoad(rsm_position, t, layer, 0);
    let nn = textureLoad(rsm_normal, t, layer, 0);
    let f = textureLoad(rsm_flux, t, layer, 0);
    var out: Texel;
    out.valid = pm.w > 0.0;
    out.p = pm.xyz;
    out.n = nn.xyz;
    out.flux = f.rgb * pm.w;
    out.area = pm.w * nn.w;
    return out;
}

// Grid `g` takes one surfel per `surfel_stride` x `surfel_stride` block of sources: its cell
// over the finest grid's, rounded on the CPU (`GpuGrid::surfel_stride`), flags bits 8..16.
fn surfel_stride(g: Grid) -> u32 {
    return max((g.flags >> 8u) & 0xffu, 1u);
}

// Injects the surfel of source (x, y) (an RSM texel, a camera sample) of area `area` into
// every grid whose surfel block it heads, with the block's area.
fn inject_surfel(x: u32, y: u32, p: vec3<f32>, n: vec3<f32>, area: f32, section: u32) {
    for (var gi = 0u; gi < grids.count; gi++) {
        let g = grids.grids[gi];
        let s = surfel_stride(g);
        if x % s == 0u && y % s == 0u {
            inject_blocking(g, p, n, area * f32(s * s), section);
        }
    }
}

fn inject_blocking(g: Grid, p: vec3<f32>, n: vec3<f32>, area: f32, section: u32) {
    let corner = vec3<i32>(round((p - g.origin) / g.cell));
    let m = i32(g.n) + 1;
    if any(corner < vec3<i32>(0)) || any(corner >= vec3<i32>(m)) {
        return;
    }
    let i = section + g.gv_offset + u32(corner.x + m * (corner.y + m * corner.z));
    inject_work.z += 1u;
    let b = sh_lobe(n) * min(area / (g.cell * g.cell), 1.0);
    for (var k = 0u; k < 4u; k++) {
        add_gv(i * 4u + k, b[k]);
    }
}

// One VPL of flux `flux` at `pos` with normal `n`, into every grid that receives light.
fn inject_vpl(pos: vec3<f32>, n: vec3<f32>, flux: vec3<f32>) {
    let lobe = sh_lobe(n) / PI;
    for (var gi = 0u; gi < grids.count; gi++) {
        let g = grids.grids[gi];
        if (g.flags & 2u) == 0u {
            continue;
        }
        let c = vec3<i32>(floor((pos + 0.5 * g.cell * n - g.origin) / g.cell));
        let gn = i32(g.n);
        if any(c < vec3<i32>(0)) || any(c >= vec3<i32>(gn)) {
            continue;
        }
        let cell = g.offset + u32(c.x + gn * (c.y + gn * c.z));
        inject_work.y += 1u;
        for (var ch = 0u; ch < 3u; ch++) {
            for (var k = 0u; k < 4u; k++) {
                add_light((cell * 3u + ch) * 4u + k, flux[ch] * lobe[k]);
            }
        }
    }
}

// Whether RSM layer `layer` is drawn at half the targets' side (what it shows moved since
// the last frame; `half_layer_mask` on the CPU, at most 256 layers).
fn half_layer(layer: u32) -> bool {
    let l = min(layer, 255u);
    let word = grids.half_layers[l / 128u][(l / 32u) % 4u];
    return layer < 256u && ((word >> (l % 32u)) & 1u) != 0u;
}

// The texels of layer `layer` that hold its RSM: the corner it was drawn into.
fn layer_size(layer: u32) -> vec2<u32> {
    let size = textureDimensions(rsm_flux);
    return select(size, size / 2u, half_layer(layer));
}

// One VPL per stride x stride block: the texels within one (finest) cell of the block's first
// lit texel are merged into a VPL at their flux-weighted centre carrying their summed flux;
// texels farther away (across a depth discontinuity: a block edge over the floor) become VPLs
// of their own, so no VPL floats between surfaces and no flux is lost.
@compute @workgroup_size(8, 8, 1)
fn inject_light(@builtin(global_invocation_id) id: vec3<u32>) {
    let full = textureDimensions(rsm_flux);
    let size = layer_size(id.z);
    // A half layer with half the stride: the same blocks, each a quarter of the texels.
    let stride = select(max(grids.stride, 1u), max(grids.stride / 2u, 1u), half_layer(id.z));
    let blocks = (full + max(grids.stride, 1u) - 1u) / max(grids.stride, 1u);
    if id.x >= blocks.x || id.y >= blocks.y {
        return;
    }
    var radius = 1e30;
    for (var gi = 0u; gi < grids.count; gi++) {
        if (grids.grids[gi].flags & 2u) != 0u {
            radius = min(radius, grids.grids[gi].cell);
        }
    }
    var have_ref = false;
    var reference = vec3<f32>(0.0);
    var flux = vec3<f32>(0.0);
    var pos = vec3<f32>(0.0);
    var nrm = vec3<f32>(0.0);
    var weight = 0.0;
    for (var sy = 0u; sy < stride; sy++) {
        for (var sx = 0u; sx < stride; sx++) {
            let t = id.xy * stride + vec2<u32>(sx, sy);
            if t.x >= size.x || t.y >= size.y {
                continue;
            }
            let texel = rsm_texel(t, id.z);
            inject_work.x += 1u;
            let w = texel.flux.r + texel.flux.g + texel.flux.b;
            if !texel.valid || w <= 0.0 {
                continue;
            }
            if !have_ref {
                have_ref = true;
                reference = texel.p;
            }
            if distance(texel.p, reference) > radius {
                inject_vpl(texel.p, texel.n, texel.flux);
                continue;
            }
            flux += texel.flux;
            pos += texel.p * w;
            nrm += texel.n * w;
            weight += w;
        }
    }
    if weight > 0.0 && dot(nrm, nrm) >= 1e-12 {
        inject_vpl(pos / weight, normalize(nrm), flux);
    }
    count_inject_work();
}

@compute @workgroup_size(8, 8, 1)
fn inject_gv_rsm(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = layer_size(id.z);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let texel = rsm_texel(id.xy, id.z);
    inject_work.x += 1u;
    if texel.valid {
        inject_surfel(id.x, id.y, texel.p, texel.n, texel.area, 0u);
    }
    count_inject_work();
}

// The G-buffer is sampled on a grid of at most CAMERA_SAMPLES^2 points: one pixel per square
// block of `grids.camera_stride`^2 pixels stands for the whole block (its footprint times the
// block's pixel count), so the pass costs the same at any output size.
@compute @workgroup_size(8, 8, 1)
fn inject_gv_camera(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = vec2<u32>(cam.size.xy);
    let s = max(grids.camera_stride, 1u);
    let first = id.xy * s;
    if first.x >= size.x || first.y >= size.y {
        return;
    }
    let last = min(first + vec2<u32>(s), size);
    let block = last - first;
    let px = first + block / 2u;
    let depth = textureLoad(depth_tex, px, 0);
    if depth >= 1.0 {
        return;
    }
    let p = world_from_depth(cam, px, depth);
    let n = normalize(textureLoad(normal_tex, px, 0).xyz);
    // Pixel footprint on the plane of constant view depth (spanned by the neighbouring
    // pixels at the same depth), tilted onto the surface.
    let dx = world_from_depth(cam, px + vec2<u32>(1u, 0u), depth) - p;
    let dy = world_from_depth(cam, px + vec2<u32>(0u, 1u), depth) - p;
    let across = cross(dx, dy);
    let plane_area = length(across);
    let ray = normalize(p - cam.position.xyz);
    let axis = across / max(plane_area, 1e-20);
    let pixel_area = plane_area * abs(dot(axis, ray)) / max(abs(dot(n, ray)), 0.1);
    let area = pixel_area * f32(block.x * block.y);
    inject_surfel(id.x, id.y, p, n, area, grids.gv_total);
    count_inject_work();
}

// Sum i of the resolve passes' input, as (lo, hi).
fn sum(i: u32) -> vec2<u32> {
    return vec2<u32>(sums_lo[i], sums_hi[i]);
}

// The injected light as floats (cell-major, 12 values per cell), for propagation.
@compute @workgroup_size(64, 1, 1)
fn resolve_light(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x + id.y * 65535u * 64u;
    if i >= arrayLength(&light_out) {
        return;
    }
    light_out[i] = from_fixed(sum(i)) / grids.light_scale;
}

// Max-combination of the two geometry sources: per cell, the one with the larger band-0
// blocking, so a surface seen by both the light and the camera is not counted twice.
@compute @workgroup_size(64, 1, 1)
fn combine_gv(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x + id.y * 65535u * 64u;
    if i >= grids.gv_total {
        return;
    }
    let j = i + grids.gv_total;
    let a = vec4<f32>(from_fixed(sum(4u * i)), from_fixed(sum(4u * i + 1u)),
        from_fixed(sum(4u * i + 2u)), from_fixed(sum(4u * i + 3u))) / GV_SCALE;
    let b = vec4<f32>(from_fixed(sum(4u * j)), from_fixed(sum(4u * j + 1u)),
        from_fixed(sum(4u * j + 2u)), from_fixed(sum(4u * j + 3u))) / GV_SCALE;
    gv_out[i] = select(a, b, b.x > a.x);
}
