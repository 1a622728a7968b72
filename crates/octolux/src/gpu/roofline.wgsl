// The adapter's peaks for the roofline (`gpu/roofline.rs`): a copy kernel for memory bandwidth
// and a kernel of independent fused multiply-adds for arithmetic throughput.

@group(0) @binding(0) var<storage, read> copy_from: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read_write> copy_to: array<vec4<f32>>;

// Invocation index over a 2-D dispatch of 64-wide workgroups (`gpu::pass::dispatch_size`).
fn index(wg: vec3<u32>, nwg: vec3<u32>, li: u32) -> u32 {
    return (wg.y * nwg.x + wg.x) * 64u + li;
}

// One vec4 read and one written per invocation: 32 bytes.
@compute @workgroup_size(64)
fn copy(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) li: u32) {
    let i = index(wg, nwg, li);
    if i < arrayLength(&copy_to) {
        copy_to[i] = copy_from[i];
    }
}

// FMA_CHAINS independent chains of vec4 fused multiply-adds, FMA_STEPS deep: 8 x 4 x 256 x 2
// = 16384 floating-point operations per invocation, from registers only; the sum is written
// so that nothing is optimised away.
const FMA_CHAINS: u32 = 8u;
const FMA_STEPS: u32 = 256u;

@compute @workgroup_size(64)
fn fma_chains(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
              @builtin(local_invocation_index) li: u32) {
    let i = index(wg, nwg, li);
    let seed = f32(i & 1023u) * 1e-3;
    let m = vec4<f32>(0.999, 0.998, 0.997, 0.996);
    let c = vec4<f32>(1e-3);
    var a: array<vec4<f32>, 8>;
    for (var k = 0u; k < FMA_CHAINS; k++) {
        a[k] = vec4<f32>(seed + f32(k));
    }
    for (var s = 0u; s < FMA_STEPS; s++) {
        a[0] = fma(a[0], m, c);
        a[1] = fma(a[1], m, c);
        a[2] = fma(a[2], m, c);
        a[3] = fma(a[3], m, c);
        a[4] = fma(a[4], m, c);
        a[5] = fma(a[5], m, c);
        a[6] = fma(a[6], m, c);
        a[7] = fma(a[7], m, c);
    }
    var sum = vec4<f32>(0.0);
    for (var k = 0u; k < FMA_CHAINS; k++) {
        sum += a[k];
    }
    if i < arrayLength(&copy_to) {
        copy_to[i] = sum;
    }
}
