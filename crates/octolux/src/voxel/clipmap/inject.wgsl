// Light injection into the clipmap: every occupied voxel gets outgoing radiance
// emission + albedo / pi x direct irradiance from point, spot and directional lights (both
// premultiplied by the voxel's opacity on filtered levels), with visibility
// from marching the clipmap's own opacity towards the light (voxel shadow rays, no shadow
// maps). Output: RGBA16F (radiance, opacity) per voxel slot, same layout as `clip_voxels`.
// Needs `clipmap/emission.wgsl` before this file.

struct InjectLight {
    // xyz position, w: kind (0 point, 1 spot, 2 directional)
    position_kind: vec4<f32>,
    // xyz unit direction of travel, w: cos(inner half-angle)
    direction_cos_inner: vec4<f32>,
    // rgb radiant intensity (W/sr) or irradiance (W/m^2), w: cos(outer half-angle)
    radiant_cos_outer: vec4<f32>,
}

// x: lights, y: most march steps per shadow ray, z: voxel slots (levels * res^3).
struct InjectParams {
    misc: vec4<u32>,
}

// Storage, not uniform: see "Parameter blocks" in voxel/mod.rs.
@group(0) @binding(0) var<storage, read> clip_info: ClipInfo;
@group(0) @binding(1) var<storage, read> clip_voxels: array<u32>;
@group(0) @binding(2) var<storage, read> normals: array<u32>;
@group(0) @binding(3) var<storage, read> lights: array<InjectLight>;
@group(0) @binding(4) var<storage, read_write> radiance: array<u32>;
@group(0) @binding(5) var<storage, read> params: InjectParams;
// Mean emission per voxel slot (RGB9E5).
@group(0) @binding(6) var<storage, read> emission: array<u32>;

const PI: f32 = 3.14159265358979;

fn spot_falloff(cos_angle: f32, cos_inner: f32, cos_outer: f32) -> f32 {
    let x = clamp((cos_angle - cos_outer) / max(cos_inner - cos_outer, 1e-6), 0.0, 1.0);
    return x * x * (3.0 - 2.0 * x);
}

// Fraction of light passing from p along dir over dist, composited front to back from
// samples of footprint `voxel` half a voxel apart (a whole-voxel step lets about a quarter of
// the light through a one-voxel-thick occluder, as trilinear weights split between samples).
fn transmittance(p: vec3<f32>, dir: vec3<f32>, dist: f32, voxel: f32) -> f32 {
    var alpha = 0.0;
    var t = 0.0;
    for (var i = 0u; i < params.misc.y && t < dist && alpha < 0.99; i++) {
        alpha += (1.0 - alpha) * clip_sample(p + t * dir, voxel).a;
        t += 0.5 * voxel;
    }
    return 1.0 - alpha;
}

@compute @workgroup_size(64)
fn inject(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
          @builtin(local_invocation_index) li: u32) {
    let i = (wg.y * nwg.x + wg.x) * 64u + li;
    if i >= params.misc.z {
        return;
    }
    let value = unpack4x8unorm(clip_voxels[i]);
    if value.a == 0.0 {
        radiance[2u * i] = 0u;
        radiance[2u * i + 1u] = 0u;
        return;
    }
    let r = clip_info.misc.x;
    let l = i / (r * r * r);
    let s = i % (r * r * r);
    let m = vec3<i32>(vec3<u32>(s % r, (s / r) % r, s / (r * r)));
    let o = clip_info.origins[l].xyz;
    let ri = i32(r);
    let g = o + ((m - o) % ri + ri) % ri;
    let v = clip_info.voxel.x * f32(1u << l);
    let p = (vec3<f32>(g) + 0.5) * v;
    var n = unpack4x8snorm(normals[i]).xyz;
    let has_normal = dot(n, n) > 0.01;
    if has_normal {
        n = normalize(n);
    }
    var e = vec3<f32>(0.0);
    for (var k = 0u; k < params.misc.x; k++) {
        let light = lights[k];
        let kind = light.position_kind.w;
        var to_light: vec3<f32>;
        var el: vec3<f32>;
        var dist = 1.0e4;
        if kind > 1.5 {
            to_light = -light.direction_cos_inner.xyz;
            el = light.radiant_cos_outer.rgb;
        } else {
            let d = light.position_kind.xyz - p;
            let r2 = max(dot(d, d), 1e-8);
            dist = sqrt(r2);
            to_light = d / dist;
            el = light.radiant_cos_outer.rgb / r2;
            if kind > 0.5 {
                el *= spot_falloff(dot(light.direction_cos_inner.xyz, -to_light),
                                   light.direction_cos_inner.w, light.radiant_cos_outer.w);
            }
        }
        var cos_theta = 1.0;
        if has_normal {
            cos_theta = dot(n, to_light);
        }
        if cos_theta <= 0.0 || all(el <= vec3<f32>(0.0)) {
            continue;
        }
        // Leave the voxel's own footprint: two voxels along the normal before marching.
        var start = p + to_light * v;
        if has_normal {
            start += n * 2.0 * v;
        }
        let vis = transmittance(start, to_light, dist - 3.0 * v, v);
        e += el * cos_theta * vis;
    }
    let out = emission_decode(emission[i]) + value.rgb / PI * e;
    radiance[2u * i] = pack2x16float(out.rg);
    radiance[2u * i + 1u] = pack2x16float(vec2<f32>(out.b, value.a));
}
