// Adds octolux's indirect light to Bevy's deferred lighting: radiance += diffuse / pi * E,
// with diffuse = base colour x (1 - metallic) x the material's occlusion as Bevy's deferred
// G-buffer stores them (bevy_pbr deferred/functions.wesl), E the indirect irradiance (W/m^2)
// and params.x = exposure x 683 lm/W / pi (E to nits, then Bevy's exposure).

struct Params {
    scale: vec4<f32>,
}

@group(0) @binding(0) var gbuffer: texture_2d<u32>;
@group(0) @binding(1) var indirect: texture_2d<f32>;
@group(0) @binding(2) var<uniform> params: Params;

@vertex
fn vs(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(uv * 2.0 - 1.0, 0.0, 1.0);
}

// Bevy's unpack_unorm4x8_ (deferred/types.wesl): x in the low byte.
fn unpack_unorm4x8(v: u32) -> vec4<f32> {
    return vec4<f32>(
        f32(v & 0xffu),
        f32((v >> 8u) & 0xffu),
        f32((v >> 16u) & 0xffu),
        f32((v >> 24u) & 0xffu)
    ) / 255.0;
}

@fragment
fn fs(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let p = vec2<i32>(position.xy);
    let g = textureLoad(gbuffer, p, 0);
    // Unlit surfaces and pixels without a deferred surface store a black base colour.
    let base = pow(unpack_unorm4x8(g.r).rgb, vec3<f32>(2.2));
    let props = unpack_unorm4x8(g.b);
    let diffuse = base * (1.0 - props.g) * props.b;
    let e = max(textureLoad(indirect, p, 0).rgb, vec3<f32>(0.0));
    return vec4<f32>(diffuse * e * params.scale.x, 0.0);
}
