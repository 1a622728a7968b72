//! Rays without ray-tracing hardware: a binary BVH over world triangles, built on the CPU with
//! binned SAH, flattened depth-first into one storage buffer and traversed in WGSL
//! (`bvh.wgsl`, the module `gi/probes/bvh`) with the same steps as [`Bvh::closest`] here.
//!
//! Layout ([`GpuNode`], two `vec4` per node): bounds, and in the `w`s either (right child, 0)
//! for an inner node, whose left child is the next node, or (first triangle, count) for a leaf.
//! Triangles ([`GpuTri`], 64 bytes) are stored in leaf order as the Möller-Trumbore test
//! wants them: a vertex and two edges, with the packed RGBA8 albedo in the first `w` (the
//! per-triangle albedo of [`crate::voxel::scene_triangles`]) and the emission in the last.
//!
//! Several BVHs share one node and one triangle buffer ([`SceneBvh`], a two-level BVH: the
//! static objects' BVH in world space, and one BVH per animated object in its model space,
//! all built once; each frame only the animated objects' transforms are uploaded):
//! [`Bvh::flatten_at`] writes a BVH's indices for its place in the buffers, and the shader
//! traverses each from its root, the animated ones with the ray in the object's space.

use crate::voxel::VoxelTriangle;
use glam::Vec3;

/// Most triangles in a leaf.
const LEAF_MAX: usize = 4;
/// SAH bins per axis.
const BINS: usize = 12;
/// Deepest node: the WGSL traversal stack holds `MAX_DEPTH + 1` entries.
pub const MAX_DEPTH: usize = 40;
/// Direction components smaller than this are replaced by it (with their sign) before the
/// reciprocal, so that the slab test never divides by zero on any adapter.
const MIN_DIR: f32 = 1e-8;

/// One BVH node as the shader reads it.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuNode {
    /// Lower corner.
    pub min: [f32; 3],
    /// Inner node: index of the right child; leaf: first triangle.
    pub right_or_first: u32,
    /// Upper corner.
    pub max: [f32; 3],
    /// 0 for an inner node, else the leaf's triangle count.
    pub tri_count: u32,
}

/// One triangle as the shader reads it (`BvhTri` in `bvh.wgsl`), laid out for the
/// Möller-Trumbore test: a vertex and the two edges from it.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuTri {
    /// Vertex 0.
    pub p0: [f32; 3],
    /// Linear albedo x 255 as RGBA8, red in the low byte.
    pub albedo: u32,
    /// Edge vertex 1 - vertex 0.
    pub e1: [f32; 3],
    /// Padding (WGSL aligns a `vec3<f32>` to 16 bytes).
    pub _pad1: u32,
    /// Edge vertex 2 - vertex 0.
    pub e2: [f32; 3],
    /// Padding.
    pub _pad2: u32,
    /// Emitted radiance (W/(m^2 sr)).
    pub emission: [f32; 3],
    /// Padding to the struct's 16-byte alignment.
    pub _pad3: u32,
}

/// A triangle prepared for intersection.
#[derive(Clone, Copy, Debug)]
pub struct BvhTri {
    /// Vertex 0.
    pub p0: Vec3,
    /// Edge 1 - 0.
    pub e1: Vec3,
    /// Edge 2 - 0.
    pub e2: Vec3,
    /// Linear albedo x 255.
    pub albedo: [u8; 3],
    /// Emitted radiance.
    pub emission: Vec3,
}

impl BvhTri {
    /// Möller-Trumbore, the reference's test (`reference/accel.rs`): (t, u, v) for a hit with
    /// t in (0, t_max).
    pub fn intersect(&self, o: Vec3, d: Vec3, t_max: f32) -> Option<(f32, f32, f32)> {
        let p = d.cross(self.e2);
        let det = self.e1.dot(p);
        if det.abs() < 1e-12 {
            return None;
        }
        let inv = 1.0 / det;
        let s = o - self.p0;
        let u = s.dot(p) * inv;
        if !(0.0..=1.0).contains(&u) {
            return None;
        }
        let q = s.cross(self.e1);
        let v = d.dot(q) * inv;
        if v < 0.0 || u + v > 1.0 {
            return None;
        }
        let t = self.e2.dot(q) * inv;
        (t > 0.0 && t < t_max).then_some((t, u, v))
    }

