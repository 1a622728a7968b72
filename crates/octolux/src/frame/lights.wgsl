// Punctual lights as the renderer uploads them (`frame/lights.rs`, `GpuLight`), their
// irradiance and their PCF-filtered shadow-map visibility, with the bindings they are read
// from. Shared by the direct-light pass, the voxel light injections and the probes' surfel
// light so that all of them light surfaces identically. The bindings are the same in every
// shader that imports them (`frame::light_bindings` binds them in Rust): group 0 from
// binding 40 on, above every pass's own.

// `GpuLight` in frame/lights.rs.
struct Light {
    // Point and spot lights.
    position: vec3<f32>,
    // LIGHT_POINT, LIGHT_SPOT or LIGHT_DIRECTIONAL.
    kind: u32,
    // Unit direction of travel (spot and directional lights).
    direction: vec3<f32>,
    // Cosine of a spot cone's inner half-angle (1 for other lights).
    cos_inner: f32,
    // Radiant intensity, W/sr (point, spot), or irradiance, W/m^2 (directional).
    radiant: vec3<f32>,
    // Cosine of a spot cone's outer half-angle (-1 for other lights).
    cos_outer: f32,
    // First shadow view (its lookup matrix; a point light's six follow), -1 for none.
    shadow_view: i32,
    // World size of a shadow texel per metre of distance (perspective) or absolute
    // (orthographic).
    shadow_texel: f32,
    // 1 when the shadow views are orthographic.
    shadow_orthographic: u32,
    // Sky lights (frame/sky.rs): 1 + the texture layer that holds their tile, else 0.
    sky_layer_plus_one: u32,
    // Sky lights: tangent of the angular radius of the region they stand for (0: hard).
    sky_spread: f32,
    // Sky lights: the shadow view's depth range (world distance = depth x range).
    sky_depth_range: f32,
    // Sky lights: the largest soft-shadow filter radius, texels (the tile's free margin).
    sky_margin: f32,
    _pad: u32,
};

const LIGHT_POINT: u32 = 0u;
const LIGHT_SPOT: u32 = 1u;
const LIGHT_DIRECTIONAL: u32 = 2u;

@group(0) @binding(40) var<storage, read> lights: array<Light>;
@group(0) @binding(41) var<storage, read> shadow_matrices: array<mat4x4<f32>>;
@group(0) @binding(42) var shadow_maps: texture_depth_2d_array;
@group(0) @binding(43) var shadow_sampler: sampler_comparison;

// Cube face of direction `d` in the order +x, -x, +y, -y, +z, -z.
fn cube_face(d: vec3<f32>) -> u32 {
    let a = abs(d);
    if a.x >= a.y && a.x >= a.z {
        return select(1u, 0u, d.x > 0.0);
    }
    if a.y >= a.z {
        return select(3u, 2u, d.y > 0.0);
    }
    return select(5u, 4u, d.z > 0.0);
}

// Spot falloff: smoothstep from the outer cone (0) to the inner cone (1), as on the CPU.
fn spot_attenuation(cos_angle: f32, cos_inner: f32, cos_outer: f32) -> f32 {
    let x = clamp((cos_angle - cos_outer) / max(cos_inner - cos_outer, 1e-6), 0.0, 1.0);
    return x * x * (3.0 - 2.0 * x);
}

struct Incidence {
    // unit direction towards the light
    to_light: vec3<f32>,
    // irradiance on a surface facing the light (W/m^2), before shadowing
    irradiance: vec3<f32>,
    // distance to the light (1 for directional lights)
    dist: f32,
};

// Light arriving at `p` from `light`, unshadowed.
fn light_incidence(light: Light, p: vec3<f32>) -> Incidence {
    var out: Incidence;
    out.dist = 1.0;
    if light.kind == LIGHT_DIRECTIONAL {
        out.to_light = -light.direction;
        out.irradiance = light.radiant;
        return out;
    }
    let d = light.position - p;
    let r2 = max(dot(d, d), 1e-8);
    out.dist = sqrt(r2);
    out.to_light = d / out.dist;
    out.irradiance = light.radiant / r2;
    if light.kind == LIGHT_SPOT {
        out.irradiance *= spot_attenuation(dot(light.direction, -out.to_light), light.cos_inner, light.cos_outer);
    }
    return out;
}

