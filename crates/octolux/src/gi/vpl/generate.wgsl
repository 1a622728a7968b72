// VPL generation from the reflective shadow maps, importance-sampled by flux on the GPU.
//
// 1. `pyramid_base`: per RSM texel its reflected flux (albedo x incident, W: `flux.rgb` x the
//    texel measure `position.w`, see frame/rsm.wgsl) and its weight, the sum over r, g, b.
// 2. `pyramid_level` (once per level): every node sums its 2x2 children, up to one node per
//    layer.
// 3. `sample_vpls`: VPL i inverts the weight's distribution at u = (i + 0.5) / N: it picks a
//    layer, then descends the pyramid, at each level choosing the child whose share of the
//    weight holds u and rescaling u into it (sample warping; stratified over the RSMs). Its flux
//    is the texel's divided by the probability of choosing it times N:
//      Phi_vpl = Phi_texel x W / (N w_texel)    (W the total weight, w_texel its own),
//    so every VPL carries W / N of mean flux and the N of them sum to the RSMs' reflected flux
//    (exactly in the weight, in expectation per channel) whatever N is.
//
// The descent decides on floating-point boundaries (a uniformly lit floor puts u exactly between
// two children at every level), so every value it compares is computed the same way on every
// adapter and by the CPU twin: weights from additions and one multiplication (nothing a compiler
// may fuse into a multiply-add), sums in a fixed order, and u x W from two multiplications (no
// division, whose precision WGSL leaves to the adapter) clamped before the first subtraction.

import octolux::gi::vpl::vpl::Vpl;

struct GenParams {
    // RSM side (a power of two), layers, pyramid levels above the base, VPL count.
    size: u32,
    layers: u32,
    levels: u32,
    count: u32,
    // First word of every pyramid level in `pyramid` (level 0 = the texels).
    offsets: array<vec4<u32>, 4>,
    // 1 / (2 count), rounded once on the CPU: VPL i's point is (2i + 1) x this.
    inv_twice_count: f32,
    // A bit per layer drawn at half the side, in its corner (frame/rsm.rs `half_layer_mask`):
    // the rest of such a layer holds what an earlier frame drew there.
    half_layers: array<vec4<u32>, 2>,
};


@group(0) @binding(0) var<storage, read> gp: GenParams;
@group(0) @binding(1) var rsm_position: texture_2d_array<f32>;
@group(0) @binding(2) var rsm_normal: texture_2d_array<f32>;
@group(0) @binding(3) var rsm_flux: texture_2d_array<f32>;
@group(0) @binding(4) var<storage, read_write> pyramid: array<f32>;
@group(0) @binding(5) var<storage, read_write> vpls: array<Vpl>;
// The level a `pyramid_level` dispatch builds (one slot per level).
@group(0) @binding(6) var<storage, read> level: u32;

fn level_offset(k: u32) -> u32 {
    return gp.offsets[k / 4u][k % 4u];
}

fn texel_flux(x: u32, y: u32, layer: u32) -> vec3<f32> {
    let p = textureLoad(rsm_position, vec2<u32>(x, y), layer, 0);
    let f = textureLoad(rsm_flux, vec2<u32>(x, y), layer, 0);
    return max(f.rgb, vec3<f32>(0.0)) * max(p.w, 0.0);
}

// Whether layer `layer` is drawn at half the side this frame (at most 256 layers are marked).
fn half_layer(layer: u32) -> bool {
    let l = min(layer, 255u);
    let word = gp.half_layers[l / 128u][(l / 32u) % 4u];
    return layer < 256u && ((word >> (l % 32u)) & 1u) != 0u;
}

// The texel's sampling weight, 3x its mean flux: the channels' sum times the texel measure
// (additions, then one multiplication: the same bits on every adapter); 0 outside the corner
// a half-side layer is drawn in.
fn texel_weight(x: u32, y: u32, layer: u32) -> f32 {
    if half_layer(layer) && max(x, y) >= gp.size / 2u {
        return 0.0;
    }
    let p = textureLoad(rsm_position, vec2<u32>(x, y), layer, 0);
    let f = max(textureLoad(rsm_flux, vec2<u32>(x, y), layer, 0).rgb, vec3<f32>(0.0));
    return (f.r + f.g + f.b) * max(p.w, 0.0);
}