    /// Unit geometric normal (the winding's).
    pub fn normal(&self) -> Vec3 {
        self.e1.cross(self.e2).normalize_or_zero()
    }

    fn bounds(&self) -> (Vec3, Vec3) {
        let (b, c) = (self.p0 + self.e1, self.p0 + self.e2);
        (self.p0.min(b).min(c), self.p0.max(b).max(c))
    }

    fn centroid(&self) -> Vec3 {
        self.p0 + (self.e1 + self.e2) / 3.0
    }

    /// The GPU layout.
    pub fn to_gpu(&self) -> GpuTri {
        let albedo = self.albedo[0] as u32
            | (self.albedo[1] as u32) << 8
            | (self.albedo[2] as u32) << 16
            | 255 << 24;
        GpuTri {
            p0: self.p0.to_array(),
            albedo,
            e1: self.e1.to_array(),
            e2: self.e2.to_array(),
            emission: self.emission.to_array(),
            ..Default::default()
        }
    }
}

/// A closest hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BvhHit {
    /// Triangle index in [`Bvh::tris`] (leaf order).
    pub tri: u32,
    /// Distance along the (unit) direction.
    pub t: f32,
    /// Barycentric weight of vertex 1.
    pub u: f32,
    /// Barycentric weight of vertex 2.
    pub v: f32,
}

/// The work of traversals, as a counting shader counts it (`note_bvh` in `bvh.wgsl`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BvhWork {
    /// Nodes visited: popped from the stack with the ray entering their box.
    pub nodes: u64,
    /// Triangles tested (ray-triangle intersections computed).
    pub triangles: u64,
}

/// A BVH with its triangles in leaf order. Node indices are local (root 0).
#[derive(Clone, Debug, Default)]
pub struct Bvh {
    /// Depth-first nodes; empty for no triangles.
    pub nodes: Vec<GpuNode>,
    /// Triangles in leaf order.
    pub tris: Vec<BvhTri>,
}

struct Builder<'a> {
    tris: &'a [BvhTri],
    bounds: Vec<(Vec3, Vec3)>,
    centroids: Vec<Vec3>,
    order: Vec<u32>,
    nodes: Vec<GpuNode>,
}

fn area(lo: Vec3, hi: Vec3) -> f32 {
    let e = (hi - lo).max(Vec3::ZERO);
    e.x * e.y + e.y * e.z + e.z * e.x
}

