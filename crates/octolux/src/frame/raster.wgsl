// Scene rasterisation shared by every pass that draws the meshes (G-buffer, shadow maps,
// reflective shadow maps): the bind groups of `SceneGpu` (0 view, 1 material, 2 object), the
// vertex shader `vs` and the material's base colour. The passes' fragment shaders import it.

struct View {
    view_proj: mat4x4<f32>,
    position: vec4<f32>,
};
@group(0) @binding(0) var<uniform> view: View;

// `MaterialUniform` in frame/scene_gpu.rs.
struct Material {
    // Linear albedo factor.
    base_color: vec3<f32>,
    // Alpha cutoff of a masked material; negative: opaque.
    alpha_cutoff: f32,
    // Emitted radiance, W/(m^2 sr).
    emission: vec3<f32>,
    // 1 if the base colour texture is used.
    textured: u32,
    // Multiplies the texture's alpha.
    opacity: f32,
    // 1 if the back face emits too.
    two_sided_emission: u32,
};
@group(1) @binding(0) var<uniform> material: Material;
@group(1) @binding(1) var base_texture: texture_2d<f32>;
@group(1) @binding(2) var base_sampler: sampler;

struct Object {
    model: mat4x4<f32>,
    normal_matrix: mat4x4<f32>,
};
@group(2) @binding(0) var<uniform> object: Object;

struct VertexOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
};

@vertex
fn vs(@location(0) position: vec3<f32>, @location(1) normal: vec3<f32>, @location(2) uv: vec2<f32>) -> VertexOut {
    var out: VertexOut;
    let world = object.model * vec4<f32>(position, 1.0);
    out.world = world.xyz;
    out.clip = view.view_proj * world;
    out.normal = (object.normal_matrix * vec4<f32>(normal, 0.0)).xyz;
    out.uv = uv;
    return out;
}

fn base_color(uv: vec2<f32>) -> vec4<f32> {
    let texel = textureSample(base_texture, base_sampler, uv);
    let factor = vec4<f32>(material.base_color, material.opacity);
    return select(factor, factor * texel, material.textured == 1u);
}

// The base colour at `uv`, with the alpha test of masked materials (fragment shaders only).
fn masked_base_color(uv: vec2<f32>) -> vec4<f32> {
    let color = base_color(uv);
    if material.alpha_cutoff >= 0.0 && color.a < material.alpha_cutoff {
        discard;
    }
    return color;
}
