//! The adaptive probe octree of `004` §3.1-§3.2 on the CPU: the buffer encoding, allocation
//! and the per-leaf state machine (memory update M0-M4, light update L0-L3) over the
//! three-segment leaf ring. It is the specification the GPU version (`probes-octree`) is to be
//! tested against; here hit fractions come from the caller (scripted in tests, surfel rays on
//! the GPU).
//!
//! Encoding (`004` §3.1.1): one `i32` buffer. Index 0 is the root; after it, clusters of 9
//! words: a meta word (0 free, `< 0`: allocated, `!meta` = parent node) and 8 sibling nodes.
//! A node is 0 (leaf without probe), `< 0` (leaf with probe `!node`) or `> 0` (parent; the
//! value is its children's meta index, children at `value + 1 ..= value + 8`). Child slot `s`
//! covers the octant with bit 0, 1, 2 of `s` set = upper half in x, y, z. A tail shorter than 9
//! words is never allocated.
//!
//! Changes from `004`, each for a trap the notes name:
//! - **Allocation** pops free lists (clusters, probes) instead of scanning the buffer with
//!   compare-exchange (the cause of `004`'s depth-3 spikes); on the GPU an atomic stack.
//! - **Orphans.** M2 frees a leaf's probe and pushes only the parent (M4). If a sibling keeps
//!   its probe, M4 does nothing and the freed leaf was in no segment any more: geometry moving
//!   into it later could never give it a probe. Here M2 also pushes the leaf as L3.
//! - **Collapse.** A parent split for a high hit fraction whose children all free their probes
//!   (their lattices, confined to smaller cubes, hit less) collapsed to a probe-less L3 for
//!   good. Here a collapsed parent asks for a probe again (M1) and is not split again until
//!   geometry moves through it.

use glam::Vec3;
use std::collections::{BTreeMap, BTreeSet};

/// The states of `004` §3.2.1-§3.2.2.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum State {
    /// A child of this parent is allocating a cluster: the parent must not free its children.
    M0,
    /// Allocate a probe.
    M1,
    /// Free the probe (hit fraction below the lower bound).
    M2,
    /// Split: allocate a cluster and a probe per child, then free the own probe.
    M3,
    /// Free the children's cluster if none of them holds a probe.
    M4,
    /// The leaf's cluster was freed: drop it.
    L0,
    /// (Re)place surfels, measure the hit fraction, decide.
    L1,
    /// Light surfels and probe.
    L2,
    /// Probe-less leaf: only test against moving geometry.
    L3,
}

impl State {
    fn is_memory(self) -> bool {
        matches!(
            self,
            State::M0 | State::M1 | State::M2 | State::M3 | State::M4
        )
    }
}

/// The thresholds of the split/free rule.
#[derive(Clone, Copy, Debug)]
pub struct OctreeRule {
    /// Deepest level (root 0).
    pub max_depth: u32,
    /// A leaf frees its probe below this hit fraction (`004`: 1/4).
    pub f_lower: f32,
    /// A leaf splits at or above this hit fraction (`004`: 1/2).
    pub f_upper: f32,
}

impl Default for OctreeRule {
    fn default() -> Self {
        OctreeRule {
            max_depth: 2,
            f_lower: 0.25,
            f_upper: 0.5,
        }
    }
}

/// A probe: position (its cube's centre) and depth, as `004` §3.1.2 keeps them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OctreeProbe {
    /// World position.
    pub position: Vec3,
    /// Depth of its leaf.
    pub depth: u32,
}

/// The probe octree with its allocators and leaf ring.
pub struct ProbeOctree {
    /// The octree buffer.
    pub nodes: Vec<i32>,
    probes: Vec<Option<OctreeProbe>>,
    free_probes: Vec<u32>,
    free_clusters: Vec<u32>,
    ring: [BTreeMap<u32, State>; 3],
    origin: usize,
    /// Collapsed parents that may not split again until geometry moves through them.
    no_split: BTreeSet<u32>,
    lo: Vec3,
    size: f32,
    rule: OctreeRule,
}

