// What both light injections into the clipmap share (`inject.wgsl`: voxel shadow rays,
// `inject_shadow.wgsl`: the renderer's shadow maps): every occupied voxel gets outgoing
// radiance emission + albedo / pi x direct irradiance (both premultiplied by the voxel's
// opacity on filtered levels), and the direction that radiance leaves in (the voxel's
// facing, `voxel/facing.wgsl`). Output per voxel slot, same layout as `clip_voxels`: three
// words, RGBA16F (radiance, opacity) and the facing as snorm8 x 3.

import octolux::voxel::clipmap::sample::{clip_info, clip_slot_centre, clip_voxels};
import octolux::voxel::clipmap::emission::emission_decode;

// `InjectParams` in clipmap/inject.rs.
struct InjectParams {
    lights: u32,
    // Most march steps per shadow ray (voxel rays only).
    max_steps: u32,
    // Voxel slots (levels * res^3).
    slots: u32,
    // 1 when `bounce` holds indirect irradiance to add (multiple bounces).
    bounce: u32,
}

// Storage, not uniform: see "Parameter blocks" in voxel/mod.rs. The clipmap's parameter
// block and voxels are the sampler's bindings (`clip_info`, `clip_voxels`).
@group(0) @binding(2) var<storage, read> normals: array<u32>;
@group(0) @binding(4) var<storage, read_write> radiance: array<u32>;
@group(0) @binding(5) var<storage, read> params: InjectParams;
// Mean emission per voxel slot (RGB9E5).
@group(0) @binding(6) var<storage, read> emission: array<u32>;
// Multiple bounces: indirect irradiance per voxel slot (RGBA16F, 2 words) that the voxels
// gathered last frame (`gi/vct/clipmap_bounce.wgsl`); a placeholder when params.bounce is 0.
@group(0) @binding(10) var<storage, read> bounce: array<u32>;

const INJECT_PI: f32 = 3.14159265358979;

// One voxel slot to light: its premultiplied albedo and opacity, world centre, unit normal
// (zero where opposite faces cancelled: lit as facing the light) and voxel size.
struct InjectVoxel {
    value: vec4<f32>,
    p: vec3<f32>,
    n: vec3<f32>,
    has_normal: bool,
    size: f32,
}

// Slot `i` of the clipmap's voxels; None (value.a == 0) for an empty one, whose radiance is
// written here.
fn inject_voxel(i: u32) -> InjectVoxel {
    var v: InjectVoxel;
    v.value = unpack4x8unorm(clip_voxels[i]);
    if v.value.a == 0.0 {
        radiance[3u * i] = 0u;
        radiance[3u * i + 1u] = 0u;
        radiance[3u * i + 2u] = 0u;
        return v;
    }
    let centre = clip_slot_centre(i);
    v.size = centre.w;
    v.p = centre.xyz;
    v.n = unpack4x8snorm(normals[i]).xyz;
    v.has_normal = dot(v.n, v.n) > 0.01;
    if v.has_normal {
        v.n = normalize(v.n);
    } else {
        v.n = vec3<f32>(0.0);
    }
    return v;
}

// What the lights give a voxel: direct irradiance, and for a voxel without a dominant normal
// the directions to the lights, each weighted by the light the voxel reflects from it.
struct InjectLit {
    e: vec3<f32>,
    toward: vec3<f32>,
}

// Adds irradiance `e` arriving from direction `to_light` to `lit`.
fn inject_add(lit: ptr<function, InjectLit>, v: InjectVoxel, e: vec3<f32>, to_light: vec3<f32>) {
    (*lit).e += e;
    (*lit).toward += to_light * dot(v.value.rgb, e);
}

// Writes slot i's radiance from its albedo/opacity and direct light, plus (multiple bounces)
// the indirect irradiance the slot gathered last frame, and its facing: the voxel's normal,
// or for a voxel without one (lit as facing each light) the mean of the directions to the
// lights weighted by the light it reflects from each (its emission and bounce light have no
// direction: they shorten the mean). CPU twins: `injected_radiance`, `injected_facing`.
fn inject_store(i: u32, v: InjectVoxel, lit: InjectLit) {
    var irradiance = lit.e;
    if params.bounce != 0u {
        irradiance += vec3<f32>(unpack2x16float(bounce[2u * i]),
                                unpack2x16float(bounce[2u * i + 1u]).x);
    }
    let out = emission_decode(emission[i]) + v.value.rgb / INJECT_PI * irradiance;
    var facing = v.n;
    if !v.has_normal {
        facing = lit.toward / (INJECT_PI * max(out.r + out.g + out.b, 1e-20));
    }
    radiance[3u * i] = pack2x16float(out.rg);
    radiance[3u * i + 1u] = pack2x16float(vec2<f32>(out.b, v.value.a));
    radiance[3u * i + 2u] = pack4x8snorm(vec4<f32>(facing, 0.0));
}

fn inject_slot(wg: vec3<u32>, nwg: vec3<u32>, li: u32) -> u32 {
    return (wg.y * nwg.x + wg.x) * 64u + li;
}
