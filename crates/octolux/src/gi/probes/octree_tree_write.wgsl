// The probe octree's bindings as the state machine (octree.wgsl) writes them; composed in as
// `gi/probes/tree_bindings` (octree_tree.wgsl).

import octolux::gi::probes::octree_params::OctreeParams;

@group(0) @binding(0) var<storage, read> O: OctreeParams;
@group(0) @binding(1) var<storage, read_write> tree: array<i32>;
