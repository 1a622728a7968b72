//! The adaptive probe octree of `004` §3.1-§3.2 on the CPU: the buffer encoding, allocation
//! and the per-leaf state machine (memory update M0-M4, light update L0-L3) over the
//! three-segment leaf ring. It is the specification the GPU version (`probes-octree`,
//! octree.wgsl) is tested against word for word; hit counts come from the caller (scripted in
//! tests, surfel rays on the GPU).
//!
//! Encoding (`004` §3.1.1): one `i32` buffer. Index 0 is the root; after it, clusters of 9
//! words: a meta word (0 free, `< 0`: allocated, `!meta` = parent node) and 8 sibling nodes.
//! A node is 0 (leaf without probe), `< 0` (leaf with probe `!node`) or `> 0` (parent; the
//! value is its children's meta index, children at `value + 1 ..= value + 8`). Child slot `s`
//! covers the octant with bit 0, 1, 2 of `s` set = upper half in x, y, z. A tail shorter than 9
//! words is never allocated.
//!
//! Every step is independent of the order in which a parallel machine visits the leaves, so
//! that the GPU reaches the same tree bit for bit:
//! - a ring segment holds one state per leaf; when two pushes meet, the higher
//!   [`State::code`] wins (M0 and L0 override, then the lower-numbered state);
//! - the memory update runs in four steps: M2 frees probes; M4 decides on the tree after
//!   that which clusters to free, then frees them; M1 and M3 allocate from the free lists as
//!   they were at the start of the update, in node order by prefix sums of their demands (a
//!   request succeeds when it and all requests before it fit, so a request never takes what
//!   an earlier one needed); last, the freed probes and clusters go back on their free lists
//!   in node order. Nothing freed in an update is handed out again in the same update (a
//!   cluster freed by M4 would otherwise get new children whose L1 the L0 of the old ones
//!   overrides).
//!
//! Changes from `004`, each for a trap the notes name:
//! - **Allocation** pops free lists (clusters, probes) instead of scanning the buffer with
//!   compare-exchange (the cause of `004`'s depth-3 spikes).
//! - **Orphans.** M2 frees a leaf's probe and pushes only the parent (M4). If a sibling keeps
//!   its probe, M4 does nothing and the freed leaf was in no segment any more: geometry moving
//!   into it later could never give it a probe. Here M2 also pushes the leaf as L3.
//! - **Collapse.** A parent split for a high hit fraction whose children all free their probes
//!   (their lattices, confined to smaller cubes, hit less) collapsed to a probe-less L3 for
//!   good. Here a collapsed parent asks for a probe again (M1) and is not split again until
//!   geometry moves through it.
//! - **Stale requests.** An M1 for a leaf whose cluster was freed meanwhile is dropped.

use glam::Vec3;
use std::collections::BTreeMap;

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
    const ALL: [State; 9] = [
        State::L3,
        State::L2,
        State::L1,
        State::L0,
        State::M4,
        State::M3,
        State::M2,
        State::M1,
        State::M0,
    ];

    /// The state's word in the GPU's ring (0: no state). Of two states pushed for one leaf
    /// into one segment the higher code stays: M0 and L0 override, then the lower-numbered
    /// state. A segment holds memory or light states, never both.
    pub fn code(self) -> u32 {
        Self::ALL.iter().position(|&s| s == self).unwrap_or(0) as u32 + 1
    }

    /// The state of a ring word (None for 0 or an unknown word).
    pub fn from_code(code: u32) -> Option<State> {
        Self::ALL.get((code as usize).checked_sub(1)?).copied()
    }

    fn is_memory(self) -> bool {
        matches!(
            self,
            State::M0 | State::M1 | State::M2 | State::M3 | State::M4
        )
    }
}

