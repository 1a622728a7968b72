// G-buffer and shadow-map fragment shaders over `raster.wgsl`'s vertex shader: the G-buffer
// writes albedo, normal and emission, the shadow pass only runs the alpha test of masked
// materials.

import octolux::frame::raster::{VertexOut, masked_base_color, material, view};

struct GBufferOut {
    @location(0) albedo: vec4<f32>,
    @location(1) normal: vec4<f32>,
    @location(2) emission: vec4<f32>,
};

@fragment
fn fs_gbuffer(in: VertexOut) -> GBufferOut {
    let color = masked_base_color(in.uv);
    // Surfaces reflect on both sides: the shading normal faces the viewer. They emit from the
    // front face (the side the vertex normals point to) unless marked two-sided.
    var n = normalize(in.normal);
    let front = dot(n, view.position.xyz - in.world) > 0.0;
    if !front {
        n = -n;
    }
    var out: GBufferOut;
    out.albedo = vec4<f32>(color.rgb, 1.0);
    out.normal = vec4<f32>(n, 1.0);
    let emits = front || material.two_sided_emission == 1u;
    out.emission = vec4<f32>(select(vec3<f32>(0.0), material.emission, emits), 1.0);
    return out;
}

@fragment
fn fs_shadow(in: VertexOut) {
    _ = masked_base_color(in.uv);
}
