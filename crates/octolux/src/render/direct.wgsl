// Deferred direct lighting: Lambertian (albedo/pi) response to point, spot and directional
// lights with PCF-filtered shadow maps and to the sky, plus emission; the sky's radiance where
// nothing was drawn. Output: outgoing radiance per pixel.
//
// Sky: unshadowed irradiance from the sky's spherical-harmonic irradiance coefficients, times
// the visible fraction of the directional lights that stand in for the sky (`frame/sky.rs`).

import octolux::frame::common::{Camera, PI, world_from_depth};
import octolux::frame::lights::{Light, light_incidence, lights, shadow_visibility_offset, sharp_orthographic_shadow};

@group(0) @binding(0) var<uniform> cam: Camera;
@group(0) @binding(1) var albedo_tex: texture_2d<f32>;
@group(0) @binding(2) var normal_tex: texture_2d<f32>;
@group(0) @binding(3) var emission_tex: texture_2d<f32>;
@group(0) @binding(4) var depth_tex: texture_depth_2d;
@group(0) @binding(9) var out_direct: texture_storage_2d<rgba16float, write>;

// `SkyParams` in frame/sky.rs.
struct SkyParams {
    // Irradiance coefficients (rgb; w unused) of the nine band 0-2 basis functions.
    sh: array<vec4<f32>, 9>,
    // Rows of the world-to-map rotation (xyz; w unused).
    to_map: array<vec4<f32>, 3>,
    // A constant sky's radiance (x intensity).
    constant: vec3<f32>,
    // SKY_NONE, SKY_CONSTANT or SKY_MAP.
    kind: u32,
    // The map's texels per row and rows.
    map_width: u32,
    map_height: u32,
    // Scale of the map's texels.
    intensity: f32,
    _pad: u32,
};

const SKY_NONE: u32 = 0u;
const SKY_CONSTANT: u32 = 1u;
@group(0) @binding(10) var<storage, read> sky: SkyParams;
@group(0) @binding(11) var<storage, read> sky_map: array<vec4<f32>>;

fn sky_texel(x: i32, y: i32) -> vec3<f32> {
    let w = i32(sky.map_width);
    let h = i32(sky.map_height);
    let tx = ((x % w) + w) % w;
    let ty = clamp(y, 0, h - 1);
    return sky_map[ty * w + tx].rgb;
}

// Radiance arriving from world direction `d`: bilinear in the map like `Sky::radiance`.
fn sky_radiance(d: vec3<f32>) -> vec3<f32> {
    if sky.kind == SKY_NONE {
        return vec3<f32>(0.0);
    }
    if sky.kind == SKY_CONSTANT {
        return sky.constant;
    }
    let local = vec3<f32>(dot(sky.to_map[0].xyz, d), dot(sky.to_map[1].xyz, d), dot(sky.to_map[2].xyz, d));
    var u = atan2(local.x, -local.z) / (2.0 * PI);
    u = u - floor(u);
    let v = acos(clamp(local.y, -1.0, 1.0)) / PI;
    let x = u * f32(sky.map_width) - 0.5;
    let y = v * f32(sky.map_height) - 0.5;
    let x0 = floor(x);
    let y0 = floor(y);
    let f = vec2<f32>(x - x0, y - y0);
    let ix = i32(x0);
    let iy = i32(y0);
    let top = mix(sky_texel(ix, iy), sky_texel(ix + 1, iy), f.x);
    let bottom = mix(sky_texel(ix, iy + 1), sky_texel(ix + 1, iy + 1), f.x);
    return mix(top, bottom, f.y) * sky.intensity;
}

// Unshadowed sky irradiance for unit normal `n` (`sh_irradiance` on the CPU).
fn sky_irradiance(n: vec3<f32>) -> vec3<f32> {
    let x = n.x;
    let y = n.y;
    let z = n.z;
    var e = sky.sh[0].rgb * 0.282095;
    e += sky.sh[1].rgb * (0.488603 * y);
    e += sky.sh[2].rgb * (0.488603 * z);
    e += sky.sh[3].rgb * (0.488603 * x);
    e += sky.sh[4].rgb * (1.092548 * x * y);
    e += sky.sh[5].rgb * (1.092548 * y * z);
    e += sky.sh[6].rgb * (0.315392 * (3.0 * z * z - 1.0));
    e += sky.sh[7].rgb * (1.092548 * x * z);
    e += sky.sh[8].rgb * (0.546274 * (x * x - y * y));
    return max(e, vec3<f32>(0.0));
}

