// The radiance's facing, shared by both voxel structures (`voxel/facing.rs`): next to its
// radiance a voxel keeps the direction that radiance leaves in, and a cone sample keeps only
// the share of it that leaves towards the cone's apex, so the light on one face of a wall
// thinner than a voxel is not seen from the other face.

// How fast radiance seen from behind fades: all of it is dropped once the cone travels
// more than asin(1 / FACING_SHARPNESS) (14.5 degrees) off the plane its surface faces out of.
// A sharpness of 1 kept 1 - cos(angle) of the light on a wall's far face seen at that angle
// off its normal, and let most of a thin wall's leak through (docs/vct.md, "The radiance's
// facing", measured). The CPU twin is `voxel::facing::FACING_SHARPNESS`.
const FACING_SHARPNESS: f32 = 4.0;

// The share of a sample's radiance (premultiplied, with its facing sum `facing`: the
// radiance's weight r + g + b times the direction it leaves in, filtered as the radiance)
// that leaves towards the apex of a cone travelling along `dir`. Radiance whose mean facing
// is F (|F| <= 1, F = facing / (r + g + b)) keeps 1 - FACING_SHARPNESS F . dir, at most 1 and
// at least 1 - |F|: what faces the apex is kept whole (as without the facing), what faces
// away is dropped. The floor 1 - |F| is the share that does not face away: for a wall thinner
// than a voxel whose faces hold radiance a and b, the sample's mean (a + b) / 2 keeps
// 2b / (a + b) of itself seen from b's side, b, at every angle more than 14.5 degrees off the
// wall's plane. CPU twin: `voxel::facing::facing_toward`.
fn facing_toward(radiance: vec4<f32>, facing: vec3<f32>, dir: vec3<f32>) -> f32 {
    let f = facing / max(radiance.r + radiance.g + radiance.b, 1e-20);
    let undirected = 1.0 - min(length(f), 1.0);
    return clamp(1.0 - FACING_SHARPNESS * dot(f, dir), undirected, 1.0);
}