// Point `i` of `count` on a Vogel (golden-angle) spiral filling the unit disk evenly.
fn vogel_disk(i: u32, count: u32) -> vec2<f32> {
    let r = sqrt((f32(i) + 0.5) / f32(count));
    let theta = f32(i) * 2.39996323;
    return r * vec2<f32>(cos(theta), sin(theta));
}

// Depth change of the receiver's tangent plane per shadow texel in x and y, for an orthographic
// (affine) view matrix `m`: the tangent t with given clip x, y steps and t.n = 0 (Cramer's rule on the
// rows of the matrix). Clamped, so that a plane seen edge-on does not push its taps away.
fn receiver_slope(m: mat4x4<f32>, n: vec3<f32>, size: vec2<f32>) -> vec2<f32> {
    let r0 = vec3<f32>(m[0].x, m[1].x, m[2].x);
    let r1 = vec3<f32>(m[0].y, m[1].y, m[2].y);
    let r2 = vec3<f32>(m[0].z, m[1].z, m[2].z);
    let c0 = cross(r1, n);
    let c1 = cross(n, r0);
    let det = dot(r0, c0);
    if abs(det) <= 1e-8 {
        return vec2<f32>(0.0);
    }
    // uv = clip / 2 + 1/2 with v flipped: one texel is 2 / size in clip x and -2 / size in y.
    let slope = vec2<f32>(dot(r2, c0), -dot(r2, c1)) / det * (2.0 / size);
    return clamp(slope, vec2<f32>(-0.01), vec2<f32>(0.01));
}

// The turn of a sky light's tap disk at shadow texel `texel` of view `view`: interleaved
// gradient noise (Jimenez 2014) of the texel, offset per view. With one disk for every
// receiver, neighbouring receivers whose disks straddle an edge alike switch their taps
// together, and the 32 sky lights' switches line up into streaks; turned per texel and per
// light, they become a fine grain that the lights' sum averages out. Tied to the map's
// texels, so it stays put when the camera moves.
fn disk_turn(texel: vec2<f32>, view: u32) -> mat2x2<f32> {
    let q = texel + vec2<f32>(f32(view) * 5.588238, f32(view) * 7.370101);
    let a = 6.2831853 * fract(52.9829189 * fract(dot(q, vec2<f32>(0.06711056, 0.00583715))));
    let c = cos(a);
    let s = sin(a);
    return mat2x2<f32>(c, s, -s, c);
}

