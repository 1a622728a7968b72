// Converts the RGBA16F build pool into the RGBA8 pool (values are in 0..1): one invocation per
// texel, pool buffer by pool buffer.

struct PackParams {
    // Texels of all bricks (27 per brick).
    texels: u32,
    // Bricks per pool buffer.
    pool_bricks: u32,
    pad1: u32,
    pad2: u32,
}

// Storage, not uniform: see "Parameter blocks" in voxel/mod.rs.
@group(0) @binding(0) var<storage, read> P: PackParams;
@group(0) @binding(1) var<storage, read> wide0: array<u32>;
@group(0) @binding(2) var<storage, read> wide1: array<u32>;
@group(0) @binding(3) var<storage, read> wide2: array<u32>;
@group(0) @binding(4) var<storage, read> wide3: array<u32>;
@group(0) @binding(5) var<storage, read_write> narrow0: array<u32>;
@group(0) @binding(6) var<storage, read_write> narrow1: array<u32>;
@group(0) @binding(7) var<storage, read_write> narrow2: array<u32>;
@group(0) @binding(8) var<storage, read_write> narrow3: array<u32>;

@compute @workgroup_size(64)
fn pack(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) li: u32) {
    let i = (wg.y * nwg.x + wg.x) * 64u + li;
    if i >= P.texels {
        return;
    }
    let b = i / 27u;
    let t = i % 27u;
    let slot = b % P.pool_bricks;
    let w = slot * 54u + 2u * t;
    var lo = 0u;
    var hi = 0u;
    switch b / P.pool_bricks {
        case 0u: { lo = wide0[w]; hi = wide0[w + 1u]; }
        case 1u: { lo = wide1[w]; hi = wide1[w + 1u]; }
        case 2u: { lo = wide2[w]; hi = wide2[w + 1u]; }
        default: { lo = wide3[w]; hi = wide3[w + 1u]; }
    }
    let v = clamp(vec4<f32>(unpack2x16float(lo), unpack2x16float(hi)), vec4<f32>(0.0), vec4<f32>(1.0));
    let n = slot * 27u + t;
    switch b / P.pool_bricks {
        case 0u: { narrow0[n] = pack4x8unorm(v); }
        case 1u: { narrow1[n] = pack4x8unorm(v); }
        case 2u: { narrow2[n] = pack4x8unorm(v); }
        default: { narrow3[n] = pack4x8unorm(v); }
    }
}
