// Interleaved VPL shading (002 §3.2, eq. 1-4) and the geometry-aware merge.
//
// Sparse shading (`sparse` setting, `frame/sparse.rs`): the pixels below are those of the
// reduced image, one per f x f block of the G-buffer, each standing at its block's centre
// pixel; `frame/upsample.wgsl` reconstructs the full image after the merge (f = 1: every
// pixel, no reconstruction).
//
// `shade`: the image is split into I x I sub-images by addressing, not by copying: dispatch z
// is the sub-image k = (y mod I) I + (x mod I), and its pixels (x, y) sum VPL subset k, the
// VPLs j = k, k + I^2, k + 2 I^2, ... (the VPLs are stratified over the RSMs in index order, so
// every subset is spread over all of them). Workgroups never straddle sub-images, so a
// workgroup reads one subset. Per pixel p (normal n) and VPL (p_v, n_v, Phi, area A):
//   G = max(0, cos_i) max(0, cos_o) / max(B, A / pi, |p - p_v|^2)       (eq. 2-4)
//   E += I^2 / pi x Phi G (1 - V)                                          (eq. 1)
// 1/pi turns the VPL's flux into the radiant intensity of a Lambertian emitter (Phi/pi cos_o),
// I^2 scales the subset up to all N VPLs (each subset holds 1/I^2 of them), so the expected
// value over subsets is the full VPL sum. VPLs with G = 0 (behind either surface), no flux,
// or a mean contribution below `cull` (W/m^2) are skipped before the shadow ray.
//
// Russian roulette (`roulette` r > 0): a VPL whose mean unoccluded contribution c is below
// r x the mean of c over the pixel's VPLs in this dispatch that pass the test above traces its
// ray with probability p = c / threshold and, if visible, adds its contribution / p: the
// expected value is unchanged, and each rouletted VPL adds at most threshold^2 / 4 of
// variance. The random number hashes the pixel and the VPL index, so a still frame is the
// same frame after frame.

// `merge`: every pixel averages the I x I window around it (which holds every sub-image once)
// over the pixels on its own surface: normal within `normal_min` (cosine) and the neighbour's
// distance to the pixel's tangent plane within `plane_tol` x its distance to the camera. The
// weights are 0 or 1 and normalised, so a pixel's value stays an average of unbiased
// estimates of its full VPL sum.

import octolux::voxel::svo::walk::{count_walk_work, svo_occluded, vpl_fixed_point};
import octolux::gpu::work::count_work;
import octolux::frame::common::{Camera, PI, world_from_depth};
import octolux::frame::sparse::block_pixel;
import octolux::gi::vpl::vpl::Vpl;


struct ShadeParams {
    count: u32,
    interleave: u32,
    clamp_b: f32,
    cull: f32,
    normal_min: f32,
    plane_tol: f32,
    merge_on: u32,
    // The sparse factor f.
    sparse: u32,
    // VPLs of a subset one `shade` dispatch sums per pixel, a lane each: 8, 16, 32 or 64
    // (whole chunks of CHUNK).
    lanes: u32,
    // Russian roulette's threshold r, in means of the pixel's contributions (0: off).
    roulette: f32,
};

@group(0) @binding(0) var<uniform> cam: Camera;
@group(0) @binding(4) var depth_tex: texture_depth_2d;
@group(0) @binding(5) var normal_tex: texture_2d<f32>;
@group(0) @binding(6) var<storage, read> vpls: array<Vpl>;
@group(0) @binding(7) var<storage, read> sp: ShadeParams;
// Per pixel (row-major) the sum of its subset so far; `shade` runs once per `lanes` VPLs of
// the subset (one dispatch where the subset holds at most 64) and adds to it, `merge` reads it.
@group(0) @binding(8) var<storage, read_write> raw: array<vec4<f32>>;
@group(0) @binding(9) var<storage, read> raw_in: array<vec4<f32>>;
// The merged image: the indirect irradiance (f = 1) or the reduced image (f > 1).
@group(0) @binding(10) var out_tex: texture_storage_2d<rgba16float, write>;
// The first chunk of VPLs a `shade` dispatch sums (one slot per dispatch).
@group(0) @binding(13) var<storage, read> chunk: u32;