/// Whether two boxes overlap.
fn overlaps(a: (Vec3, Vec3), b: (Vec3, Vec3)) -> bool {
    a.0.cmple(b.1).all() && b.0.cmple(a.1).all()
}

impl ProbeOctree {
    /// An octree over the cube at `lo` of edge `size`, in a buffer of `len` words (clusters:
    /// the whole 9-word groups after the root) with room for `probe_capacity` probes. The root
    /// asks for a probe at the first frame (M1).
    pub fn new(len: usize, probe_capacity: u32, lo: Vec3, size: f32, rule: OctreeRule) -> Self {
        let len = len.max(1);
        let clusters = (len - 1) / 9;
        let mut tree = ProbeOctree {
            nodes: vec![0; len],
            probes: vec![None; probe_capacity as usize],
            free_probes: (0..probe_capacity).rev().collect(),
            free_clusters: (0..clusters as u32).rev().map(|k| 1 + 9 * k).collect(),
            ring: Default::default(),
            origin: 0,
            no_split: BTreeSet::new(),
            lo,
            size,
            rule,
        };
        tree.push(0, 0, State::M1);
        tree
    }

    /// Pushes `state` for `node` into segment `origin + offset`; M0 and L0 override any other
    /// state of their kind, otherwise the first push wins.
    fn push(&mut self, offset: usize, node: u32, state: State) {
        let segment = &mut self.ring[(self.origin + offset) % 3];
        match segment.get(&node) {
            Some(State::M0 | State::L0) => {}
            Some(_) if !matches!(state, State::M0 | State::L0) => {}
            _ => {
                segment.insert(node, state);
            }
        }
    }

    /// The parent of node `i` (None for the root).
    pub fn parent(&self, i: u32) -> Option<u32> {
        (i != 0).then(|| !self.nodes[Self::meta_of(i) as usize] as u32)
    }

    fn meta_of(i: u32) -> u32 {
        1 + 9 * ((i - 1) / 9)
    }

    /// Cube of node `i`: lower corner, edge and depth, rebuilt bottom-up through the meta
    /// words' parent links (a probe-less leaf has no stored position).
    pub fn cube(&self, i: u32) -> (Vec3, f32, u32) {
        let Some(parent) = self.parent(i) else {
            return (self.lo, self.size, 0);
        };
        let (lo, size, depth) = self.cube(parent);
        let slot = i - Self::meta_of(i) - 1;
        let half = size * 0.5;
        let offset = Vec3::new(
            (slot & 1) as f32,
            ((slot >> 1) & 1) as f32,
            ((slot >> 2) & 1) as f32,
        );
        (lo + offset * half, half, depth + 1)
    }

    /// Probes allocated.
    pub fn probe_count(&self) -> usize {
        self.probes.iter().flatten().count()
    }

    /// The allocated probes.
    pub fn probes(&self) -> impl Iterator<Item = &OctreeProbe> {
        self.probes.iter().flatten()
    }

    /// Leaves (nodes reachable from the root that have no children).
    pub fn leaves(&self) -> Vec<u32> {
        let mut out = Vec::new();
        let mut stack = vec![0u32];
        while let Some(i) = stack.pop() {
            let v = self.nodes[i as usize];
            if v > 0 {
                stack.extend((1..=8).map(|k| v as u32 + k));
            } else {
                out.push(i);
            }
        }
        out
    }

    /// The state queued for `node` in any segment.
    pub fn queued(&self, node: u32) -> Vec<State> {
        self.ring
            .iter()
            .filter_map(|s| s.get(&node).copied())
            .collect()
    }

    fn alloc_probe(&mut self, node: u32) -> Option<u32> {
        let p = self.free_probes.pop()?;
        let (lo, size, depth) = self.cube(node);
        self.probes[p as usize] = Some(OctreeProbe {
            position: lo + Vec3::splat(size * 0.5),
            depth,
        });
        Some(p)
    }

    fn free_probe_of(&mut self, node: u32) {
        let v = self.nodes[node as usize];
        if v < 0 {
            let p = !v as u32;
            self.probes[p as usize] = None;
            self.free_probes.push(p);
            self.nodes[node as usize] = 0;
        }
    }