impl Builder<'_> {
    fn range_bounds(&self, range: &[u32]) -> (Vec3, Vec3) {
        range.iter().fold((Vec3::MAX, Vec3::MIN), |(lo, hi), &i| {
            let (a, b) = self.bounds[i as usize];
            (lo.min(a), hi.max(b))
        })
    }

    /// Builds the node for `order[start..end]` at `depth`; returns its index.
    fn build(&mut self, start: usize, end: usize, depth: usize) -> usize {
        let (lo, hi) = self.range_bounds(&self.order[start..end]);
        // Padded a little so that rays grazing a face, or with a direction component
        // clamped to MIN_DIR, still enter the boxes of the triangles they hit.
        let pad = (hi - lo).max_element().max(1e-6) * 1e-5;
        let index = self.nodes.len();
        self.nodes.push(GpuNode {
            min: (lo - pad).to_array(),
            right_or_first: start as u32,
            max: (hi + pad).to_array(),
            tri_count: (end - start) as u32,
        });
        let count = end - start;
        if count <= 1 || depth >= MAX_DEPTH {
            return index;
        }
        let split = self.split(start, end);
        let Some(mid) = split else {
            return index;
        };
        self.build(start, mid, depth + 1);
        let right = self.build(mid, end, depth + 1);
        self.nodes[index].right_or_first = right as u32;
        self.nodes[index].tri_count = 0;
        index
    }

    /// Partitions `order[start..end]` by the cheapest binned SAH split; None to keep a leaf.
    fn split(&mut self, start: usize, end: usize) -> Option<usize> {
        let count = end - start;
        let range = &self.order[start..end];
        let (clo, chi) = range.iter().fold((Vec3::MAX, Vec3::MIN), |(lo, hi), &i| {
            let c = self.centroids[i as usize];
            (lo.min(c), hi.max(c))
        });
        let extent = chi - clo;
        let mut best: Option<(f32, usize, usize)> = None; // (cost, axis, last left bin)
        for axis in 0..3 {
            if extent[axis] <= 0.0 {
                continue;
            }
            let mut bins = [(Vec3::MAX, Vec3::MIN, 0u32); BINS];
            let bin_of = |c: Vec3| {
                (((c[axis] - clo[axis]) / extent[axis] * BINS as f32) as usize).min(BINS - 1)
            };
            for &i in range {
                let b = &mut bins[bin_of(self.centroids[i as usize])];
                let (lo, hi) = self.bounds[i as usize];
                b.0 = b.0.min(lo);
                b.1 = b.1.max(hi);
                b.2 += 1;
            }
            // Sweep from the right for suffix areas, then from the left.
            let mut right = [(0.0f32, 0u32); BINS];
            let (mut lo, mut hi, mut n) = (Vec3::MAX, Vec3::MIN, 0);
            for k in (1..BINS).rev() {
                lo = lo.min(bins[k].0);
                hi = hi.max(bins[k].1);
                n += bins[k].2;
                right[k] = (area(lo, hi), n);
            }
            let (mut lo, mut hi, mut n) = (Vec3::MAX, Vec3::MIN, 0);
            for k in 0..BINS - 1 {
                lo = lo.min(bins[k].0);
                hi = hi.max(bins[k].1);
                n += bins[k].2;
                let (ra, rn) = right[k + 1];
                if n == 0 || rn == 0 {
                    continue;
                }
                let cost = area(lo, hi) * n as f32 + ra * rn as f32;
                if best.is_none_or(|b| cost < b.0) {
                    best = Some((cost, axis, k));
                }
            }
        }
        let (lo, hi) = self.range_bounds(range);
        let leaf_cost = area(lo, hi) * count as f32;
        match best {
            Some((cost, axis, last)) if cost < leaf_cost || count > LEAF_MAX => {
                let centroids = &self.centroids;
                let slice = &mut self.order[start..end];
                let mut mid = 0;
                for k in 0..slice.len() {
                    // The binning rule above, so that both sides are non-empty.
                    let c = centroids[slice[k] as usize][axis];
                    let bin =
                        (((c - clo[axis]) / extent[axis] * BINS as f32) as usize).min(BINS - 1);
                    if bin <= last {
                        slice.swap(k, mid);
                        mid += 1;
                    }
                }
                (mid > 0 && mid < count).then_some(start + mid)
            }
            // All centroids equal: split in the middle if the leaf would be too big.
            None if count > LEAF_MAX => Some(start + count / 2),
            _ => None,
        }
    }
}

impl Bvh {
    /// Builds the BVH of `triangles`; degenerate ones (zero or non-finite area) are dropped
    /// as the reference drops them.
    pub fn build(triangles: &[VoxelTriangle]) -> Bvh {
        let tris: Vec<BvhTri> = triangles
            .iter()
            .filter_map(|t| {
                let [a, b, c] = t.positions;
                let (e1, e2) = (b - a, c - a);
                let area2 = e1.cross(e2).length();
                (area2 > 0.0 && area2.is_finite()).then_some(BvhTri {
                    p0: a,
                    e1,
                    e2,
                    albedo: t.albedo,
                    emission: t.emission,
                })
            })
            .collect();
        if tris.is_empty() {
            return Bvh::default();
        }
        let mut builder = Builder {
            tris: &tris,
            bounds: tris.iter().map(BvhTri::bounds).collect(),
            centroids: tris.iter().map(BvhTri::centroid).collect(),
            order: (0..tris.len() as u32).collect(),
            nodes: Vec::with_capacity(2 * tris.len()),
        };
        builder.build(0, tris.len(), 0);
        let ordered = builder
            .order
            .iter()
            .map(|&i| builder.tris[i as usize])
            .collect();
        Bvh {
            nodes: builder.nodes,
            tris: ordered,
        }
    }

