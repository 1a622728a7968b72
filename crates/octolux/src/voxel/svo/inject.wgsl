// Light injection into the sparse voxel octree (Arnebäck 2017 §3.2: direct light from the
// shadow maps). `accumulate` sums the fragments' albedo, emission and normal per leaf voxel;
// `inject` turns every leaf voxel into outgoing radiance emission + albedo / pi x direct
// irradiance, with visibility from the renderer's shadow-map array (PCF as in
// `render/direct.wgsl`), and writes the leaf bricks of the radiance pool (RGBA16F, radiance
// and opacity) the way `leaf_fill` writes albedo; with the feature `facing`, the facing pool's
// leaf bricks too (the direction the radiance leaves in). The transfer and mip kernels of
// `svo/build.wgsl` then filter the pool upward.

import octolux::voxel::voxelize::overlap::{fragment_sum_terms, linear_index, Tri};
import octolux::voxel::svo::leaf_sums::{leaf_sum_offset, LEAF_EMISSION_SCALE, LEAF_SUM_WORDS, voxel_sums, VoxelSums};
import octolux::voxel::svo::control::SvoControlValues;
import octolux::voxel::svo::bounce_table::{bounce_table_hash, BOUNCE_TABLE_PROBES};
import octolux::frame::lights::{Light, light_incidence, lights, shadow_visibility};

// Per occupied leaf voxel: its fragments' sums (svo/leaf_sums.wgsl, `VoxelSums`).
const SUM_WORDS: u32 = LEAF_SUM_WORDS;

// The accumulation's parameters (`AccumulateParams` in svo/inject.rs). `sums` is the leaf
// sums buffer (svo/leaf_sums.wgsl) or, for `leaf_mask` and `leaf_slots`, its index part + 1
// counter word.
struct AccumulateParams {
    // Fragments in the list.
    fragments: u32,
    // Levels of the octree.
    depth: u32,
    // The static leaf nodes [first_leaf, first_leaf + leaf_count).
    first_leaf: u32,
    leaf_count: u32,
}

// Storage, not uniform: see "Parameter blocks" in voxel/mod.rs.
@group(0) @binding(0) var<storage, read> A: AccumulateParams;
@group(0) @binding(1) var<storage, read> fragments: array<vec2<u32>>;
@group(0) @binding(2) var<storage, read> tris: array<Tri>;
@group(0) @binding(3) var<storage, read> child: array<u32>;
@group(0) @binding(4) var<storage, read_write> sums: array<atomic<u32>>;

fn unpack3(c: u32) -> vec3<u32> {
    return vec3<u32>(c & 1023u, (c >> 10u) & 1023u, (c >> 20u) & 1023u);
}

// The static leaf node (relative to the first) and octant of fragment f, or INVALID_LEAF.
const INVALID_LEAF: u32 = 0xffffffffu;

fn fragment_leaf(f: u32) -> vec2<u32> {
    let v = unpack3(fragments[f].x);
    let leaf = A.depth - 1u;
    let c = v >> vec3<u32>(1u);
    var node = 0u;
    for (var l = 0u; l < leaf; l++) {
        let first = child[node];
        if first == 0u {
            return vec2<u32>(INVALID_LEAF);
        }
        let s = leaf - 1u - l;
        node = first + (((c.x >> s) & 1u) | (((c.y >> s) & 1u) << 1u) | (((c.z >> s) & 1u) << 2u));
    }
    if node < A.first_leaf || node >= A.first_leaf + A.leaf_count {
        return vec2<u32>(INVALID_LEAF);
    }
    return vec2<u32>(node - A.first_leaf, (v.x & 1u) | ((v.y & 1u) << 1u) | ((v.z & 1u) << 2u));
}

// Occupancy masks: every fragment marks its voxel in its leaf node's index word.
@compute @workgroup_size(64)
fn leaf_mask(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
             @builtin(local_invocation_index) li: u32) {
    let f = linear_index(wg, nwg, li);
    if f >= A.fragments {
        return;
    }
    let at = fragment_leaf(f);
    if at.x != INVALID_LEAF {
        atomicOr(&sums[at.x], 1u << at.y);
    }
}

// Sum slots: every leaf node takes one per occupied voxel (counter after the index words).
@compute @workgroup_size(64)
fn leaf_slots(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
              @builtin(local_invocation_index) li: u32) {
    let l = linear_index(wg, nwg, li);
    if l >= A.leaf_count {
        return;
    }
    let mask = atomicLoad(&sums[l]);
    let first = atomicAdd(&sums[A.leaf_count], countOneBits(mask));
    atomicStore(&sums[l], (first << 8u) | mask);
}