/// The split/free rule: a probe's hit count `h` out of `surfels` (the surfels it places
/// inside its cube) frees it when `h / surfels < f_lower` and splits its leaf when
/// `h / surfels >= f_upper` above `max_depth`. Decided in integers ([`Self::free_below`],
/// [`Self::split_from`]) so that every adapter decides alike.
///
/// `min_depth` keeps the coarse levels populated whatever the hit fractions: a leaf above it
/// always splits, a leaf at it or above never frees its probe, so the tree is complete down
/// to `min_depth` and only the refinement below it follows `004`'s rule. 0 is `004`'s rule
/// (every level adaptive, the root's probe included).
#[derive(Clone, Copy, Debug)]
pub struct OctreeRule {
    /// Deepest level (root 0).
    pub max_depth: u32,
    /// Levels complete down to this depth (0: `004`, none).
    pub min_depth: u32,
    /// Surfels (rays) per probe.
    pub surfels: u32,
    /// A leaf frees its probe below this hit fraction (`004`: 1/4).
    pub f_lower: f32,
    /// A leaf splits at or above this hit fraction (`004`: 1/2).
    pub f_upper: f32,
}

/// What a leaf that measured its hit count does next.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Decision {
    /// Free its probe (M2).
    Free,
    /// Split (M3, its parent M0).
    Split,
    /// Keep its probe and light it (L2).
    Keep,
}

impl Default for OctreeRule {
    /// `004`'s rule at depth 2.
    fn default() -> Self {
        OctreeRule {
            max_depth: 2,
            min_depth: 0,
            surfels: 64,
            f_lower: 0.25,
            f_upper: 0.5,
        }
    }
}

impl OctreeRule {
    /// Hit counts below this free the probe (`h < f_lower x surfels`).
    pub fn free_below(&self) -> u32 {
        (self.f_lower as f64 * self.surfels as f64).ceil() as u32
    }

    /// Hit counts from this on split the leaf (`h >= f_upper x surfels`).
    pub fn split_from(&self) -> u32 {
        (self.f_upper as f64 * self.surfels as f64).ceil() as u32
    }

    /// The decision of a leaf at `depth` whose probe counted `hits` inside its cube;
    /// `no_split`: a collapsed parent that may not split again yet. Integers only: the GPU's
    /// `light_decide` is the same expression.
    pub fn decide(&self, hits: u32, depth: u32, no_split: bool) -> Decision {
        let may_split = depth < self.max_depth && !no_split;
        if may_split && depth < self.min_depth {
            Decision::Split
        } else if hits < self.free_below() && !(self.min_depth > 0 && depth <= self.min_depth) {
            Decision::Free
        } else if may_split && hits >= self.split_from() {
            Decision::Split
        } else {
            Decision::Keep
        }
    }

