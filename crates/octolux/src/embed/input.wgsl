// The G-buffer input pass (`embed/input.rs`): reads a caller's depth and normal in the
// conventions it declares and writes them in octolux's (`frame::GiSurfaces`): depth for
// octolux's standard-depth projection of the caller's camera, 1 where nothing was drawn, and the
// world-space unit normal facing the viewer. One full-screen triangle.

struct InputParams {
    // The caller's inverse projection: caller NDC -> view space.
    inv_proj: mat4x4<f32>,
    // Octolux's projection of the same camera (standard depth: 0 near, 1 far).
    proj: mat4x4<f32>,
    // View space -> world.
    inv_view: mat4x4<f32>,
    // width, height, reversed depth (0/1), view-space normals (0/1)
    size: vec4<f32>,
    // normal packing: 0 xyz, 1 xyz unorm, 2 octahedral, 3 octahedral unorm
    packing: vec4<u32>,
};

@group(0) @binding(0) var<uniform> params: InputParams;
@if(float_depth) @group(0) @binding(1) var depth_tex: texture_2d<f32>;
@if(!float_depth) @group(0) @binding(1) var depth_tex: texture_depth_2d;
@group(0) @binding(2) var normal_tex: texture_2d<f32>;

struct VsOut {
    @builtin(position) position: vec4<f32>,
};

@vertex
fn vs(@builtin(vertex_index) i: u32) -> VsOut {
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    var out: VsOut;
    out.position = vec4<f32>(uv * 2.0 - 1.0, 0.0, 1.0);
    return out;
}

@if(float_depth) fn caller_depth(px: vec2<u32>) -> f32 {
    return textureLoad(depth_tex, px, 0).r;
}
@if(!float_depth) fn caller_depth(px: vec2<u32>) -> f32 {
    return textureLoad(depth_tex, px, 0);
}

// Octahedral decoding of a unit vector from [-1, 1]^2.
fn octahedral_decode(e: vec2<f32>) -> vec3<f32> {
    var n = vec3<f32>(e.x, e.y, 1.0 - abs(e.x) - abs(e.y));
    let t = max(-n.z, 0.0);
    n.x += select(t, -t, n.x >= 0.0);
    n.y += select(t, -t, n.y >= 0.0);
    return normalize(n);
}

fn decode_normal(texel: vec4<f32>) -> vec3<f32> {
    switch params.packing.x {
        case 1u: { return texel.xyz * 2.0 - 1.0; }
        case 2u: { return octahedral_decode(texel.xy); }
        case 3u: { return octahedral_decode(texel.xy * 2.0 - 1.0); }
        default: { return texel.xyz; }
    }
}

struct FsOut {
    @location(0) normal: vec4<f32>,
    @builtin(frag_depth) depth: f32,
};

@fragment
fn fs(in: VsOut) -> FsOut {
    let px = vec2<u32>(in.position.xy);
    let d = caller_depth(px);
    var out: FsOut;
    out.depth = 1.0;
    out.normal = vec4<f32>(0.0);
    let reversed = params.size.z > 0.5;
    // Nothing drawn: the far value of the caller's convention (or beyond it).
    if (reversed && d <= 0.0) || (!reversed && d >= 1.0) {
        return out;
    }
    let uv = in.position.xy / params.size.xy;
    let ndc = vec4<f32>(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0, d, 1.0);
    let v = params.inv_proj * ndc;
    let view_pos = v.xyz / v.w;
    let clip = params.proj * vec4<f32>(view_pos, 1.0);
    // Below 1: a surface beyond octolux's far plane stays a surface.
    out.depth = clamp(clip.z / clip.w, 0.0, 0.99999994);
    var n = decode_normal(textureLoad(normal_tex, px, 0));
    if params.size.w > 0.5 {
        n = (params.inv_view * vec4<f32>(n, 0.0)).xyz;
    }
    n = normalize(n);
    // Facing the viewer, as octolux's own G-buffer (surfaces reflect on both sides).
    let eye = params.inv_view[3].xyz;
    let world = (params.inv_view * vec4<f32>(view_pos, 1.0)).xyz;
    if dot(n, eye - world) < 0.0 {
        n = -n;
    }
    out.normal = vec4<f32>(n, 1.0);
    return out;
}
