// SH helpers and grid description shared by the LPV shaders (same conventions as sh.rs).

const SH_C0: f32 = 0.2820948;
const SH_C1: f32 = 0.4886025;
const LOBE_C0: f32 = 0.8862269;
const LOBE_C1: f32 = 1.0233267;
// sh.rs LOOKUP_OFFSET: the lookup samples this many cells in front of the surface.
const LOOKUP_OFFSET: f32 = 1.0;
const FRONT_SOLID_ANGLE: f32 = 0.4006697;
const SIDE_SOLID_ANGLE: f32 = 0.42343135;

// One uniform grid of cells (a whole LPV, a cascade or an octree level).
struct Grid {
    // world position of the grid's minimum corner
    origin: vec3<f32>,
    // cell side (m)
    cell: f32,
    // cells per side
    n: u32,
    // first cell of this grid in the light buffers
    offset: u32,
    // first cell of this grid's geometry volume ((n+1)^3 cells at LPV cell corners)
    gv_offset: u32,
    // bit 0: occlusion by the geometry volume, bit 1: receives injected light, bits 8..16:
    // the surfel stride (`inject.wgsl`)
    flags: u32,
};

// Every grid of a technique, plus the settings the injection and lookup passes need.
struct Grids {
    count: u32,
    // cells in all geometry volumes together
    gv_total: u32,
    // RSM injection stride (texels per VPL side)
    stride: u32,
    // G-buffer pixels per camera surfel side (see `inject_gv_camera`)
    camera_stride: u32,
    gain: f32,
    damping: f32,
    // cascade blend width in cells
    blend: f32,
    // fixed-point scale of the injected light sums (a power of two chosen per frame)
    light_scale: f32,
    // bit i: RSM layer i is drawn at half the side, read with half the stride
    half_layers: array<vec4<u32>, 2>,
    grids: array<Grid, 8>,
};

fn sh_basis(d: vec3<f32>) -> vec4<f32> {
    return vec4<f32>(SH_C0, -SH_C1 * d.y, SH_C1 * d.z, -SH_C1 * d.x);
}

// SH of max(0, n.w).
fn sh_lobe(n: vec3<f32>) -> vec4<f32> {
    return vec4<f32>(LOBE_C0, -LOBE_C1 * n.y, LOBE_C1 * n.z, -LOBE_C1 * n.x);
}
