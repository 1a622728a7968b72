// Shared by the full-screen compute passes (direct light, compose, GI gathers).

const PI: f32 = 3.14159265358979;

struct Camera {
    view_proj: mat4x4<f32>,
    inv_view_proj: mat4x4<f32>,
    // xyz eye position, w unused
    position: vec4<f32>,
    // width, height, 1/width, 1/height
    size: vec4<f32>,
    // x: exposure scale 2^ev, y: light count, z: time (s), w: output (compose.wgsl)
    params: vec4<f32>,
};

// World position of pixel `px` with depth-buffer value `depth` (wgpu depth 0..1).
fn world_from_depth(cam: Camera, px: vec2<u32>, depth: f32) -> vec3<f32> {
    let uv = (vec2<f32>(px) + 0.5) * cam.size.zw;
    let ndc = vec4<f32>(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0, depth, 1.0);
    let w = cam.inv_view_proj * ndc;
    return w.xyz / w.w;
}
