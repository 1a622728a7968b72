// The octree's control block (`SvoControl` in svo/control.rs, which a test holds to this
// layout) and the per-level parameters every octree kernel reads. The build and the dynamic
// update count into the block with atomics (`SvoControl`); passes that only read it bind the
// same words as `SvoControlValues`, and the dynamic update keeps the previous update's block
// in that form.

// Levels of the deepest octree (1024^3 voxels: levels 0..9).
const MAX_LEVELS: u32 = 10u;

// The nodes [first, end) of one level (or the entries [first, end) of a list).
struct NodeRange {
    first: u32,
    end: u32,
}

struct AtomicNodeRange {
    first: atomic<u32>,
    end: atomic<u32>,
}

struct SvoControl {
    // Nodes allocated so far: the next free node.
    node_count: atomic<u32>,
    // 1 when a subdivision found no room below the node capacity.
    node_overflow: atomic<u32>,
    // Bricks allocated so far.
    brick_count: atomic<u32>,
    // What the dynamic update ran out of: 1 a list, 2 the brick reserve.
    dynamic_overflow: atomic<u32>,
    // Dynamic fragments appended by the voxelization (may exceed the list's capacity).
    dynamic_fragments: atomic<u32>,
    // Entries appended to the dynamic occupied and needed lists.
    occupied_count: atomic<u32>,
    needed_count: atomic<u32>,
    pad: u32,
    // Per level: the static nodes, the dynamic nodes, and the dynamic occupied and needed
    // lists' entries.
    levels: array<AtomicNodeRange, MAX_LEVELS>,
    dynamic_levels: array<AtomicNodeRange, MAX_LEVELS>,
    occupied_ranges: array<AtomicNodeRange, MAX_LEVELS>,
    needed_ranges: array<AtomicNodeRange, MAX_LEVELS>,
}

// `SvoControl` read without atomics.
struct SvoControlValues {
    node_count: u32,
    node_overflow: u32,
    brick_count: u32,
    dynamic_overflow: u32,
    dynamic_fragments: u32,
    occupied_count: u32,
    needed_count: u32,
    pad: u32,
    levels: array<NodeRange, MAX_LEVELS>,
    dynamic_levels: array<NodeRange, MAX_LEVELS>,
    occupied_ranges: array<NodeRange, MAX_LEVELS>,
    needed_ranges: array<NodeRange, MAX_LEVELS>,
}

struct LevelParams {
    // The level.
    d: u32,
    // Levels of the octree.
    depth: u32,
    // Voxel fragments of the build.
    fragments: u32,
    // Node capacity.
    capacity: u32,
    // Bricks per pool buffer (the pool is split over up to 4 storage bindings).
    pool_bricks: u32,
    // Which node range a kernel walks: 0 the level's static nodes; 1 its dynamic nodes
    // (`level_entry`) or the previous update's dirty list (`dirty_entry`, svo/dynamic.wgsl).
    range: u32,
    pad1: u32,
    pad2: u32,
}