// Work counts of `shade` (`SHADE_WORK` in vpl/mod.rs): pixels shaded, VPL pairs evaluated,
// shadow rays, octree cells the rays visited, octree nodes their descents visited.
const WORK_PIXELS: u32 = 0u;
const WORK_PAIRS: u32 = 1u;
const WORK_RAYS: u32 = 2u;
const WORK_CELLS: u32 = 3u;
const WORK_NODES: u32 = 4u;

// The subset is summed in chunks of this many VPLs: each chunk's sum in VPL order, then the
// chunks' sums in order. The order is that of one dispatch per chunk, which `shade` once was
// (a lane per VPL of the chunk, the chunk's sum added to `raw`); a dispatch now takes
// `lanes / CHUNK` chunks at once, so that a pixel's shadow rays are all in flight together
// instead of one chunk's after another's, and sums them in the same order: the same image to
// the bit.
const CHUNK: u32 = 8u;
// 1 / pi: a disk of area A has radius^2 A / pi.
const DISK_SCALE: f32 = 0.31830988;


// Eq. 2-4: the geometry term of a VPL at `pv` (normal `nv`) for a receiver at `p` (normal `n`).
fn vpl_g(p: vec3<f32>, n: vec3<f32>, pv: vec3<f32>, nv: vec3<f32>, area: f32) -> f32 {
    let d = p - pv;
    let r2 = dot(d, d);
    if r2 <= 0.0 {
        return 0.0;
    }
    let w = d * inverseSqrt(r2);
    let cos_i = max(0.0, dot(n, -w));
    let cos_o = max(0.0, dot(nv, w));
    // The bound of r^2: the clamp, or the squared radius of a disk of the VPL's area
    // (`vpl_clamp` in vpl/mod.rs).
    return cos_i * cos_o / max(max(sp.clamp_b, area * DISK_SCALE), r2);
}

// The G-buffer's size, and the reduced image's (one pixel per f x f block).
fn full_size() -> vec2<u32> {
    return vec2<u32>(cam.size.xy);
}

fn reduced_size() -> vec2<u32> {
    return (full_size() + vec2<u32>(sp.sparse - 1u)) / sp.sparse;
}

// The G-buffer pixel reduced pixel `q` stands for.
fn gbuffer_pixel(q: vec2<u32>) -> vec2<u32> {
    return block_pixel(q, sp.sparse, full_size());
}

// One VPL's shaded irradiance per lane: a workgroup holds 64 / `lanes` pixels of one
// sub-image's row and `lanes` lanes per pixel, one per VPL, each tracing at most one shadow
// ray. (One lane per pixel walking its rays one after another left a large GPU mostly idle
// and waiting: a reduced image holds too few pixels to fill it.)
var<workgroup> vpl_irradiance: array<vec4<f32>, 64>;
// Each lane's unoccluded mean contribution and whether it has one, summed per pixel for the
// roulette.
var<workgroup> vpl_share: array<vec2<f32>, 64>;

// A uniform number in [0, 1) from the pixel and the VPL index (a PCG-style integer hash).
fn roulette_number(pixel: u32, vpl: u32) -> f32 {
    var h = pixel * 747796405u + 2891336453u;
    h = (h ^ (vpl * 277803737u + 1013904223u)) * 747796405u;
    h = ((h >> ((h >> 28u) + 4u)) ^ h) * 277803737u;
    h = (h >> 22u) ^ h;
    return f32(h >> 8u) * (1.0 / 16777216.0);
}

// The sum of `vpl_share` over each pixel's `lanes` lanes, in the pixel's first lane (a tree
// over halving strides; every lane passes every barrier).
fn sum_shares(li: u32, l: u32, lanes: u32) {
    for (var i = 0u; i < 6u; i++) {
        let stride = 32u >> i;
        if stride < lanes && l < stride {
            vpl_share[li] += vpl_share[li + stride];
        }
        workgroupBarrier();
    }
}