    /// The nodes and triangles in GPU layout for a place in shared buffers that starts at
    /// node `node_base` and triangle `tri_base`.
    pub fn flatten_at(&self, node_base: u32, tri_base: u32) -> (Vec<GpuNode>, Vec<GpuTri>) {
        let nodes = self
            .nodes
            .iter()
            .map(|n| {
                let right_or_first = if n.tri_count == 0 {
                    n.right_or_first + node_base
                } else {
                    n.right_or_first + tri_base
                };
                GpuNode {
                    right_or_first,
                    ..*n
                }
            })
            .collect();
        (nodes, self.tris.iter().map(BvhTri::to_gpu).collect())
    }

    /// Walks the nodes whose boxes `o + t d` enters before `t_max` (nearer child first),
    /// counting them in `nodes` and calling `leaf` with each leaf's triangle range; `leaf`
    /// returns the new `t_max`, or None to stop.
    fn walk(
        &self,
        o: Vec3,
        d: Vec3,
        mut t_max: f32,
        nodes: &mut u64,
        mut leaf: impl FnMut(std::ops::Range<usize>, f32) -> Option<f32>,
    ) {
        if self.nodes.is_empty() {
            return;
        }
        let inv = safe_dir(d).recip();
        let mut stack = [0u32; MAX_DEPTH + 2];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let index = stack[top];
            let node = &self.nodes[index as usize];
            if slab(node, o, inv, t_max).is_none() {
                continue;
            }
            *nodes += 1;
            if node.tri_count > 0 {
                let first = node.right_or_first as usize;
                match leaf(first..first + node.tri_count as usize, t_max) {
                    Some(t) => t_max = t,
                    None => return,
                }
                continue;
            }
            let (left, right) = (index + 1, node.right_or_first);
            let tl = slab(&self.nodes[left as usize], o, inv, t_max);
            let tr = slab(&self.nodes[right as usize], o, inv, t_max);
            // Push the farther child first so the nearer one is popped next.
            let (near, far) = match (tl, tr) {
                (Some(a), Some(b)) if b < a => (Some(right), Some(left)),
                (Some(_), Some(_)) => (Some(left), Some(right)),
                (Some(_), None) => (Some(left), None),
                (None, Some(_)) => (Some(right), None),
                (None, None) => (None, None),
            };
            for child in [far, near].into_iter().flatten() {
                stack[top] = child;
                top += 1;
            }
        }
    }

    /// Closest hit along `o + t d`, t in (0, t_max).
    pub fn closest(&self, o: Vec3, d: Vec3, t_max: f32) -> Option<BvhHit> {
        self.closest_counted(o, d, t_max, &mut BvhWork::default())
    }

    /// [`Bvh::closest`], adding the nodes it visits and the triangles it tests to `work` (as
    /// a counting shader counts `bvh_closest`'s).
    pub fn closest_counted(
        &self,
        o: Vec3,
        d: Vec3,
        t_max: f32,
        work: &mut BvhWork,
    ) -> Option<BvhHit> {
        let mut best = None;
        let triangles = &mut work.triangles;
        self.walk(o, d, t_max, &mut work.nodes, |range, mut t_max| {
            for i in range {
                *triangles += 1;
                if let Some((t, u, v)) = self.tris[i].intersect(o, d, t_max) {
                    t_max = t;
                    best = Some(BvhHit {
                        tri: i as u32,
                        t,
                        u,
                        v,
                    });
                }
            }
            Some(t_max)
        });
        best
    }

    /// Whether any triangle lies on `o + t d`, t in (0, t_max).
    pub fn occluded(&self, o: Vec3, d: Vec3, t_max: f32) -> bool {
        let mut hit = false;
        self.walk(o, d, t_max, &mut 0, |range, t_max| {
            hit = range
                .into_iter()
                .any(|i| self.tris[i].intersect(o, d, t_max).is_some());
            (!hit).then_some(t_max)
        });
        hit
    }
}

