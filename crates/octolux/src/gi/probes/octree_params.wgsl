// The probe octree's parameter block (`OctreeParams` in octree_gi.rs), bound by the state
// machine and the probe set (octree_tree_write.wgsl, octree_tree_read.wgsl).

struct OctreeParams {
    // xyz: lower corner of the root cube; w: its edge
    root: vec4<f32>,
    // x: words in the tree buffer, y: probe slots, z: clusters, w: deepest level
    sizes: vec4<u32>,
    // x: ring origin of this frame, y: moved boxes, z: hits below which a probe is freed,
    // w: hits from which a leaf splits
    frame: vec4<u32>,
    // x: 1 = surfels beyond the probe's cube are kept (lit, not counted), y: gather 0 through
    // the octree, 1 over all probes, z: 1 = place every live probe this frame, w: levels
    // complete down to this depth (`OctreeRule::min_depth`)
    modes: vec4<u32>,
    // x: surfels per probe, y: moment-map texels per probe (the shared passes' invocations
    // per listed probe)
    shape: vec4<u32>,
};
