// Reflective shadow maps: rasterise the scene from a light (the shadow layer's matrix) and
// store, per texel, the world position, the normal facing the light and what the injection
// needs to turn the texel into a VPL with physical flux (over `frame/raster.wgsl`'s vertex
// shader):
//   perspective (spot, point face): measure m = solid angle of the texel
//     = (2 tan(half fov) / N)^2 cos^3(angle to the axis); incident flux = I(w) m
//   orthographic (directional): m = texel area across the beam; incident flux = E m
// reflected flux = albedo x incident flux (Lambertian: everything not absorbed leaves).
// Surfel area = m r^2 / cos (perspective) or m / cos (orthographic).

import octolux::frame::raster::{VertexOut, masked_base_color};

// `RsmLayer` in frame/rsm.rs: one layer's light and view.
struct RsmLayer {
    // Light position (point and spot lights).
    position: vec3<f32>,
    // 0 point, 1 spot, 2 directional (frame/lights.rs, `LIGHT_POINT` ...).
    kind: u32,
    // Unit axis of the layer (spot axis, cube face, sun direction of travel).
    axis: vec3<f32>,
    // Perspective layers: tan(half fov).
    tan_half_fov: f32,
    // Radiant intensity (W/sr) or irradiance (W/m^2).
    radiant: vec3<f32>,
    // Cube face of a point light's layer, -1 for other lights.
    face: i32,
    cos_inner: f32,
    cos_outer: f32,
    // RSM side in texels.
    side: u32,
    // The shadow view the layer is drawn through.
    view: u32,
    // Orthographic layers: a texel's area across the beam (m^2).
    texel_area: f32,
};
@group(3) @binding(0) var<uniform> layer: RsmLayer;

struct RsmOut {
    @location(0) position: vec4<f32>,
    @location(1) normal: vec4<f32>,
    @location(2) flux: vec4<f32>,
};

fn face_of(d: vec3<f32>) -> i32 {
    let a = abs(d);
    if a.x >= a.y && a.x >= a.z {
        return select(1, 0, d.x > 0.0);
    }
    if a.y >= a.z {
        return select(3, 2, d.y > 0.0);
    }
    return select(5, 4, d.z > 0.0);
}

// Written without branches on the layer uniform: Mesa's lavapipe specialises (and recompiles,
// keeping every variant) a shader per value of a uniform that decides a branch, so a branch on
// the layer kind cost a compile and ~100 KB per draw there.
@fragment
fn fs_rsm(in: VertexOut) -> RsmOut {
    let color = masked_base_color(in.uv);
    let axis = layer.axis;
    let perspective = layer.kind != 2u;
    let spot = layer.kind == 1u;
    let d = in.world - layer.position;
    let r2 = max(dot(d, d), 1e-12);
    let w = d * inverseSqrt(r2);
    let to_light = select(-axis, -w, perspective);
    // Perspective layers: solid angle of the texel; orthographic: its area across the beam.
    let cos_axis = max(dot(w, axis), 1e-4);
    let texel = 2.0 * layer.tan_half_fov / f32(layer.side);
    let measure = select(layer.texel_area, texel * texel * cos_axis * cos_axis * cos_axis, perspective);
    let x = clamp((dot(w, axis) - layer.cos_outer) / max(layer.cos_inner - layer.cos_outer, 1e-6), 0.0, 1.0);
    let radiant = layer.radiant * select(1.0, x * x * (3.0 - 2.0 * x), spot);
    // Cube faces overlap slightly (widened shadow frusta): each direction belongs to
    // exactly one face, so no flux is counted twice.
    let other_face = perspective & (layer.face >= 0) & (face_of(w) != layer.face);
    var n = normalize(in.normal);
    if dot(n, to_light) < 0.0 {
        n = -n;
    }
    let ratio = select(1.0, r2, perspective) / max(dot(n, to_light), 0.05);
    var out: RsmOut;
    out.position = select(vec4<f32>(in.world, measure), vec4<f32>(0.0), other_face);
    out.normal = select(vec4<f32>(n, ratio), vec4<f32>(0.0), other_face);
    out.flux = select(vec4<f32>(color.rgb * radiant, 0.0), vec4<f32>(0.0), other_face);
    return out;
}

// The clear of a layer drawn at less than the targets' side. A load-op clear covers the whole
// layer, four times the texels of a half-side layer, and on a GPU whose rasteriser is its
// narrow part (an H200) the clear cost as much as the drawing: so such a layer keeps its
// contents and this triangle, over the viewport only, writes what the clear would (zero in
// every target, depth 1) before the scene is drawn.
@vertex
fn vs_clear(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let corner = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(corner * 2.0 - 1.0, 1.0, 1.0);
}

@fragment
fn fs_clear() -> RsmOut {
    return RsmOut(vec4<f32>(0.0), vec4<f32>(0.0), vec4<f32>(0.0));
}