    /// Words of a tree buffer and probes that hold the full tree of `max_depth` levels: every
    /// parent's cluster, and `8^max_depth` leaves plus the `8^(max_depth - 1)` probes their
    /// parents hold while they allocate their children's (a split returns its own probe at
    /// the end of the update, so a whole level splitting at once needs both).
    pub fn full_capacity(&self) -> (usize, u32) {
        let leaves = 8u64.pow(self.max_depth);
        let clusters = (leaves - 1) / 7;
        (
            1 + 9 * clusters as usize,
            (leaves + leaves / 8).max(1) as u32,
        )
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

impl OctreeProbe {
    /// The probe's record in the GPU's probe-info buffer (`ProbeInfo` of `octree_params.wgsl`):
    /// position and depth, or `(0, 0, 0, -1)` for a free slot.
    pub fn gpu_info(probe: Option<&OctreeProbe>) -> [f32; 4] {
        probe.map_or([0.0, 0.0, 0.0, -1.0], |p| {
            p.position.extend(p.depth as f32).to_array()
        })
    }
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
    /// Per node: a collapsed parent that may not split again until geometry moves through it.
    no_split: Vec<bool>,
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
    /// the whole 9-word groups after the root) with room for `probe_capacity` probes.
    ///
    /// The levels above `rule.min_depth` split whatever their probes see, so they are built
    /// here, by the frames that would build them (hit counts do not enter them): the first
    /// frame allocates the probes of depth `min_depth` and the tree reaches `max_depth`
    /// `max_depth - min_depth` frames later. With `min_depth` 0 (`004`) the root asks for a
    /// probe at the first frame (M1).
    pub fn new(len: usize, probe_capacity: u32, lo: Vec3, size: f32, rule: OctreeRule) -> Self {
        let mut tree = Self::seed(len, probe_capacity, lo, size, rule);
        for _ in 0..rule.min_depth.min(rule.max_depth) {
            tree.frame(&[], |_, _| 0);
        }
        tree
    }

    /// The tree before any frame: the root asking for a probe.
    fn seed(len: usize, probe_capacity: u32, lo: Vec3, size: f32, rule: OctreeRule) -> Self {
        let len = len.max(1);
        let clusters = (len - 1) / 9;
        let mut tree = ProbeOctree {
            nodes: vec![0; len],
            probes: vec![None; probe_capacity as usize],
            free_probes: (0..probe_capacity).rev().collect(),
            free_clusters: (0..clusters as u32).rev().map(|k| 1 + 9 * k).collect(),
            ring: Default::default(),
            origin: 0,
            no_split: vec![false; len],
            lo,
            size,
            rule,
        };
        tree.push(0, 0, State::M1);
        tree
    }

    /// Pushes `state` for `node` into segment `origin + offset`; the higher code wins.
    fn push(&mut self, offset: usize, node: u32, state: State) {
        let segment = &mut self.ring[(self.origin + offset) % 3];
        let old = segment.get(&node).map_or(0, |s| s.code());
        if state.code() > old {
            segment.insert(node, state);
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

    /// The probe in slot `p`, if allocated.
    pub fn probe(&self, p: u32) -> Option<&OctreeProbe> {
        self.probes.get(p as usize)?.as_ref()
    }

    /// Per probe slot its GPU record ([`OctreeProbe::gpu_info`]).
    pub fn probe_info(&self) -> Vec<[f32; 4]> {
        self.probes
            .iter()
            .map(|p| OctreeProbe::gpu_info(p.as_ref()))
            .collect()
    }

    /// The free lists as stacks (the next pop is the last element): probe slots, clusters.
    pub fn free_lists(&self) -> (&[u32], &[u32]) {
        (&self.free_probes, &self.free_clusters)
    }

    /// The ring as the GPU holds it: per segment `k` and node `i`, word `k x len + i` is the
    /// [`State::code`] queued (0 none); and the pull origin of the next frame.
    pub fn ring_codes(&self) -> (Vec<u32>, usize) {
        let len = self.nodes.len();
        let mut codes = vec![0; 3 * len];
        for (k, segment) in self.ring.iter().enumerate() {
            for (&node, state) in segment {
                codes[k * len + node as usize] = state.code();
            }
        }
        (codes, self.origin)
    }

    /// Per node whether it is a collapsed parent that may not split again yet.
    pub fn no_split(&self) -> &[bool] {
        &self.no_split
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

    /// Gives leaf `node` probe slot `p`.
    fn set_probe(&mut self, node: u32, p: u32) {
        let (lo, size, depth) = self.cube(node);
        self.probes[p as usize] = Some(OctreeProbe {
            position: lo + Vec3::splat(size * 0.5),
            depth,
        });
        self.nodes[node as usize] = !(p as i32);
    }

    /// Takes the probe of leaf `node` (its slot is returned to the free list by the caller).
    fn take_probe(&mut self, node: u32) -> Option<u32> {
        let v = self.nodes[node as usize];
        (v < 0).then(|| {
            let p = !v as u32;
            self.probes[p as usize] = None;
            self.nodes[node as usize] = 0;
            p
        })
    }

    /// Whether `node` still belongs to the tree (the root, or its cluster is allocated).
    fn in_live_cluster(&self, node: u32) -> bool {
        node == 0 || self.nodes[Self::meta_of(node) as usize] != 0
    }

    /// One frame: the memory update, then the light update. `moved` holds the boxes of the
    /// geometry that changed this frame (old and new bounds); `hits(slot, probe)` is the
    /// number of the probe's surfels (of [`OctreeRule::surfels`]) that land inside its cube.
    pub fn frame(&mut self, moved: &[(Vec3, Vec3)], hits: impl Fn(u32, &OctreeProbe) -> u32) {
        // Memory update: pull segment origin; L items go to origin + 1 (lit this frame), M
        // items to origin + 2 (next frame's memory update).
        self.memory_update();
        // Light update: pull origin + 1; M items to origin + 2, L items to origin + 3 =
        // origin (next frame's light segment, (origin + 2) + 1).
        self.light_update(moved, &hits);
        self.origin = (self.origin + 2) % 3;
    }

    fn memory_update(&mut self) {
        let pulled = std::mem::take(&mut self.ring[self.origin]);
        debug_assert!(pulled.values().all(|s| s.is_memory()));
        let of = |state: State| {
            pulled
                .iter()
                .filter(move |(_, &s)| s == state)
                .map(|(&node, _)| node)
        };
        // (node, slot) of every probe freed in this update.
        let mut freed_probes = Vec::new();
        // 1. M2: free the probe.
        for node in of(State::M2) {
            if let Some(p) = self.take_probe(node) {
                freed_probes.push((node, p));
            }
            if let Some(parent) = self.parent(node) {
                self.push(2, parent, State::M4);
            }
            // Orphan fix: the freed leaf keeps watching for moving geometry.
            self.push(1, node, State::L3);
        }
        // 2. M4: which clusters to free is decided on the tree after step 1, then applied.
        let collapsing: Vec<u32> = of(State::M4)
            .filter(|&node| {
                let v = self.nodes[node as usize];
                v > 0 && (1..=8).all(|k| self.nodes[(v + k) as usize] == 0)
            })
            .collect();
        let mut freed_clusters = Vec::new();
        for &node in &collapsing {
            let cluster = self.nodes[node as usize] as u32;
            self.nodes[cluster as usize] = 0;
            self.nodes[node as usize] = 0;
            freed_clusters.push(cluster);
            for k in 1..=8 {
                self.push(1, cluster + k, State::L0);
            }
            if let Some(parent) = self.parent(node) {
                self.push(2, parent, State::M4);
            }
            // Collapse fix: the parent asks for a probe again and does not split again
            // until geometry moves through it.
            self.no_split[node as usize] = true;
            self.push(2, node, State::M1);
        }
        // 3. M1 and M3 allocate in node order from the free lists as they were before this
        // update: a request succeeds when it and all before it fit.
        let (mut clusters_used, mut probes_used, mut fits) = (0, 0, true);
        for (&node, &state) in &pulled {
            let v = self.nodes[node as usize];
            let (clusters, probes) = match state {
                State::M1 if v == 0 && self.in_live_cluster(node) => (0, 1),
                State::M3 if v < 0 => (1, 8),
                _ => continue,
            };
            fits = fits
                && clusters_used + clusters <= self.free_clusters.len()
                && probes_used + probes <= self.free_probes.len();
            if !fits {
                // M1 keeps watching; M3 keeps its probe.
                let next = if state == State::M1 {
                    State::L3
                } else {
                    State::L2
                };
                self.push(1, node, next);
                continue;
            }
            let probe = |tree: &Self, j: usize| {
                tree.free_probes[tree.free_probes.len() - 1 - probes_used - j]
            };
            if state == State::M1 {
                let p = probe(self, 0);
                self.set_probe(node, p);
                self.push(1, node, State::L1);
            } else {
                let cluster = self.free_clusters[self.free_clusters.len() - 1 - clusters_used];
                // Link the cluster: meta first (its parent), then the parent's word.
                self.nodes[cluster as usize] = !(node as i32);
                self.nodes[node as usize] = cluster as i32;
                for k in 1..=8 {
                    let child = cluster + k;
                    let p = probe(self, k as usize - 1);
                    self.no_split[child as usize] = false;
                    self.set_probe(child, p);
                    self.push(1, child, State::L1);
                }
                let own = !v as u32;
                self.probes[own as usize] = None;
                freed_probes.push((node, own));
            }
            clusters_used += clusters;
            probes_used += probes;
        }
        self.free_clusters
            .truncate(self.free_clusters.len() - clusters_used);
        self.free_probes
            .truncate(self.free_probes.len() - probes_used);
        // 4. What this update freed goes back on the free lists, in node order.
        freed_probes.sort_unstable();
        self.free_probes
            .extend(freed_probes.into_iter().map(|(_, p)| p));
        self.free_clusters.extend(freed_clusters);
    }

    fn light_update(&mut self, moved: &[(Vec3, Vec3)], hits: &impl Fn(u32, &OctreeProbe) -> u32) {
        let pulled = std::mem::take(&mut self.ring[(self.origin + 1) % 3]);
        for (node, state) in pulled {
            debug_assert!(!state.is_memory());
            if state == State::L0 {
                continue;
            }
            let v = self.nodes[node as usize];
            if v > 0 {
                // Became a parent: its children carry on.
                continue;
            }
            let (lo, size, depth) = self.cube(node);
            let mut state = state;
            if moved
                .iter()
                .any(|&b| overlaps((lo, lo + Vec3::splat(size)), b))
            {
                self.no_split[node as usize] = false;
                if v == 0 {
                    self.push(2, node, State::M1);
                    continue;
                }
                state = State::L1;
            }
            if state == State::L1 && v < 0 {
                let p = !v as u32;
                let h = self.probes[p as usize].map_or(0, |probe| hits(p, &probe));
                match self.rule.decide(h, depth, self.no_split[node as usize]) {
                    Decision::Free => self.push(2, node, State::M2),
                    Decision::Split => {
                        self.push(2, node, State::M3);
                        if let Some(parent) = self.parent(node) {
                            self.push(2, parent, State::M0);
                        }
                    }
                    Decision::Keep => self.push(0, node, State::L2),
                }
            } else {
                let next = if v < 0 { State::L2 } else { State::L3 };
                self.push(0, node, next);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Hits of a probe of 64 surfels with hit fraction `f`.
    fn hits(f: f32) -> u32 {
        (f * 64.0) as u32
    }

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
                assert!(t.in_live_cluster(m as u32 + 1));
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
            t.frame(&[], |_, _| 64);
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
            t.frame(&[], |_, _| 64);
            check(&t);
        }
        assert_eq!(t.probe_count(), 8);
        assert!(t.nodes[10..].iter().all(|&w| w == 0));
        // Too few probes for a split's 8 children: the split is undone, the root keeps its.
        let mut t = tree(2, 9, 5);
        for _ in 0..6 {
            t.frame(&[], |_, _| 64);
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
        let f = |_, p: &OctreeProbe| match p.depth {
            0 => 64,
            _ if p.position == Vec3::splat(2.0) => hits(0.1),
            _ => hits(0.4),
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
        t.frame(&[(Vec3::splat(1.0), Vec3::splat(2.0))], |_, _| hits(0.4));
        t.frame(&[], |_, _| hits(0.4));
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
        let f = |_, p: &OctreeProbe| if p.depth == 0 { hits(0.6) } else { hits(0.1) };
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
    fn min_depth_0_is_004s_rule_and_min_depth_overrides_only_the_coarse_levels() {
        // Every hit count at depths 0..=3: min_depth 0 decides as 004 (free below 16 hits of
        // 64, split from 32 above max_depth); min_depth 2 splits depths 0 and 1 whatever the
        // count, keeps the probes of depths 1 and 2, and decides depth 3 as 004.
        let rule = |min_depth| OctreeRule {
            max_depth: 3,
            min_depth,
            ..Default::default()
        };
        for h in 0..=64 {
            for depth in 0..=3 {
                let d004 = if h < 16 {
                    Decision::Free
                } else if h >= 32 && depth < 3 {
                    Decision::Split
                } else {
                    Decision::Keep
                };
                assert_eq!(rule(0).decide(h, depth, false), d004, "h {h} depth {depth}");
                let want = match depth {
                    0 | 1 => Decision::Split,
                    2 if d004 == Decision::Free => Decision::Keep,
                    _ => d004,
                };
                assert_eq!(rule(2).decide(h, depth, false), want, "h {h} depth {depth}");
                // A collapsed parent does not split again, whatever the level.
                assert_ne!(rule(2).decide(h, depth, true), Decision::Split);
            }
        }
    }

    #[test]
    fn min_depth_completes_the_coarse_levels_whatever_the_hit_fractions() {
        // No hits at all (an open scene's coarse cubes): with 004's rule everything is freed
        // (the test below); with min_depth 2 the tree is built down to depth 1 before the
        // first frame, which allocates the 64 depth-2 leaves, and keeps their probes, in a
        // buffer of the full tree's size.
        let rule = OctreeRule {
            max_depth: 3,
            min_depth: 2,
            ..Default::default()
        };
        let (len, capacity) = rule.full_capacity();
        let mut t = ProbeOctree::new(len, capacity, Vec3::ZERO, 8.0, rule);
        let mut counts = Vec::new();
        for _ in 0..8 {
            t.frame(&[], |_, _| 0);
            check(&t);
            counts.push(t.probe_count());
        }
        assert_eq!(counts, [64, 64, 64, 64, 64, 64, 64, 64]);
        assert!(t.probes().all(|p| p.depth == 2));
        // Full hit fractions: the whole level 2 splits in one update (the second frame); the
        // full capacity holds the 512 new probes and the 64 the splitting leaves hold until
        // its end.
        let mut t = ProbeOctree::new(len, capacity, Vec3::ZERO, 8.0, rule);
        let mut counts = Vec::new();
        for _ in 0..4 {
            t.frame(&[], |_, _| 64);
            check(&t);
            counts.push(t.probe_count());
        }
        assert_eq!(counts, [64, 512, 512, 512]);
    }

    #[test]
    fn below_min_depth_004s_rule_refines_frees_and_collapses() {
        // min_depth 1, max_depth 2, cube of edge 8. Depth 1: the octant at the origin sees
        // much (f = 0.6) and splits; the others see little (f = 0.1) and keep their probes.
        // Depth 2 inside the split octant: the child at the origin keeps its probe (f = 0.3),
        // the other seven free theirs (f = 0.1). Then the kept child drops to f = 0.1 once
        // geometry moves through it: all eight are free, the octant collapses and asks for
        // a probe again, which it keeps without splitting.
        let mut t = tree(2, 9, 100);
        t.rule.min_depth = 1;
        let f = |low: bool| {
            move |_, p: &OctreeProbe| match (p.depth, p.position) {
                (0, _) => 0,
                (1, q) if q == Vec3::splat(2.0) => hits(0.6),
                (2, q) if q == Vec3::splat(1.0) && !low => hits(0.3),
                _ => hits(0.1),
            }
        };
        for _ in 0..8 {
            t.frame(&[], f(false));
            check(&t);
        }
        let octant = t.nodes[0] as u32 + 1;
        assert!(t.nodes[octant as usize] > 0, "the busy octant split");
        assert_eq!(t.probe_count(), 7 + 1);
        assert_eq!(t.probes().filter(|p| p.depth == 1).count(), 7);
        let kept: Vec<_> = t.probes().filter(|p| p.depth == 2).collect();
        assert_eq!(kept[0].position, Vec3::splat(1.0));
        // Geometry moves through the kept child: it re-decides at f = 0.1 and frees.
        t.frame(&[(Vec3::splat(0.5), Vec3::splat(1.0))], f(true));
        for _ in 0..8 {
            t.frame(&[], f(true));
            check(&t);
        }
        assert!(
            t.nodes[octant as usize] < 0,
            "collapsed, with a probe again"
        );
        assert_eq!(t.probe_count(), 8);
        assert!(t.probes().all(|p| p.depth == 1));
    }

    #[test]
    fn low_hit_fractions_free_everything_and_the_root_still_watches() {
        let mut t = tree(2, 9, 100);
        for _ in 0..3 {
            t.frame(&[], |_, _| hits(0.1));
            check(&t);
        }
        assert_eq!(t.probe_count(), 0);
        assert_eq!(t.queued(0), [State::L3]);
    }
}