    /// One frame: the memory update, then the light update. `moved` holds the boxes of the
    /// geometry that changed this frame (old and new bounds); `hit_fraction(lo, size, depth)`
    /// is the share of a probe's surfels that land inside its cube.
    pub fn frame(&mut self, moved: &[(Vec3, Vec3)], hit_fraction: impl Fn(Vec3, f32, u32) -> f32) {
        // Memory update: pull segment origin; L items go to origin + 1 (lit this frame), M
        // items to origin + 2 (next frame's memory update).
        let pulled = std::mem::take(&mut self.ring[self.origin]);
        for (node, state) in pulled {
            debug_assert!(state.is_memory());
            self.memory_update(node, state);
        }
        // Light update: pull origin + 1; M items to origin + 2, L items to origin + 3 =
        // origin (next frame's light segment, (origin + 2) + 1).
        let pulled = std::mem::take(&mut self.ring[(self.origin + 1) % 3]);
        for (node, state) in pulled {
            debug_assert!(!state.is_memory());
            self.light_update(node, state, moved, &hit_fraction);
        }
        self.origin = (self.origin + 2) % 3;
    }

    fn memory_update(&mut self, node: u32, state: State) {
        let v = self.nodes[node as usize];
        match state {
            State::M0 => {}
            State::M1 => {
                if v != 0 {
                    return;
                }
                match self.alloc_probe(node) {
                    Some(p) => {
                        self.nodes[node as usize] = !(p as i32);
                        self.push(1, node, State::L1);
                    }
                    None => self.push(1, node, State::L3),
                }
            }
            State::M2 => {
                self.free_probe_of(node);
                if let Some(parent) = self.parent(node) {
                    self.push(2, parent, State::M4);
                }
                // Orphan fix: the freed leaf keeps watching for moving geometry.
                self.push(1, node, State::L3);
            }
            State::M3 => {
                if v >= 0 {
                    return;
                }
                let Some(cluster) = self.free_clusters.pop() else {
                    self.push(1, node, State::L2);
                    return;
                };
                // Link the cluster: meta first (its parent), then the parent's word.
                self.nodes[cluster as usize] = !(node as i32);
                self.nodes[node as usize] = cluster as i32;
                let mut made = Vec::new();
                for k in 1..=8 {
                    let child = cluster + k;
                    match self.alloc_probe(child) {
                        Some(p) => made.push((child, p)),
                        None => break,
                    }
                }
                if made.len() < 8 {
                    // Undo: the node keeps its probe and stays a leaf.
                    for (_, p) in made {
                        self.probes[p as usize] = None;
                        self.free_probes.push(p);
                    }
                    self.nodes[node as usize] = v;
                    self.nodes[cluster as usize] = 0;
                    self.free_clusters.push(cluster);
                    self.push(1, node, State::L2);
                    return;
                }
                let own = !v as u32;
                self.probes[own as usize] = None;
                self.free_probes.push(own);
                for (child, p) in made {
                    self.nodes[child as usize] = !(p as i32);
                    self.push(1, child, State::L1);
                }
            }
            State::M4 => {
                if v <= 0 {
                    return;
                }
                let cluster = v as u32;
                if (1..=8).any(|k| self.nodes[(cluster + k) as usize] != 0) {
                    return;
                }
                self.nodes[cluster as usize] = 0;
                self.free_clusters.push(cluster);
                self.nodes[node as usize] = 0;
                for k in 1..=8 {
                    self.push(1, cluster + k, State::L0);
                }
                if let Some(parent) = self.parent(node) {
                    self.push(2, parent, State::M4);
                }
                // Collapse fix: the parent asks for a probe again and does not split again
                // until geometry moves through it.
                self.no_split.insert(node);
                self.push(2, node, State::M1);
            }
            _ => unreachable!("light state {state:?} in the memory segment"),
        }
    }