/// `d` with components of magnitude below [`MIN_DIR`] replaced by `MIN_DIR` with their sign.
fn safe_dir(d: Vec3) -> Vec3 {
    let fix = |x: f32| {
        if x.abs() < MIN_DIR {
            if x.is_sign_negative() {
                -MIN_DIR
            } else {
                MIN_DIR
            }
        } else {
            x
        }
    };
    Vec3::new(fix(d.x), fix(d.y), fix(d.z))
}

/// Entry distance of `o + t d` (with `inv` = 1 / d) into the node's box, if it enters before
/// `t_max`.
fn slab(node: &GpuNode, o: Vec3, inv: Vec3, t_max: f32) -> Option<f32> {
    let t0 = (Vec3::from(node.min) - o) * inv;
    let t1 = (Vec3::from(node.max) - o) * inv;
    let near = t0.min(t1).max_element().max(0.0);
    let far = t0.max(t1).min_element().min(t_max);
    (near <= far).then_some(near)
}

/// One animated object of a [`SceneBvh`] as the shader reads it (`BvhInstance` in
/// `bvh.wgsl`): where its model-space BVH starts and its transform this frame.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuInstance {
    /// Rows of the world-to-object matrix (3 x 4: linear part and translation).
    pub world_to_object: [[f32; 4]; 3],
    /// The object's root node in the shared node buffer.
    pub root: u32,
    /// +1, or -1 for a mirroring transform (whose world winding, and so geometric normal,
    /// is the model's flipped).
    pub sign: f32,
    /// Padding.
    pub pad: [u32; 2],
}

impl GpuInstance {
    /// The object-space point (`w` = 1) or direction (`w` = 0) of world `p` (as
    /// `bvh_to_object` in `bvh.wgsl`).
    pub fn to_object(&self, p: Vec3, w: f32) -> Vec3 {
        let row = |r: [f32; 4]| Vec3::new(r[0], r[1], r[2]).dot(p) + r[3] * w;
        let [a, b, c] = self.world_to_object;
        Vec3::new(row(a), row(b), row(c))
    }

    /// The world geometric normal of a model-space one (as `bvh_hit_normal` in `bvh.wgsl`):
    /// the inverse transpose of the object's transform, i.e. the transpose of its inverse.
    pub fn normal_to_world(&self, n: Vec3) -> Vec3 {
        let [a, b, c] = self.world_to_object.map(|r| Vec3::new(r[0], r[1], r[2]));
        ((a * n.x + b * n.y + c * n.z) * self.sign).normalize_or_zero()
    }
}

/// The scene's triangles for rays, as a two-level BVH: the static objects in one BVH in
/// world space, built once, and each animated object in its own BVH in model space, also
/// built once; every frame only the animated objects' transforms change
/// ([`SceneBvh::instances`]), so nothing is rebuilt or re-uploaded but one matrix per
/// object, whatever its triangle count. Rigid and affine animation (the scene format's
/// translate, rotate, scale keys) is exact this way.
#[derive(Clone, Debug, Default)]
pub struct SceneBvh {
    /// The static objects, world space.
    pub still: Bvh,
    /// The animated objects, each in model space, with its index in the scene's objects.
    pub objects: Vec<(usize, Bvh)>,
}

/// A closest hit in a [`SceneBvh`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SceneHit {
    /// The hit; its triangle indexes the static BVH or the animated object's own.
    pub hit: BvhHit,
    /// The animated object hit (index into [`SceneBvh::objects`]), or `None` for a static
    /// triangle.
    pub object: Option<usize>,
}

impl SceneBvh {
    /// The BVHs of `scene`'s objects (animated ones in model space).
    pub fn build(scene: &crate::scene::Scene) -> SceneBvh {
        let frame = scene.frame(0.0, 0);
        let mut model = frame.clone();
        model.object_transforms.fill(glam::Mat4::IDENTITY);
        let objects = (0..scene.objects.len())
            .filter(|&i| scene.objects[i].animation.is_some())
            .map(|i| {
                (
                    i,
                    Bvh::build(&crate::voxel::object_triangles(scene, &model, i)),
                )
            })
            .collect();
        SceneBvh {
            still: Bvh::build(&crate::voxel::objects_triangles(scene, &frame, false)),
            objects,
        }
    }