// How fast the surface at pixel px (point p, normal n) turns: the largest change of normal per
// metre towards the four neighbouring pixels of the same surface (a neighbour much farther
// along the view than across it lies on another surface and is skipped).
fn curvature(px: vec2<u32>, p: vec3<f32>, n: vec3<f32>, size: vec2<u32>) -> f32 {
    var k = 0.0;
    let steps = array<vec2<i32>, 4>(vec2<i32>(1, 0), vec2<i32>(-1, 0), vec2<i32>(0, 1), vec2<i32>(0, -1));
    for (var i = 0u; i < 4u; i++) {
        let q = vec2<i32>(px) + steps[i];
        if any(q < vec2<i32>(0)) || any(q >= vec2<i32>(size)) {
            continue;
        }
        let d = textureLoad(depth_tex, vec2<u32>(q), 0);
        if d >= 1.0 {
            continue;
        }
        let pq = world_from_depth(cam, vec2<u32>(q), d);
        let along = pq - p;
        let len = length(along);
        if len <= 0.0 || abs(dot(along, n)) > 0.5 * len {
            continue;
        }
        let nq = normalize(textureLoad(normal_tex, vec2<u32>(q), 0).xyz);
        k = max(k, length(nq - n) / len);
    }
    return k;
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = vec2<u32>(cam.size.xy);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let px = id.xy;
    let depth = textureLoad(depth_tex, px, 0);
    if depth >= 1.0 {
        let far = world_from_depth(cam, px, 1.0);
        let background = sky_radiance(normalize(far - cam.position.xyz));
        textureStore(out_direct, px, vec4<f32>(background, 1.0));
        return;
    }
    let p = world_from_depth(cam, px, depth);
    let n = normalize(textureLoad(normal_tex, px, 0).xyz);
    let albedo = textureLoad(albedo_tex, px, 0).rgb;
    var irradiance = vec3<f32>(0.0);
    // The sky's directional lights, unshadowed and shadowed.
    var sky_all = vec3<f32>(0.0);
    var sky_seen = vec3<f32>(0.0);
    let count = cam.light_count;
    // The surface's curvature, read once and only for a light that uses it.
    var bend = -1.0;
    for (var i = 0u; i < count; i++) {
        let light = lights[i];
        let inc = light_incidence(light, p);
        let cos_theta = dot(n, inc.to_light);
        if cos_theta <= 0.0 || all(inc.irradiance <= vec3<f32>(0.0)) {
            continue;
        }
        let e = inc.irradiance * cos_theta;
        // The filter reaches about 2 texels t; a surface turning at bend per metre leaves its
        // tangent plane by about 2 bend t^2 there: an offset of 4 bend t texels covers it twice.
        var offset = 1.5;
        if sharp_orthographic_shadow(light) {
            if bend < 0.0 {
                bend = curvature(px, p, n, size);
            }
            offset = clamp(0.25 + 4.0 * bend * light.shadow_texel, 0.25, 1.5);
        }
        let seen = e * shadow_visibility_offset(light, p, n, inc.to_light, inc.dist, 0.0, offset);
        if light.sky_layer_plus_one > 0u {
            sky_all += e;
            sky_seen += seen;
        } else {
            irradiance += seen;
        }
    }
    let visible = select(vec3<f32>(0.0), sky_seen / max(sky_all, vec3<f32>(1e-30)), sky_all > vec3<f32>(0.0));
    irradiance += sky_irradiance(n) * visible;
    let emission = textureLoad(emission_tex, px, 0).rgb;
    textureStore(out_direct, px, vec4<f32>(emission + albedo / PI * irradiance, 1.0));
}
