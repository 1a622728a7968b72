// The probe octree's parameter block (`OctreeParams` in octree_gi.rs), bound by the state
// machine and the probe set (octree_tree_write.wgsl, octree_tree_read.wgsl).

struct OctreeParams {
    // Lower corner of the root cube
    root_lo: vec3<f32>,
    // Edge of the root cube
    root_size: f32,
    // Words in the tree buffer
    tree_words: u32,
    // Probe slots
    probe_slots: u32,
    // Clusters
    clusters: u32,
    // Deepest level
    max_depth: u32,
    // Ring origin of this frame
    ring_origin: u32,
    // Moved boxes
    moved_boxes: u32,
    // Hits below which a probe is freed
    free_below: u32,
    // Hits from which a leaf splits
    split_from: u32,
    // 1 = surfels beyond the probe's cube are kept (lit, not counted)
    keep_outside: u32,
    // Gather 0 through the octree, 1 over all probes
    gather_all: u32,
    // 1 = place every live probe this frame
    place_all: u32,
    // Levels complete down to this depth (`OctreeRule::min_depth`)
    min_depth: u32,
    // Surfels per probe (of both sets with a history): the place and light passes' invocations
    // per listed probe
    surfels_per_probe: u32,
    // Invocations per listed probe of the moment maps' pass (MOMENT_LANES)
    moment_lanes: u32,
    _pad0: u32,
    _pad1: u32,
};

// The live probes' list (octree.wgsl's `live`): its count, then the slots from LIVE_FIRST.
// Lanes that integrate one probe's surfels side by side (`integrate.wgsl`; `INTEGRATE_LANES`
// in engine.rs): the integration launches this many invocations per probe.
const INTEGRATE_LANES: u32 = 8u;

const LIVE_COUNT: u32 = 0u;
const LIVE_FIRST: u32 = 1u;

// A probe slot's record in `probe_info` (`OctreeProbe::gpu_info` in octree.rs).
struct ProbeInfo {
    // Centre of the probe's cube.
    position: vec3<f32>,
    // Its depth in the octree; negative: the slot is free.
    depth: f32,
};
const FREE_INFO: ProbeInfo = ProbeInfo(vec3<f32>(0.0), -1.0);
