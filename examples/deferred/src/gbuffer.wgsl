// The example's G-buffer: albedo (Rgba8Unorm), the world normal octahedral-packed in Rg16Float
// and reversed-Z depth (1 near, 0 at infinity): a layout of its own, not octolux's.

struct Camera {
    view_proj: mat4x4<f32>,
};

struct Model {
    model: mat4x4<f32>,
    // Inverse transpose of `model` (normals).
    normal_matrix: mat4x4<f32>,
    color: vec4<f32>,
};

@group(0) @binding(0) var<uniform> camera: Camera;
@group(1) @binding(0) var<uniform> object: Model;

struct VsOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) normal: vec3<f32>,
};

@vertex
fn vs(@location(0) position: vec3<f32>, @location(1) normal: vec3<f32>) -> VsOut {
    var out: VsOut;
    out.clip = camera.view_proj * object.model * vec4<f32>(position, 1.0);
    out.normal = (object.normal_matrix * vec4<f32>(normal, 0.0)).xyz;
    return out;
}

fn octahedral_encode(n: vec3<f32>) -> vec2<f32> {
    let p = n.xy / (abs(n.x) + abs(n.y) + abs(n.z));
    if n.z >= 0.0 {
        return p;
    }
    return (1.0 - abs(p.yx)) * select(vec2<f32>(-1.0), vec2<f32>(1.0), p >= vec2<f32>(0.0));
}

struct GBuffer {
    @location(0) albedo: vec4<f32>,
    @location(1) normal: vec2<f32>,
};

@fragment
fn fs(in: VsOut, @builtin(front_facing) front: bool) -> GBuffer {
    var n = normalize(in.normal);
    if !front {
        n = -n;
    }
    var out: GBuffer;
    out.albedo = vec4<f32>(object.color.rgb, 1.0);
    out.normal = octahedral_encode(n);
    return out;
}