@compute @workgroup_size(8, 8)
fn pyramid_base(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= gp.size || id.y >= gp.size || id.z >= gp.layers {
        return;
    }
    pyramid[(id.z * gp.size + id.y) * gp.size + id.x] = texel_weight(id.x, id.y, id.z);
}

@compute @workgroup_size(8, 8)
fn pyramid_level(@builtin(global_invocation_id) id: vec3<u32>) {
    let side = gp.size >> level;
    if id.x >= side || id.y >= side || id.z >= gp.layers {
        return;
    }
    let fine = gp.size >> (level - 1u);
    let base = level_offset(level - 1u) + id.z * fine * fine;
    let x = 2u * id.x;
    let y = 2u * id.y;
    let s = (pyramid[base + y * fine + x] + pyramid[base + y * fine + x + 1u])
        + (pyramid[base + (y + 1u) * fine + x] + pyramid[base + (y + 1u) * fine + x + 1u]);
    pyramid[level_offset(level) + (id.z * side + id.y) * side + id.x] = s;
}

@compute @workgroup_size(64)
fn sample_vpls(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= gp.count {
        return;
    }
    let top = level_offset(gp.levels);
    var total = 0.0;
    for (var l = 0u; l < gp.layers; l++) {
        total += pyramid[top + l];
    }
    var out: Vpl;
    out.position = vec3<f32>(0.0);
    out.area = 0.0;
    out.normal = vec3<f32>(0.0);
    out.flux = vec3<f32>(0.0);
    out.mean_flux = 0.0;
    if total <= 0.0 {
        vpls[i] = out;
        return;
    }
    // Pick the layer.
    var t = clamp(f32(2u * i + 1u) * total * gp.inv_twice_count, 0.0, total);
    var layer = 0u;
    var last = 0u;
    for (var l = 0u; l < gp.layers; l++) {
        let w = pyramid[top + l];
        if w > 0.0 {
            last = l;
        }
    }
    layer = last;
    for (var l = 0u; l < gp.layers; l++) {
        let w = pyramid[top + l];
        if w > 0.0 && t < w {
            layer = l;
            break;
        }
        t -= w;
    }
    t = clamp(t, 0.0, pyramid[top + layer]);
    // Descend: at each level the child holding t, t made relative to it.
    var x = 0u;
    var y = 0u;
    for (var k = gp.levels; k > 0u; k--) {
        let fine = gp.size >> (k - 1u);
        let base = level_offset(k - 1u) + layer * fine * fine;
        var chosen = 4u;
        var last_nonzero = 0u;
        for (var c = 0u; c < 4u; c++) {
            let cx = 2u * x + (c & 1u);
            let cy = 2u * y + (c >> 1u);
            let w = pyramid[base + cy * fine + cx];
            if w > 0.0 {
                last_nonzero = c;
                if chosen == 4u {
                    if t < w {
                        chosen = c;
                    } else {
                        t -= w;
                    }
                }
            }
        }
        if chosen == 4u {
            // t at the very top of the node (rounding): its last child with weight.
            chosen = last_nonzero;
            t = pyramid[base + (2u * y + (chosen >> 1u)) * fine + 2u * x + (chosen & 1u)];
        }
        x = 2u * x + (chosen & 1u);
        y = 2u * y + (chosen >> 1u);
    }
    let phi = texel_flux(x, y, layer);
    let w = texel_weight(x, y, layer);
    let p = textureLoad(rsm_position, vec2<u32>(x, y), layer, 0);
    let n = textureLoad(rsm_normal, vec2<u32>(x, y), layer, 0);
    let scale = total / (f32(gp.count) * max(w, 1e-30));
    // The area the VPL stands for: its texel's surface area (measure x area / measure, see
    // frame/rsm.wgsl) over the probability of drawing it times N, as its flux; the VPLs' areas
    // sum to the area the RSMs see, as their fluxes to its flux. `shade.wgsl` bounds the
    // VPL's geometry term by it (a disk of that area, not a point).
    out.position = p.xyz;
    out.area = max(p.w, 0.0) * max(n.w, 0.0) * scale;
    out.normal = normalize(n.xyz);
    out.flux = phi * scale;
    out.mean_flux = w * scale / 3.0;
    vpls[i] = out;
}