// Soft visibility of a sky light (percentage-closer soft shadows): the light stands for a
// region of the sky of angular radius atan(sky_spread), so a receiver d metres behind
// its occluder sees a penumbra of radius d x tan. The blockers' mean depth within the largest
// possible penumbra gives d; 16 taps over that radius give the visible fraction. Depths are
// linear (orthographic): world distance = depth x range (sky_depth_range). Radii are capped at
// the tile's free margin (sky_margin texels). Every tap compares against the receiver's own
// plane at that tap (receiver-plane depth bias), or wide filters would find the receiver
// itself in front of it under grazing light; a tap whose texel lies more than `margin` metres
// beyond that plane sees past the receiver's surroundings (beyond the edge of the wall it
// meets, as in `orthographic_visibility`) and is left out, or wide filters would let the light
// creep along a box's inner corners.
fn sky_visibility(light: Light, view: u32, layer: u32, n: vec3<f32>, uv: vec2<f32>, depth: f32, margin: f32) -> f32 {
    let size = vec2<f32>(textureDimensions(shadow_maps));
    let tan_a = light.sky_spread;
    let range = light.sky_depth_range;
    let cap = light.sky_margin;
    let texel_world = light.shadow_texel;
    let slope = receiver_slope(shadow_matrices[view], n, size);
    let past = margin / range;
    let f = uv * size;
    let turn = disk_turn(floor(f), view);
    let search = clamp(tan_a * depth * range / texel_world, 1.0, cap);
    var blockers = 0.0;
    var blocker_gap = 0.0;
    for (var i = 0u; i < 16u; i++) {
        let o = turn * vogel_disk(i, 16u) * search;
        let t = floor(f + o);
        let d = textureLoad(shadow_maps, vec2<i32>(t), layer, 0);
        let receiver = depth + dot(slope, t + 0.5 - f);
        if d < receiver {
            blockers += 1.0;
            blocker_gap += receiver - d;
        }
    }
    if blockers == 0.0 {
        return 1.0;
    }
    let radius = clamp(tan_a * (blocker_gap / blockers) * range / texel_world, 1.0, cap);
    var lit = 0.0;
    var seen = 0.0;
    for (var i = 0u; i < 16u; i++) {
        let t = floor(f + turn * vogel_disk(i, 16u) * radius);
        let d = textureLoad(shadow_maps, vec2<i32>(t), layer, 0);
        let receiver = depth + dot(slope, t + 0.5 - f);
        if d > receiver + past {
            continue;
        }
        seen += 1.0;
        lit += select(0.0, 1.0, receiver <= d);
    }
    return select(1.0, lit / seen, seen > 0.0);
}

// An orthographic view's filtered visibility at `uv` (receiver depth `depth`, normal `n`): the
// 4 x 4 texels the 3 x 3 bilinear taps cover, weighted as those taps weight them (1 - f, 1, 1,
// f along each axis), each compared against the receiver's plane at the texel's centre. A
// texel whose depth lies more than `margin` (world metres) beyond that plane sees past the
// receiver's surroundings, beyond an edge of the geometry it lies in: in a corner of two
// single-sided walls, the light passing outside the neighbouring wall. Such texels are left
// out and the others decide (lit where none is left). With the orthographic views drawn
// without a depth bias (`frame/shadow.rs`), this takes most of the bright line off the inner
// edges of a box lit from outside (`tests/sky.rs`); at some alignments of the map a line a
// pixel wide stays where a sun meets the neighbouring wall from outside
// (results/lavapipe/directional-shadow-edges).
fn orthographic_visibility(m: mat4x4<f32>, layer: u32, n: vec3<f32>, uv: vec2<f32>, depth: f32, margin: f32) -> f32 {
    let size = vec2<f32>(textureDimensions(shadow_maps));
    let slope = receiver_slope(m, n, size);
    // Depth per world metre along the light (the view's depth row).
    let past = margin * length(vec3<f32>(m[0].z, m[1].z, m[2].z));
    let f = uv * size - 0.5;
    let base = floor(f);
    let fr = f - base;
    let last = vec2<i32>(size) - 1;
    var lit = 0.0;
    var seen = 0.0;
    for (var j = 0; j < 4; j++) {
        let wy = select(select(1.0, fr.y, j == 3), 1.0 - fr.y, j == 0);
        for (var i = 0; i < 4; i++) {
            let wx = select(select(1.0, fr.x, i == 3), 1.0 - fr.x, i == 0);
            let t = base + vec2<f32>(f32(i - 1), f32(j - 1));
            let receiver = depth + dot(slope, t - f);
            let d = textureLoad(shadow_maps, clamp(vec2<i32>(t), vec2<i32>(0), last), layer, 0);
            if d > receiver + past {
                continue;
            }
            seen += wx * wy;
            lit += select(0.0, wx * wy, receiver <= d);
        }
    }
    return select(1.0, lit / seen, seen > 0.0);
}