    fn light_update(
        &mut self,
        node: u32,
        state: State,
        moved: &[(Vec3, Vec3)],
        hit_fraction: &impl Fn(Vec3, f32, u32) -> f32,
    ) {
        if state == State::L0 {
            return;
        }
        let v = self.nodes[node as usize];
        if v > 0 {
            // Became a parent: its children carry on.
            return;
        }
        let (lo, size, depth) = self.cube(node);
        let mut state = state;
        if moved
            .iter()
            .any(|&b| overlaps((lo, lo + Vec3::splat(size)), b))
        {
            self.no_split.remove(&node);
            if v == 0 {
                self.push(2, node, State::M1);
                return;
            }
            state = State::L1;
        }
        match state {
            State::L1 if v < 0 => {
                let f = hit_fraction(lo, size, depth);
                if f < self.rule.f_lower {
                    self.push(2, node, State::M2);
                } else if f >= self.rule.f_upper
                    && depth < self.rule.max_depth
                    && !self.no_split.contains(&node)
                {
                    self.push(2, node, State::M3);
                    if let Some(parent) = self.parent(node) {
                        self.push(2, parent, State::M0);
                    }
                } else {
                    self.push(0, node, State::L2);
                }
            }
            State::L1 | State::L2 | State::L3 => {
                let next = if v < 0 { State::L2 } else { State::L3 };
                self.push(0, node, next);
            }
            _ => unreachable!("memory state {state:?} in the light segment"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tree(depth: u32, clusters: usize, probes: u32) -> ProbeOctree {
        ProbeOctree::new(
            1 + 9 * clusters,
            probes,
            Vec3::ZERO,
            8.0,
            OctreeRule {
                max_depth: depth,
                ..Default::default()
            },
        )
    }

    /// Every invariant of the encoding: allocated clusters point back at parents that point
    /// at them, probes belong to exactly one leaf, free lists and allocations are disjoint.
    fn check(t: &ProbeOctree) {
        let mut probe_owner = vec![None; t.probes.len()];
        for leaf in t.leaves() {
            let v = t.nodes[leaf as usize];
            if v < 0 {
                let p = !v as usize;
                assert!(probe_owner[p].is_none(), "probe {p} twice");
                probe_owner[p] = Some(leaf);
                let (lo, size, depth) = t.cube(leaf);
                let probe = t.probes[p].expect("allocated");
                assert_eq!(probe.depth, depth);
                assert_eq!(probe.position, lo + Vec3::splat(size * 0.5));
            }
        }
        assert_eq!(
            probe_owner.iter().flatten().count(),
            t.probe_count(),
            "every allocated probe is a reachable leaf's"
        );
        for m in (1..t.nodes.len())
            .step_by(9)
            .filter(|m| m + 9 <= t.nodes.len())
        {
            let meta = t.nodes[m];
            if meta < 0 {
                assert_eq!(t.nodes[!meta as usize], m as i32, "cluster {m}'s parent");
                assert!(!t.free_clusters.contains(&(m as u32)));
            } else {
                assert!(t.free_clusters.contains(&(m as u32)), "cluster {m} lost");
            }
        }
    }

    #[test]
    fn full_hit_fractions_grow_a_full_tree_one_level_per_frame() {
        // f = 1 everywhere: the root gets a probe, splits, its children split, down to depth
        // 2: 64 leaves with a probe each (004's maximum for depth 2), then nothing changes.
        let mut t = tree(2, 9, 100);
        let mut counts = Vec::new();
        for _ in 0..8 {
            t.frame(&[], |_, _, _| 1.0);
            check(&t);
            counts.push(t.probe_count());
        }
        assert_eq!(counts, [1, 8, 64, 64, 64, 64, 64, 64]);
        assert_eq!(t.leaves().len(), 64);
        assert!(t.probes().all(|p| p.depth == 2));
        // Positions: the cell centres of a 4^3 grid over the cube (edge 8, cells of 2).
        let mut xs: Vec<f32> = t.probes().map(|p| p.position.x).collect();
        xs.sort_by(f32::total_cmp);
        xs.dedup();
        assert_eq!(xs, [1.0, 3.0, 5.0, 7.0]);
    }

    #[test]
    fn the_incomplete_tail_is_never_allocated_and_failures_keep_the_probe() {
        // A buffer of 1 + 9 + 5 words holds one cluster: the root splits once; its children
        // cannot split (no cluster left) and keep their probes (M3 failure -> L2).
        let mut t = ProbeOctree::new(15, 100, Vec3::ZERO, 8.0, OctreeRule::default());
        for _ in 0..10 {
            t.frame(&[], |_, _, _| 1.0);
            check(&t);
        }
        assert_eq!(t.probe_count(), 8);
        assert!(t.nodes[10..].iter().all(|&w| w == 0));
        // Too few probes for a split's 8 children: the split is undone, the root keeps its.
        let mut t = tree(2, 9, 5);
        for _ in 0..6 {
            t.frame(&[], |_, _, _| 1.0);
            check(&t);
        }
        assert_eq!(t.probe_count(), 1);
        assert!(t.nodes[0] < 0);
    }

    #[test]
    fn a_freed_leaf_is_not_orphaned() {
        // Grow to depth 1 (8 children), then the child in slot 0 sees little (f = 0.1) while
        // its siblings see enough: it frees its probe; its parent keeps the cluster (M4 finds
        // probes in the siblings). Later geometry moves through the freed child's cube: the
        // child must get a probe again, which needs it to still be in the leaf ring (004's
        // M2 pushes only the parent, and the leaf would never be visited again).
        let mut t = tree(1, 9, 100);
        let f = |lo: Vec3, _: f32, depth: u32| match depth {
            0 => 1.0,
            _ if lo == Vec3::ZERO => 0.1,
            _ => 0.4,
        };
        for _ in 0..8 {
            t.frame(&[], f);
            check(&t);
        }
        let child = t.nodes[0] as u32 + 1;
        assert_eq!(t.cube(child), (Vec3::ZERO, 4.0, 1));
        assert_eq!(t.nodes[child as usize], 0, "slot 0 freed its probe");
        assert_eq!(t.probe_count(), 7);
        assert!(t.nodes[0] > 0, "the parent kept its cluster");
        assert_eq!(t.queued(child), [State::L3], "still watched");
        // Geometry moves through the freed cube: a probe comes back.
        t.frame(&[(Vec3::splat(1.0), Vec3::splat(2.0))], |_, _, _| 0.4);
        t.frame(&[], |_, _, _| 0.4);
        check(&t);
        assert!(
            t.nodes[child as usize] < 0,
            "the freed leaf got a probe again"
        );
        assert_eq!(t.probe_count(), 8);
    }

    #[test]
    fn a_split_whose_children_all_free_does_not_leave_the_region_without_probes() {
        // The root sees a lot (f = 0.6) but each child, its lattice confined to a smaller cube,
        // sees little (f = 0.1): the children free their probes and the parent collapses.
        // In 004 the collapsed root stays probe-less for good; here it asks for a probe again
        // and keeps it without splitting again: one probe, stable.
        let mut t = tree(2, 9, 100);
        let f = |_: Vec3, _: f32, depth: u32| if depth == 0 { 0.6 } else { 0.1 };
        let mut counts = Vec::new();
        for _ in 0..16 {
            t.frame(&[], f);
            check(&t);
            counts.push(t.probe_count());
        }
        assert_eq!(counts[..2], [1, 8], "{counts:?}");
        assert_eq!(counts[10..], [1; 6], "{counts:?}");
        assert!(t.nodes[0] < 0, "the root holds the probe");
        // Geometry moving through it lifts the no-split mark: it splits again.
        t.frame(&[(Vec3::splat(3.0), Vec3::splat(5.0))], f);
        t.frame(&[], f);
        check(&t);
        assert!(t.nodes[0] > 0, "split again after the geometry moved");
    }

    #[test]
    fn low_hit_fractions_free_everything_and_the_root_still_watches() {
        let mut t = tree(2, 9, 100);
        for _ in 0..3 {
            t.frame(&[], |_, _, _| 0.1);
            check(&t);
        }
        assert_eq!(t.probe_count(), 0);
        assert_eq!(t.queued(0), [State::L3]);
    }
}