    /// Every BVH in the shared buffers, static first: nodes, triangles, and each animated
    /// object's root node (the static root is node 0 where it has triangles).
    pub fn flatten(&self) -> (Vec<GpuNode>, Vec<GpuTri>, Vec<u32>) {
        let (mut nodes, mut tris) = self.still.flatten_at(0, 0);
        let mut roots = Vec::new();
        for (_, bvh) in &self.objects {
            let (n, t) = bvh.flatten_at(nodes.len() as u32, tris.len() as u32);
            roots.push(nodes.len() as u32);
            nodes.extend(n);
            tris.extend(t);
        }
        (nodes, tris, roots)
    }

    /// The animated objects' instances at `frame` (`roots` from [`SceneBvh::flatten`]), or
    /// an error naming an object whose transform cannot be inverted there.
    pub fn instances(
        &self,
        scene: &crate::scene::Scene,
        frame: &crate::scene::SceneFrame,
        roots: &[u32],
    ) -> crate::Result<Vec<GpuInstance>> {
        self.objects
            .iter()
            .zip(roots)
            .map(|(&(index, _), &root)| {
                let m = frame.object_transforms[index];
                let det = m.determinant();
                if !(det.is_finite() && det.abs() > 1e-12) {
                    return Err(crate::Error::InvalidArgument(format!(
                        "object '{}' has a singular transform at t = {} s (determinant {det})",
                        scene.objects[index].name, frame.time
                    )));
                }
                let inv = m.inverse().transpose();
                Ok(GpuInstance {
                    world_to_object: [inv.x_axis, inv.y_axis, inv.z_axis].map(|r| r.to_array()),
                    root,
                    sign: det.signum(),
                    pad: [0; 2],
                })
            })
            .collect()
    }

    /// Closest hit along `o + t d`, t in (0, t_max), with the animated objects placed by
    /// `instances` (CPU twin of `bvh_closest`: the static part, then each object in order up
    /// to the closest hit so far).
    pub fn closest(
        &self,
        instances: &[GpuInstance],
        o: Vec3,
        d: Vec3,
        t_max: f32,
    ) -> Option<SceneHit> {
        self.closest_counted(instances, o, d, t_max, &mut BvhWork::default())
    }

    /// [`SceneBvh::closest`], adding the nodes it visits and the triangles it tests in every
    /// BVH to `work` (as a counting shader counts `bvh_closest`'s).
    pub fn closest_counted(
        &self,
        instances: &[GpuInstance],
        o: Vec3,
        d: Vec3,
        t_max: f32,
        work: &mut BvhWork,
    ) -> Option<SceneHit> {
        let mut best = self
            .still
            .closest_counted(o, d, t_max, work)
            .map(|hit| SceneHit { hit, object: None });
        for (k, (inst, (_, bvh))) in instances.iter().zip(&self.objects).enumerate() {
            let reach = best.map_or(t_max, |b| b.hit.t);
            let (oo, dd) = (inst.to_object(o, 1.0), inst.to_object(d, 0.0));
            if let Some(hit) = bvh.closest_counted(oo, dd, reach, work) {
                best = Some(SceneHit {
                    hit,
                    object: Some(k),
                });
            }
        }
        best
    }