@compute @workgroup_size(64)
fn accumulate(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
              @builtin(local_invocation_index) li: u32) {
    let f = linear_index(wg, nwg, li);
    if f >= A.fragments {
        return;
    }
    let at = fragment_leaf(f);
    if at.x == INVALID_LEAF {
        return;
    }
    let w = leaf_sum_offset(atomicLoad(&sums[at.x]), at.y, A.leaf_count);
    let terms = fragment_sum_terms(tris[fragments[f].y]);
    for (var k = 0u; k < SUM_WORDS; k++) {
        atomicAdd(&sums[w + k], terms[k]);
    }
}

struct InjectParams {
    // The grid's origin and voxel size.
    origin: vec3<f32>,
    voxel_size: f32,
    // This dispatch's leaf nodes [first_leaf, first_leaf + leaf_count) (unless
    // `dynamic_leaves`).
    first_leaf: u32,
    leaf_count: u32,
    lights: u32,
    // Bricks per pool buffer.
    pool_bricks: u32,
    static_nodes: u32,
    first_static_leaf: u32,
    // `voxel_radiance` slot of this dispatch's first leaf.
    first_slot: u32,
    // 1 when the octree has a dynamic part (`dyn_sums`, `dyn_state`).
    has_dynamic: u32,
    // 1 when this dispatch's leaves are the dynamic nodes of level `leaf_level` as the
    // octree's last dynamic update left them on the GPU (`first_leaf` and `leaf_count`
    // unused), 0 otherwise.
    dynamic_leaves: u32,
    leaf_level: u32,
    // 1 when this dispatch takes part in multiple bounces (`bounce_*` below).
    bounce: u32,
    // For the dynamic leaves, the capacity of the table of last frame's gathered irradiance
    // (`dyn_bounce_*`; 0: their irradiance comes from `bounce_irradiance` by slot).
    bounce_table_capacity: u32,
}

// Storage, not uniform: see "Parameter blocks" in voxel/mod.rs.
@group(0) @binding(10) var<storage, read> P: InjectParams;
@group(0) @binding(11) var<storage, read> leaf_sums: array<u32>;
@group(0) @binding(12) var<storage, read> node_coord: array<u32>;
@group(0) @binding(13) var<storage, read> brick_index: array<u32>;
@group(0) @binding(18) var<storage, read_write> voxel_radiance: array<u32>;
@group(0) @binding(19) var<storage, read_write> pool0: array<u32>;
@group(0) @binding(20) var<storage, read_write> pool1: array<u32>;
@group(0) @binding(21) var<storage, read_write> pool2: array<u32>;
@group(0) @binding(22) var<storage, read_write> pool3: array<u32>;
// The dynamic part (svo/dynamic.wgsl): per node state (leaf slot + 1 in bits 2..) and the
// dynamic fragments' sums per slot.
@group(0) @binding(23) var<storage, read> dyn_sums: array<u32>;
@group(0) @binding(24) var<storage, read> dyn_state: array<u32>;
// The octree's control block (svo/control.wgsl), for the dynamic leaves' range.
@group(0) @binding(25) var<storage, read> control: SvoControlValues;
// Multiple bounces (range.z = 1), per `voxel_radiance` slot: the indirect irradiance a cone
// gather found for the voxel (RGBA16F pairs), added to its direct irradiance, and, for the
// next gather, the voxel's geometry: its coordinates (10 bits per axis, bit 30 set for an
// occupied voxel, 0 for an empty one) and its normal (snorm8x4).
@group(0) @binding(26) var<storage, read> bounce_irradiance: array<u32>;
@group(0) @binding(27) var<storage, read_write> bounce_geometry: array<u32>;
// The dynamic leaves are rebuilt every frame in another order, so the irradiance they
// gathered last frame is kept by voxel coordinates: an open-addressing table of keys (the
// geometry word, 0 = empty; `svo_bounce.wgsl` fills it) and RGBA16F values.
@group(0) @binding(28) var<storage, read> dyn_bounce_keys: array<u32>;
@group(0) @binding(29) var<storage, read> dyn_bounce_values: array<u32>;

