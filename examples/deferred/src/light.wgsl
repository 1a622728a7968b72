// The example's lighting and tone map: one unshadowed point light (Lambert) plus octolux's
// indirect irradiance E as albedo / pi * E, then exposure and Reinhard; the target's sRGB
// format encodes. One full-screen triangle.

const PI: f32 = 3.14159265358979;

struct Frame {
    inv_view_proj: mat4x4<f32>,
    // xyz position
    lamp_position: vec4<f32>,
    // rgb W/sr
    lamp_intensity: vec4<f32>,
    // width, height, exposure scale, indirect on (0/1)
    params: vec4<f32>,
};

@group(0) @binding(0) var<uniform> frame: Frame;
@group(0) @binding(1) var albedo_tex: texture_2d<f32>;
@group(0) @binding(2) var normal_tex: texture_2d<f32>;
@group(0) @binding(3) var depth_tex: texture_depth_2d;
@group(0) @binding(4) var indirect_tex: texture_2d<f32>;

@vertex
fn vs(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(uv * 2.0 - 1.0, 0.0, 1.0);
}

fn octahedral_decode(e: vec2<f32>) -> vec3<f32> {
    var n = vec3<f32>(e.x, e.y, 1.0 - abs(e.x) - abs(e.y));
    let t = max(-n.z, 0.0);
    n.x += select(t, -t, n.x >= 0.0);
    n.y += select(t, -t, n.y >= 0.0);
    return normalize(n);
}

@fragment
fn fs(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let px = vec2<u32>(position.xy);
    let depth = textureLoad(depth_tex, px, 0);
    if depth <= 0.0 {
        return vec4<f32>(0.02, 0.02, 0.025, 1.0);
    }
    let uv = position.xy / frame.params.xy;
    let ndc = vec4<f32>(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0, depth, 1.0);
    let w = frame.inv_view_proj * ndc;
    let world = w.xyz / w.w;
    let n = octahedral_decode(textureLoad(normal_tex, px, 0).xy);
    let to_lamp = frame.lamp_position.xyz - world;
    let d2 = max(dot(to_lamp, to_lamp), 1e-4);
    let direct = frame.lamp_intensity.rgb * max(dot(n, to_lamp * inverseSqrt(d2)), 0.0) / d2;
    let indirect = textureLoad(indirect_tex, px, 0).rgb * frame.params.w;
    let albedo = textureLoad(albedo_tex, px, 0).rgb;
    let radiance = albedo / PI * (direct + indirect) * frame.params.z;
    return vec4<f32>(radiance / (1.0 + radiance), 1.0);
}
