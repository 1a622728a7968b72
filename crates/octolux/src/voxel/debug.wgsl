// Probing and ray-marched display of a voxel structure through `sample_structure(p, footprint)`
// (defined by the header for the octree or the clipmap).

// `ViewBlock` in debug.rs.
struct View {
    inv_view_proj: mat4x4<f32>,
    // The camera's position.
    eye: vec3<f32>,
    // The samples' footprint (m).
    footprint: f32,
    // The box the rays march through.
    lo: vec3<f32>,
    // The step length (m).
    step: f32,
    hi: vec3<f32>,
    // The most steps one ray takes.
    max_steps: u32,
    // The image's size in pixels.
    width: u32,
    height: u32,
    // Points to probe.
    points: u32,
    _pad: u32,
}

// Storage, not uniform: see "Parameter blocks" in voxel/mod.rs.
@group(0) @binding(0) var<storage, read> view: View;
@group(0) @binding(4) var<storage, read> points: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read_write> out: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read_write> image: array<u32>;

// out[i] = sample at points[i].xyz with footprint points[i].w.
@compute @workgroup_size(64)
fn probe(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= view.points {
        return;
    }
    let q = points[id.x];
    out[id.x] = sample_structure(q.xyz, q.w);
}

// Front-to-back compositing of premultiplied samples along each pixel's ray inside the box.
@compute @workgroup_size(8, 8)
fn raymarch(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= view.width || id.y >= view.height {
        return;
    }
    let ndc = vec2<f32>((f32(id.x) + 0.5) / f32(view.width) * 2.0 - 1.0,
                        1.0 - (f32(id.y) + 0.5) / f32(view.height) * 2.0);
    let far = view.inv_view_proj * vec4<f32>(ndc, 1.0, 1.0);
    let dir = normalize(far.xyz / far.w - view.eye);
    let inv = 1.0 / dir;
    let t0 = (view.lo - view.eye) * inv;
    let t1 = (view.hi - view.eye) * inv;
    let tmin = max(max(max(min(t0.x, t1.x), min(t0.y, t1.y)), min(t0.z, t1.z)), 0.0);
    let tmax = min(min(max(t0.x, t1.x), max(t0.y, t1.y)), max(t0.z, t1.z));
    var colour = vec4<f32>(0.0);
    var t = tmin + 0.5 * view.step;
    var shade = 1.0;
    var shaded = false;
    for (var i = 0u; i < view.max_steps && t < tmax && colour.a < 0.99; i++) {
        let p = view.eye + t * dir;
        let s = sample_structure(p, view.footprint);
        colour += (1.0 - colour.a) * s;
        if !shaded && colour.a > 0.5 {
            // Shade by the opacity gradient (a surface normal estimate) so that surfaces of
            // equal albedo stay distinguishable.
            shaded = true;
            let h = view.footprint;
            let n = vec3<f32>(
                sample_structure(p + vec3<f32>(h, 0.0, 0.0), h).a - sample_structure(p - vec3<f32>(h, 0.0, 0.0), h).a,
                sample_structure(p + vec3<f32>(0.0, h, 0.0), h).a - sample_structure(p - vec3<f32>(0.0, h, 0.0), h).a,
                sample_structure(p + vec3<f32>(0.0, 0.0, h), h).a - sample_structure(p - vec3<f32>(0.0, 0.0, h), h).a);
            if dot(n, n) > 1e-8 {
                shade = 0.45 + 0.55 * abs(dot(normalize(n), normalize(vec3<f32>(0.4, 0.8, -0.45))));
            }
        }
        t += view.step;
    }
    image[id.x + id.y * view.width] = pack4x8unorm(vec4<f32>(colour.rgb * shade, 1.0));
}