    /// The world geometric normal of `hit` (`instances` as for [`SceneBvh::closest`]).
    pub fn normal(&self, instances: &[GpuInstance], hit: &SceneHit) -> Vec3 {
        match hit.object {
            None => self.still.tris[hit.hit.tri as usize].normal(),
            Some(k) => {
                instances[k].normal_to_world(self.objects[k].1.tris[hit.hit.tri as usize].normal())
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nodes_and_triangles_mirror_the_wgsl_records() {
        use crate::gpu::layout::assert_mirrors_wgsl;
        assert_mirrors_wgsl!(
            GpuNode,
            "gi/probes/bvh",
            "BvhNode",
            [min, right_or_first, max, tri_count]
        );
        assert_mirrors_wgsl!(
            GpuTri,
            "gi/probes/bvh",
            "BvhTri",
            [p0, albedo, e1, _pad1, e2, _pad2, emission, _pad3]
        );
    }

    fn tri(a: [f32; 3], b: [f32; 3], c: [f32; 3]) -> VoxelTriangle {
        VoxelTriangle {
            positions: [a.into(), b.into(), c.into()],
            albedo: [200, 100, 50],
            normal: Vec3::Z,
            emission: Vec3::ZERO,
        }
    }

    #[test]
    fn traversal_finds_the_same_hits_as_brute_force() {
        // A soup of small random triangles: the BVH's closest hit must be the brute-force
        // closest hit over the same triangles (same arithmetic, so exactly equal), and
        // `occluded` must agree with it.
        let mut seed = 7u32;
        let mut rnd = move || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 8) as f32 / (1 << 24) as f32
        };
        let mut tris = Vec::new();
        for _ in 0..500 {
            let c = Vec3::new(rnd(), rnd(), rnd()) * 10.0;
            let p = |r: &mut dyn FnMut() -> f32| (c + Vec3::new(r(), r(), r()) - 0.5).to_array();
            tris.push(tri(p(&mut rnd), p(&mut rnd), p(&mut rnd)));
        }
        let bvh = Bvh::build(&tris);
        assert_eq!(bvh.tris.len(), 500);
        // Every triangle reached exactly once by the leaves.
        let leaf_total: u32 = bvh.nodes.iter().map(|n| n.tri_count).sum();
        assert_eq!(leaf_total, 500);
        let mut hits = 0;
        for _ in 0..2000 {
            let o = Vec3::new(rnd(), rnd(), rnd()) * 12.0 - 1.0;
            let d = (Vec3::new(rnd(), rnd(), rnd()) - 0.5).normalize();
            let t_max = 20.0;
            let mut brute: Option<(f32, usize)> = None;
            for (i, t) in bvh.tris.iter().enumerate() {
                if let Some((t, _, _)) = t.intersect(o, d, brute.map_or(t_max, |b| b.0)) {
                    brute = Some((t, i));
                }
            }
            let got = bvh.closest(o, d, t_max);
            assert_eq!(got.map(|h| (h.t, h.tri as usize)), brute, "{o} {d}");
            assert_eq!(bvh.occluded(o, d, t_max), brute.is_some());
            hits += brute.is_some() as u32;
        }
        assert!(hits > 200, "{hits}");
    }

    #[test]
    fn degenerate_triangles_are_dropped_and_axis_rays_hit() {
        let bvh = Bvh::build(&[
            tri([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]),
            tri([0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0]),
        ]);
        assert_eq!(bvh.tris.len(), 1);
        // A ray along +z with exactly zero x and y components.
        let hit = bvh
            .closest(Vec3::new(0.25, 0.25, 0.0), Vec3::Z, 10.0)
            .unwrap();
        assert_eq!(hit.t, 1.0);
        assert!(Bvh::build(&[]).closest(Vec3::ZERO, Vec3::Z, 1.0).is_none());
    }

    #[test]
    fn a_singular_transform_of_an_animated_object_is_a_clear_error() {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../scenes/cornell-animated.toml"
        );
        let scene = crate::scene::Scene::load(path).unwrap();
        let bvh = SceneBvh::build(&scene);
        let (_, _, roots) = bvh.flatten();
        let mut frame = scene.frame(1.0, 0);
        assert_eq!(bvh.instances(&scene, &frame, &roots).unwrap().len(), 1);
        let (index, _) = bvh.objects[0];
        frame.object_transforms[index] = glam::Mat4::from_scale(Vec3::new(1.0, 0.0, 1.0));
        let err = bvh
            .instances(&scene, &frame, &roots)
            .unwrap_err()
            .to_string();
        let name = &scene.objects[index].name;
        assert!(err.contains(name) && err.contains("singular"), "{err}");
    }
}
