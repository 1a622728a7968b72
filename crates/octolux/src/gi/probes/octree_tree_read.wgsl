// The probe octree's bindings as the probe set (octree_set.wgsl) reads them (group 1 of the
// probe passes); composed in as `gi/probes/tree_bindings` (octree_tree.wgsl).

import octolux::gi::probes::octree_params::OctreeParams;

@group(1) @binding(0) var<storage, read> O: OctreeParams;
@group(1) @binding(1) var<storage, read> tree: array<i32>;