// The facing pool (`Svo::facing`, with the feature `facing`), laid out as the radiance pool:
// per texel the sum of the radiance's weight (r + g + b) times the direction its surface
// faces (`VoxelLight::facing`).
@if(facing) @group(0) @binding(30) var<storage, read_write> facing0: array<u32>;
@if(facing) @group(0) @binding(31) var<storage, read_write> facing1: array<u32>;
@if(facing) @group(0) @binding(32) var<storage, read_write> facing2: array<u32>;
@if(facing) @group(0) @binding(33) var<storage, read_write> facing3: array<u32>;

const PI: f32 = 3.14159265358979;

@if(facing) fn facing_store(b: u32, t: u32, v: vec3<f32>) {
    let w = (b % P.pool_bricks) * 54u + 2u * t;
    let lo = pack2x16float(v.xy);
    let hi = pack2x16float(vec2<f32>(v.z, 0.0));
    switch b / P.pool_bricks {
        case 0u: { facing0[w] = lo; facing0[w + 1u] = hi; }
        case 1u: { facing1[w] = lo; facing1[w + 1u] = hi; }
        case 2u: { facing2[w] = lo; facing2[w + 1u] = hi; }
        default: { facing3[w] = lo; facing3[w + 1u] = hi; }
    }
}

@if(!facing) fn facing_store(b: u32, t: u32, v: vec3<f32>) {}

// A voxel's outgoing radiance and opacity, and the direction its radiance leaves in: the sum
// over its parts (emission, each light's direct light, the gathered bounce) of the part's
// weight r + g + b times the way the surface it lights faces. A voxel without a dominant
// normal (a wall thinner than the voxel: its two faces' normals cancel) is lit as facing each
// light, so its direct light faces that light: seen from the wall's other side it is not there.
struct VoxelLight {
    value: vec4<f32>,
    facing: vec3<f32>,
}

fn weight(c: vec3<f32>) -> f32 {
    return c.x + c.y + c.z;
}

fn pool_store(b: u32, i: u32, v: u32) {
    let w = (b % P.pool_bricks) * 54u + i;
    switch b / P.pool_bricks {
        case 0u: { pool0[w] = v; }
        case 1u: { pool1[w] = v; }
        case 2u: { pool2[w] = v; }
        default: { pool3[w] = v; }
    }
}

// The fragment sums of octant `o` of leaf node `node`: its static sums plus, in an octree with
// a dynamic part, those of the dynamic fragments.
fn leaf_voxel_sums(node: u32, o: u32) -> VoxelSums {
    var s: array<u32, 10>;
    if node >= P.first_static_leaf && node < P.static_nodes {
        let leaves = P.static_nodes - P.first_static_leaf;
        let w = leaf_sum_offset(leaf_sums[node - P.first_static_leaf], o, leaves);
        if w != 0xffffffffu {
            for (var k = 0u; k < SUM_WORDS; k++) {
                s[k] = leaf_sums[w + k];
            }
        }
    }
    if P.has_dynamic != 0u {
        let slot = dyn_state[node] >> 2u;
        if slot != 0u {
            let w = ((slot - 1u) * 8u + o) * SUM_WORDS;
            for (var k = 0u; k < SUM_WORDS; k++) {
                s[k] += dyn_sums[w + k];
            }
        }
    }
    return voxel_sums(s);
}

// The unit mean normal of the leaf voxel with fragment sums `s`, zero where its fragments'
// normals cancel (opposite faces in one voxel) or it is empty.
fn voxel_normal(s: VoxelSums) -> vec3<f32> {
    let c = f32(s.count);
    let n = vec3<f32>(s.normal);
    if s.count == 0u || dot(n, n) <= 0.01 * c * c * 127.0 * 127.0 {
        return vec3<f32>(0.0);
    }
    return normalize(n);
}

