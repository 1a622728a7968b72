// Shared by the full-screen compute passes (direct light, compose, GI gathers).

const PI: f32 = 3.14159265358979;

// `CameraUniform` in frame/mod.rs.
struct Camera {
    view_proj: mat4x4<f32>,
    inv_view_proj: mat4x4<f32>,
    // Eye position.
    position: vec3<f32>,
    // Pixels: width, height, and their inverses.
    size: vec2<f32>,
    inv_size: vec2<f32>,
    // Exposure scale 2^ev (octolux's own compose).
    exposure: f32,
    // Lights in frame/lights.wgsl's `lights`.
    light_count: u32,
    // Scene time, s.
    time: f32,
    // What compose.wgsl shows (render::Output).
    output: u32,
};

// World position of pixel `px` with depth-buffer value `depth` (wgpu depth 0..1).
fn world_from_depth(cam: Camera, px: vec2<u32>, depth: f32) -> vec3<f32> {
    let uv = (vec2<f32>(px) + 0.5) * cam.inv_size;
    let ndc = vec4<f32>(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0, depth, 1.0);
    let w = cam.inv_view_proj * ndc;
    return w.xyz / w.w;
}
