// One cone marched front to back through a filtered voxel structure (`003`, eq. 3, with the
// step-length opacity correction it lacks). It samples the structure composed in as the module
// `gi/vct/structure` (`gi/vct/svo_trace.wgsl`, `clipmap_trace.wgsl`, or a test's):
//   fn vct_sample(p: vec3<f32>, footprint: f32, dir: vec3<f32>) -> vec4<f32>
// returning premultiplied radiance (rgb) and opacity (a) filtered over `footprint` metres, as
// seen by a cone travelling along the unit vector `dir` (structures with isotropic voxels
// ignore it).
// CPU twin: `gi/vct/cone.rs`, `march_cone`; keep the two in step.

import octolux::gi::vct::structure::vct_sample;
import octolux::gpu::work::count_work;

struct ConeParams {
    // Full aperture (radians), start offset, step (fraction of the diameter), maximum distance
    // (all distances in metres).
    aperture: f32,
    start: f32,
    step: f32,
    max_distance: f32,
    // Finest voxel size (metres): the smallest footprint; opacity at which a cone stops;
    // maximum number of steps; the coarsest voxel (metres): the largest footprint.
    voxel: f32,
    stop_opacity: f32,
    max_steps: u32,
    max_footprint: f32,
}

// Work of the cones of one invocation (`gpu/work.wgsl`): cones marched and samples taken,
// kept only by a counting shader; a pass adds them to its counts with `count_cone_work`.
@if(count_work) var<private> cone_work: vec2<u32>;

@if(count_work) fn note_cone(samples: u32) {
    cone_work += vec2<u32>(1u, samples);
}

@if(!count_work) fn note_cone(samples: u32) {}

// Adds this invocation's cones and samples to quantities `cones_q` and `samples_q`.
@if(count_work) fn count_cone_work(cones_q: u32, samples_q: u32) {
    count_work(cones_q, cone_work.x);
    count_work(samples_q, cone_work.y);
}

@if(!count_work) fn count_cone_work(cones_q: u32, samples_q: u32) {}

// What one sample adds to a cone that has accumulated `acc` (rgb premultiplied, a opacity):
// the sample's opacity, defined over a path as long as its footprint, corrected to the step
// length (1 - (1 - a)^(step / footprint)), its premultiplied radiance scaled alike.
fn cone_composite(acc: vec4<f32>, s: vec4<f32>, step: f32, footprint: f32) -> vec4<f32> {
    let a = clamp(s.a, 0.0, 1.0);
    var corrected = a;
    var scale = 1.0;
    if a > 0.0 && a < 1.0 {
        corrected = 1.0 - pow(1.0 - a, step / footprint);
        scale = corrected / a;
    }
    let t = 1.0 - acc.a;
    return vec4<f32>(acc.rgb + t * s.rgb * scale, acc.a + t * corrected);
}

// Marches the cone from `origin` along the unit vector `dir`: returns the accumulated
// premultiplied radiance (rgb) and opacity (a).
fn march_cone(origin: vec3<f32>, dir: vec3<f32>, c: ConeParams) -> vec4<f32> {
    let spread = 2.0 * tan(0.5 * c.aperture);
    var acc = vec4<f32>(0.0);
    var t = c.start;
    var samples = 0u;
    for (var i = 0u; i < c.max_steps; i++) {
        if t >= c.max_distance || acc.a >= c.stop_opacity {
            break;
        }
        samples += 1u;
        // Past the coarsest level's voxel the structure cannot filter more: the cone keeps
        // that footprint and its step, so it cannot step over a wall of coarse voxels.
        let footprint = min(max(spread * t, c.voxel), c.max_footprint);
        let step = c.step * footprint;
        acc = cone_composite(acc, vct_sample(origin + t * dir, footprint, dir), step, footprint);
        t += step;
    }
    note_cone(samples);
    return acc;
}