// Fraction of the light reaching `p` (normal `n`), looked up `lift` metres plus ~1.5 shadow
// texels along the normal; the texel-scaled normal offset removes acne without the light
// leaking of large constant biases. Orthographic views (directional and sky lights) filter
// against the receiver's plane and leave out what lies past it (`orthographic_visibility`);
// perspective views (point and spot lights, whose receiver plane is not affine in the texel
// offset) take 3 x 3 bilinear comparison taps at a flat depth, shifted half a texel towards
// the light.
fn shadow_visibility(light: Light, p: vec3<f32>, n: vec3<f32>, to_light: vec3<f32>, dist: f32, lift: f32) -> f32 {
    return shadow_visibility_offset(light, p, n, to_light, dist, lift, 1.5);
}

// Whether `light`'s shadow is looked up through the sharp orthographic filter (a directional
// light, or a sky light with sharp sky shadows): the one lookup whose normal offset a receiver
// that knows its surface's curvature may shrink (`shadow_visibility_offset`). Perspective
// views and the soft sky filter, whose wide taps lean on the receiver's plane farther out,
// keep 1.5 texels.
fn sharp_orthographic_shadow(light: Light) -> bool {
    return light.shadow_view >= 0 && light.shadow_orthographic == 1u && !soft_sky_shadow(light);
}

// Whether `light` is a sky light with soft shadows (`sky_visibility`).
fn soft_sky_shadow(light: Light) -> bool {
    return light.sky_layer_plus_one > 0u && light.sky_spread > 0.0;
}

// `shadow_visibility` with the normal offset given in shadow texels (`offset_texels`; 1.5 for
// every lookup but the sharp orthographic one of a receiver flat within the filter's reach,
// `sharp_orthographic_shadow`): the offset hides occluders that touch the receiver (a wall
// meeting the floor) over its width.
fn shadow_visibility_offset(light: Light, p: vec3<f32>, n: vec3<f32>, to_light: vec3<f32>, dist: f32, lift: f32, offset_texels: f32) -> f32 {
    if light.shadow_view < 0 {
        return 1.0;
    }
    var view = u32(light.shadow_view);
    if light.kind == LIGHT_POINT {
        view += cube_face(p - light.position);
    }
    // A sky light's map is a tile of a shared layer; its matrix maps into the tile.
    let sky = light.sky_layer_plus_one > 0u;
    let layer = select(view, light.sky_layer_plus_one - 1u, sky);
    let orthographic = light.shadow_orthographic == 1u;
    let texel_world = select(light.shadow_texel * dist, light.shadow_texel, orthographic);
    let cos_l = clamp(dot(n, to_light), 0.0, 1.0);
    let toward = select(texel_world * 0.5, 0.0, orthographic);
    let offset_p = p + n * (lift + texel_world * offset_texels * (1.0 - 0.5 * cos_l)) + to_light * toward;
    let m = shadow_matrices[view];
    let clip = m * vec4<f32>(offset_p, 1.0);
    let ndc = clip.xyz / clip.w;
    let uv = vec2<f32>(ndc.x * 0.5 + 0.5, 0.5 - ndc.y * 0.5);
    if any(uv < vec2<f32>(0.0)) || any(uv > vec2<f32>(1.0)) || ndc.z > 1.0 {
        return 1.0;
    }
    // Past (orthographic views): farther than the normal offset and a voxel's lift could put
    // the receiver's own surface (twice each), plus a few texels of the clamped slope's error.
    let past = 2.0 * lift + 6.0 * texel_world;
    if soft_sky_shadow(light) {
        return sky_visibility(light, view, layer, n, uv, ndc.z, past);
    }
    if orthographic {
        return orthographic_visibility(m, layer, n, uv, ndc.z, past);
    }
    let size = vec2<f32>(textureDimensions(shadow_maps));
    var sum = 0.0;
    for (var y = -1; y <= 1; y++) {
        for (var x = -1; x <= 1; x++) {
            let o = vec2<f32>(f32(x), f32(y));
            sum += textureSampleCompareLevel(shadow_maps, shadow_sampler, uv + o / size, layer, ndc.z);
        }
    }
    return sum / 9.0;
}
