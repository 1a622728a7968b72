// Deferred direct lighting: Lambertian (albedo/pi) response to point, spot and directional
// lights with PCF-filtered shadow maps, plus emission. Output: outgoing radiance per pixel.

// `Light`, `light_incidence` and `shadow_visibility` come from `lights.wgsl`.

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
        let inc = light_incidence(light, p);
        let cos_theta = dot(n, inc.to_light);
        if cos_theta <= 0.0 || all(inc.irradiance <= vec3<f32>(0.0)) {
            continue;
        }
        irradiance += inc.irradiance * cos_theta * shadow_visibility(light, p, n, inc.to_light, inc.dist, 0.0);
    }
    let emission = textureLoad(emission_tex, px, 0).rgb;
    textureStore(out_direct, px, vec4<f32>(emission + albedo / PI * irradiance, 1.0));
}
