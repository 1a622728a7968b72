// Compose: outgoing radiance = direct + albedo/pi x indirect irradiance (or one of its parts,
// see below); then exposure, the filmic curve (same as image_io::filmic) and the sRGB transfer
// function for display.

import octolux::frame::common::{Camera, PI};

@group(0) @binding(0) var<uniform> cam: Camera;
@group(0) @binding(1) var direct_tex: texture_2d<f32>;
@group(0) @binding(2) var albedo_tex: texture_2d<f32>;
@group(0) @binding(3) var indirect_tex: texture_2d<f32>;
@group(0) @binding(4) var out_hdr: texture_storage_2d<rgba32float, write>;
@group(0) @binding(5) var out_ldr: texture_storage_2d<rgba8unorm, write>;
// The technique's specular image, or a 1 x 1 black stand-in.
@group(0) @binding(6) var specular_tex: texture_2d<f32>;

fn filmic(x: vec3<f32>) -> vec3<f32> {
    // At 8 the curve is above 1 already; the bound keeps v * v finite for any radiance.
    let v = min(max(x, vec3<f32>(0.0)), vec3<f32>(8.0));
    return clamp((v * (2.51 * v + 0.03)) / (v * (2.43 * v + 0.59) + 0.14), vec3<f32>(0.0), vec3<f32>(1.0));
}

fn linear_to_srgb(c: vec3<f32>) -> vec3<f32> {
    let lo = 12.92 * c;
    let hi = 1.055 * pow(c, vec3<f32>(1.0 / 2.4)) - 0.055;
    return select(hi, lo, c <= vec3<f32>(0.0031308));
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = vec2<u32>(cam.size.xy);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let px = id.xy;
    let direct = textureLoad(direct_tex, px, 0).rgb;
    let albedo = textureLoad(albedo_tex, px, 0).rgb;
    let indirect = textureLoad(indirect_tex, px, 0);
    // cam.output picks what is shown (render::Output): 0 the frame, 1 direct light only,
    // 2 the indirect irradiance as the radiance a white Lambertian surface would reflect,
    // 3 the ambient occlusion in the indirect image's alpha (shown as is, no exposure),
    // 4 the specular image.
    let output = cam.output;
    var radiance = direct + albedo / PI * indirect.rgb;
    if output == 1u {
        radiance = direct;
    } else if output == 2u {
        radiance = indirect.rgb / PI;
    } else if output == 3u {
        let ao = clamp(indirect.a, 0.0, 1.0);
        textureStore(out_hdr, px, vec4<f32>(vec3<f32>(ao), 1.0));
        textureStore(out_ldr, px, vec4<f32>(linear_to_srgb(vec3<f32>(ao)), 1.0));
        return;
    } else if output == 4u {
        radiance = textureLoad(specular_tex, min(px, textureDimensions(specular_tex) - vec2<u32>(1u)), 0).rgb;
    }
    textureStore(out_hdr, px, vec4<f32>(radiance, 1.0));
    textureStore(out_ldr, px, vec4<f32>(linear_to_srgb(filmic(radiance * cam.exposure)), 1.0));
}