// Outgoing radiance and opacity at `p` of the leaf voxel with fragment sums `s`, which also
// receives the irradiance `e0` (multiple bounces), and the direction it leaves in.
fn voxel_value(s: VoxelSums, p: vec3<f32>, e0: vec3<f32>) -> VoxelLight {
    let count = s.count;
    if count == 0u {
        return VoxelLight(vec4<f32>(0.0), vec3<f32>(0.0));
    }
    let c = f32(count);
    let albedo = vec3<f32>(s.albedo) / c / 255.0;
    let emission = vec3<f32>(s.emission) / c / LEAF_EMISSION_SCALE;
    let n = voxel_normal(s);
    let has_normal = dot(n, n) > 0.5;
    var e = e0;
    var facing = n * weight(emission + albedo / PI * e0);
    for (var k = 0u; k < P.lights; k++) {
        let light = lights[k];
        let inc = light_incidence(light, p);
        // A voxel without a dominant normal (opposite faces cancelled) is lit as facing the light.
        var cos_theta = 1.0;
        if has_normal {
            cos_theta = dot(n, inc.to_light);
        }
        if cos_theta <= 0.0 || all(inc.irradiance <= vec3<f32>(0.0)) {
            continue;
        }
        // Looked up half a voxel along the normal: the surface may lie anywhere in the voxel.
        let lift = 0.5 * P.voxel_size;
        let direct = inc.irradiance * cos_theta * shadow_visibility(light, p, n, inc.to_light, inc.dist, lift);
        e += direct;
        facing += select(inc.to_light, n, has_normal) * weight(albedo / PI * direct);
    }
    return VoxelLight(vec4<f32>(emission + albedo / PI * e, 1.0), facing);
}

// Last frame's irradiance of the dynamic voxel `key` (zero where it was not there).
fn dyn_bounce_lookup(key: u32) -> vec3<f32> {
    let mask = P.bounce_table_capacity - 1u;
    var e = bounce_table_hash(key) & mask;
    for (var i = 0u; i < BOUNCE_TABLE_PROBES; i++) {
        let k = dyn_bounce_keys[e];
        if k == key {
            return vec3<f32>(unpack2x16float(dyn_bounce_values[2u * e]),
                             unpack2x16float(dyn_bounce_values[2u * e + 1u]).x);
        }
        if k == 0u {
            break;
        }
        e = (e + 1u) & mask;
    }
    return vec3<f32>(0.0);
}

fn octant(o: u32) -> vec3<u32> {
    return vec3<u32>(o & 1u, (o >> 1u) & 1u, (o >> 2u) & 1u);
}

@compute @workgroup_size(64)
fn inject(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
          @builtin(local_invocation_index) li: u32) {
    let l = linear_index(wg, nwg, li);
    var first = P.first_leaf;
    var count = P.leaf_count;
    if P.dynamic_leaves != 0u {
        let leaves = control.dynamic_levels[P.leaf_level];
        first = leaves.first;
        count = leaves.end - first;
    }
    if l >= count {
        return;
    }
    let n = first + l;
    let b1 = brick_index[n];
    let c = unpack3(node_coord[n]);
    var voxels: array<vec4<f32>, 8>;
    var facings: array<vec3<f32>, 8>;
    for (var o = 0u; o < 8u; o++) {
        let v = 2u * c + octant(o);
        let p = P.origin + (vec3<f32>(v) + 0.5) * P.voxel_size;
        let slot = (P.first_slot + l) * 8u + o;
        let sums = leaf_voxel_sums(n, o);
        var e0 = vec3<f32>(0.0);
        if P.bounce != 0u {
            let key = select(0u, v.x | (v.y << 10u) | (v.z << 20u) | (1u << 30u), sums.count != 0u);
            if P.bounce_table_capacity == 0u {
                e0 = vec3<f32>(unpack2x16float(bounce_irradiance[2u * slot]),
                               unpack2x16float(bounce_irradiance[2u * slot + 1u]).x);
            } else if key != 0u {
                e0 = dyn_bounce_lookup(key);
            }
            bounce_geometry[2u * slot] = key;
            bounce_geometry[2u * slot + 1u] = pack4x8snorm(vec4<f32>(voxel_normal(sums), 0.0));
        }
        let light = voxel_value(sums, p, e0);
        voxels[o] = light.value;
        facings[o] = light.facing;
        voxel_radiance[2u * slot] = pack2x16float(voxels[o].xy);
        voxel_radiance[2u * slot + 1u] = pack2x16float(voxels[o].zw);
    }
    if b1 == 0u {
        return;
    }
    let b = b1 - 1u;
    for (var t = 0u; t < 27u; t++) {
        let i = vec3<u32>(t % 3u, (t / 3u) % 3u, t / 9u);
        var sum = vec4<f32>(0.0);
        var facing = vec3<f32>(0.0);
        for (var o = 0u; o < 8u; o++) {
            let a = octant(o);
            if all(i >= a) && all(i - a <= vec3<u32>(1u)) {
                sum += voxels[o] * 0.125;
                facing += facings[o] * 0.125;
            }
        }
        pool_store(b, 2u * t, pack2x16float(sum.xy));
        pool_store(b, 2u * t + 1u, pack2x16float(sum.zw));
        facing_store(b, t, facing);
    }
}
