// Deferred direct lighting: Lambertian (albedo/pi) response to point, spot and directional
// lights with PCF-filtered shadow maps, plus emission. Output: outgoing radiance per pixel.

struct Light {
    // xyz position, w: kind (0 point, 1 spot, 2 directional)
    position_kind: vec4<f32>,
    // xyz unit direction of travel, w: cos(inner cone half-angle)
    direction_cos_inner: vec4<f32>,
    // rgb radiant intensity (W/sr) or irradiance (W/m^2), w: cos(outer half-angle)
    radiant_cos_outer: vec4<f32>,
    // x: first shadow layer (negative = no shadow), y: world size of a shadow texel per metre
    // of distance (perspective) or absolute (orthographic), z: 1 if orthographic, w unused
    shadow: vec4<f32>,
};

@group(0) @binding(0) var<uniform> cam: Camera;
@group(0) @binding(1) var albedo_tex: texture_2d<f32>;
@group(0) @binding(2) var normal_tex: texture_2d<f32>;
@group(0) @binding(3) var emission_tex: texture_2d<f32>;
@group(0) @binding(4) var depth_tex: texture_depth_2d;
@group(0) @binding(5) var<storage, read> lights: array<Light>;
@group(0) @binding(6) var<storage, read> shadow_matrices: array<mat4x4<f32>>;
@group(0) @binding(7) var shadow_maps: texture_depth_2d_array;
@group(0) @binding(8) var shadow_sampler: sampler_comparison;
@group(0) @binding(9) var out_direct: texture_storage_2d<rgba16float, write>;

// Cube face of direction `d` in the order +x, -x, +y, -y, +z, -z.
fn cube_face(d: vec3<f32>) -> u32 {
    let a = abs(d);
    if a.x >= a.y && a.x >= a.z {
        return select(1u, 0u, d.x > 0.0);
    }
    if a.y >= a.z {
        return select(3u, 2u, d.y > 0.0);
    }
    return select(5u, 4u, d.z > 0.0);
}

fn spot_attenuation(cos_angle: f32, cos_inner: f32, cos_outer: f32) -> f32 {
    let x = clamp((cos_angle - cos_outer) / max(cos_inner - cos_outer, 1e-6), 0.0, 1.0);
    return x * x * (3.0 - 2.0 * x);
}

// Fraction of the light reaching `p`: 3x3 bilinear comparison taps (a 4x4-texel footprint).
fn visibility(light: Light, p: vec3<f32>, n: vec3<f32>, to_light: vec3<f32>, dist: f32) -> f32 {
    if light.shadow.x < 0.0 {
        return 1.0;
    }
    var layer = u32(light.shadow.x);
    if light.position_kind.w < 0.5 {
        layer += cube_face(p - light.position_kind.xyz);
    }
    // Normal offset of ~1.5 shadow texels removes acne without the light leaking of large
    // constant biases.
    let texel_world = select(light.shadow.y * dist, light.shadow.y, light.shadow.z > 0.5);
    let cos_l = clamp(dot(n, to_light), 0.0, 1.0);
    let offset_p = p + n * texel_world * 1.5 * (1.0 - 0.5 * cos_l) + to_light * texel_world * 0.5;
    let clip = shadow_matrices[layer] * vec4<f32>(offset_p, 1.0);
    let ndc = clip.xyz / clip.w;
    let uv = vec2<f32>(ndc.x * 0.5 + 0.5, 0.5 - ndc.y * 0.5);
    if any(uv < vec2<f32>(0.0)) || any(uv > vec2<f32>(1.0)) || ndc.z > 1.0 {
        return 1.0;
    }
    let texel = 1.0 / vec2<f32>(textureDimensions(shadow_maps));
    var sum = 0.0;
    for (var y = -1; y <= 1; y++) {
        for (var x = -1; x <= 1; x++) {
            sum += textureSampleCompareLevel(shadow_maps, shadow_sampler, uv + vec2<f32>(f32(x), f32(y)) * texel, layer, ndc.z);
        }
    }
    return sum / 9.0;
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
        textureStore(out_direct, px, vec4<f32>(0.0, 0.0, 0.0, 1.0));
        return;
    }
    let p = world_from_depth(cam, px, depth);
    let n = normalize(textureLoad(normal_tex, px, 0).xyz);
    let albedo = textureLoad(albedo_tex, px, 0).rgb;
    var irradiance = vec3<f32>(0.0);
    let count = u32(cam.params.y);
    for (var i = 0u; i < count; i++) {
        let light = lights[i];
        let kind = light.position_kind.w;
        var to_light: vec3<f32>;
        var e: vec3<f32>;
        var dist = 1.0;
        if kind > 1.5 {
            to_light = -light.direction_cos_inner.xyz;
            e = light.radiant_cos_outer.rgb;
        } else {
            let d = light.position_kind.xyz - p;
            let r2 = max(dot(d, d), 1e-8);
            dist = sqrt(r2);
            to_light = d / dist;
            e = light.radiant_cos_outer.rgb / r2;
            if kind > 0.5 {
                e *= spot_attenuation(dot(light.direction_cos_inner.xyz, -to_light), light.direction_cos_inner.w, light.radiant_cos_outer.w);
            }
        }
        let cos_theta = dot(n, to_light);
        if cos_theta <= 0.0 || all(e <= vec3<f32>(0.0)) {
            continue;
        }
        irradiance += e * cos_theta * visibility(light, p, n, to_light, dist);
    }
    let emission = textureLoad(emission_tex, px, 0).rgb;
    textureStore(out_direct, px, vec4<f32>(emission + albedo / PI * irradiance, 1.0));
}