@compute @workgroup_size(64)
fn shade(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let m = sp.interleave;
    let k = wg.z;
    let lanes = sp.lanes;
    let l = li % lanes;
    let q = vec2<u32>((wg.x * (64u / lanes) + li / lanes) * m + k % m, wg.y * m + k / m);
    let size = reduced_size();
    let inside = q.x < size.x && q.y < size.y;
    let at = q.y * size.x + q.x;
    var sky = true;
    var e = vec3<f32>(0.0);
    var pairs = 0u;
    var rays = 0u;
    // The candidate's position, normal, VPL and contribution, for the ray after the sum.
    var c = 0.0;
    var p = vec3<f32>(0.0);
    var n = vec3<f32>(0.0);
    var v: Vpl;
    var g = 0.0;
    let scale = f32(m * m) / PI;
    // VPL l of this dispatch's VPLs of subset k.
    let j = k + (chunk * CHUNK + l) * m * m;
    if inside {
        let px = gbuffer_pixel(q);
        let depth = textureLoad(depth_tex, px, 0);
        sky = depth >= 1.0;
        if !sky && j < sp.count {
            p = world_from_depth(cam, px, depth);
            n = normalize(textureLoad(normal_tex, px, 0).xyz);
            pairs = 1u;
            v = vpls[j];
            g = vpl_g(p, n, v.position, v.normal, v.area);
            let mean = scale * v.mean_flux * g;
            if g > 0.0 && mean > sp.cull {
                c = mean;
            }
        }
    }
    vpl_share[li] = vec2<f32>(c, f32(c > 0.0));
    workgroupBarrier();
    sum_shares(li, l, lanes);
    let pixel = vpl_share[li - l];
    let threshold = sp.roulette * pixel.x / max(pixel.y, 1.0);
    if c > 0.0 {
        // The weight 1 / p of a ray that survives the roulette (1 above the threshold).
        var weight = 1.0;
        if c < threshold {
            weight = threshold / c;
        }
        if weight == 1.0 || roulette_number(at, j) * weight < 1.0 {
            rays = 1u;
            let a = vpl_fixed_point(p, n);
            if !svo_occluded(a, vpl_fixed_point(v.position, v.normal)) {
                e = scale * v.flux * g * weight;
            }
        }
    }
    vpl_irradiance[li] = vec4<f32>(e, 0.0);
    workgroupBarrier();
    // The pixel's first lane adds each chunk's VPLs in index order, then the chunks in order.
    if inside && l == 0u {
        if sky {
            raw[at] = vec4<f32>(0.0);
        } else {
            // (A chunk past the subset's last VPL adds +0: exact.)
            var total = vec3<f32>(0.0);
            if chunk != 0u {
                total = raw[at].rgb;
            }
            for (var c = 0u; c < lanes / CHUNK; c++) {
                var sum = vec3<f32>(0.0);
                for (var i = 0u; i < CHUNK; i++) {
                    sum += vpl_irradiance[li + c * CHUNK + i].rgb;
                }
                if chunk + c == 0u {
                    total = sum;
                } else {
                    total += sum;
                }
            }
            count_work(WORK_PIXELS, u32(chunk == 0u));
            raw[at] = vec4<f32>(total, 0.0);
        }
    }
    count_work(WORK_PAIRS, pairs);
    count_work(WORK_RAYS, rays);
    count_walk_work(WORK_CELLS, WORK_NODES);
}

@compute @workgroup_size(8, 8)
fn merge(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = reduced_size();
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let px = gbuffer_pixel(id.xy);
    let depth = textureLoad(depth_tex, px, 0);
    if depth >= 1.0 || sp.merge_on == 0u {
        textureStore(out_tex, id.xy, vec4<f32>(raw_in[id.y * size.x + id.x].rgb, 1.0));
        return;
    }
    let p = world_from_depth(cam, px, depth);
    let n = normalize(textureLoad(normal_tex, px, 0).xyz);
    let tol = sp.plane_tol * length(p - cam.position.xyz);
    let m = i32(sp.interleave);
    var sum = vec3<f32>(0.0);
    var weight = 0.0;
    for (var dy = -m / 2; dy < m - m / 2; dy++) {
        for (var dx = -m / 2; dx < m - m / 2; dx++) {
            let q = vec2<i32>(id.xy) + vec2<i32>(dx, dy);
            if any(q < vec2<i32>(0)) || any(q >= vec2<i32>(size)) {
                continue;
            }
            let gq = gbuffer_pixel(vec2<u32>(q));
            let dq = textureLoad(depth_tex, gq, 0);
            if dq >= 1.0 {
                continue;
            }
            let nq = normalize(textureLoad(normal_tex, gq, 0).xyz);
            let pq = world_from_depth(cam, gq, dq);
            if dot(n, nq) < sp.normal_min || abs(dot(n, pq - p)) > tol {
                continue;
            }
            sum += raw_in[u32(q.y) * size.x + u32(q.x)].rgb;
            weight += 1.0;
        }
    }
    textureStore(out_tex, id.xy, vec4<f32>(sum / max(weight, 1.0), 1.0));
}
