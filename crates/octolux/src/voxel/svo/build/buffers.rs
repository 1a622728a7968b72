//! The buffers of a build attempt: the scratch it makes and releases ([`Scratch`]), the node
//! arrays sized for its node capacity ([`BuildNodes`]) and their exact-sized copies the octree
//! keeps ([`KeptNodes`]), and the kept buffers and brick pools the octree is made of.

use crate::gpu::{GpuContext, PassTimer};
use crate::voxel::svo::{word_buffer, BUILD_BRICK_WORDS, OWNER, POOLS};

/// Usage of every buffer the build makes: bound as storage, copied and read back.
pub(super) const USAGE: wgpu::BufferUsages = wgpu::BufferUsages::STORAGE
    .union(wgpu::BufferUsages::COPY_SRC)
    .union(wgpu::BufferUsages::COPY_DST);

/// A brick pool of `bricks` bricks of `words` words, split over [`POOLS`] buffers of
/// `pool_bricks`: buffer k holds bricks `[k * pool_bricks, (k + 1) * pool_bricks)` (unused
/// ones are 16-byte placeholders).
pub(super) fn pools(
    ctx: &GpuContext,
    label: &str,
    words: u32,
    bricks: u32,
    pool_bricks: u32,
) -> Vec<wgpu::Buffer> {
    (0..POOLS as u64)
        .map(|k| {
            let here = (bricks as u64)
                .saturating_sub(k * pool_bricks as u64)
                .min(pool_bricks as u64);
            word_buffer(ctx, &format!("{label} {k}"), here * words as u64, USAGE)
        })
        .collect()
}

/// The buffers of one build attempt: made through it, and forgotten by the ledger together
/// when the attempt ends (the GPU frees each when its last use has run).
pub(super) struct Scratch<'a> {
    ctx: &'a GpuContext,
    labels: Vec<String>,
}

impl<'a> Scratch<'a> {
    pub(super) fn new(ctx: &'a GpuContext) -> Scratch<'a> {
        Scratch {
            ctx,
            labels: Vec::new(),
        }
    }

    pub(super) fn buffer(&mut self, label: &str, words: u64) -> wgpu::Buffer {
        self.labels.push(label.to_string());
        word_buffer(self.ctx, label, words, USAGE)
    }

    /// An RGBA16F brick pool of `bricks` (as [`pools`]).
    pub(super) fn pools(
        &mut self,
        label: &str,
        bricks: u32,
        pool_bricks: u32,
    ) -> Vec<wgpu::Buffer> {
        self.labels
            .extend((0..POOLS).map(|k| format!("{label} {k}")));
        pools(self.ctx, label, BUILD_BRICK_WORDS, bricks, pool_bricks)
    }

    pub(super) fn release(self) {
        for label in &self.labels {
            self.ctx.ledger.forget(OWNER, label);
        }
    }
}

/// The node arrays of one build attempt, sized for its node capacity.
pub(super) struct BuildNodes {
    /// First child per node (0 = none).
    pub(super) child: wgpu::Buffer,
    /// +x, +y, +z neighbour per node.
    pub(super) neighbours: wgpu::Buffer,
    /// Packed coordinates per node on its level.
    pub(super) coord: wgpu::Buffer,
    /// Per node its brick index + 1 (0 = no brick), as [`Svo`]'s `brick_plus_one`; during
    /// the structure pass it holds the node's occupied / needed flags instead, which
    /// `assign_bricks` turns into the brick index + 1.
    pub(super) brick_plus_one: wgpu::Buffer,
    /// A bit per node: its cell holds a voxel ([`Svo`]'s `static_occupied`).
    pub(super) occupied: wgpu::Buffer,
    /// Stands in for the brick pool buffers in the structure pass.
    pub(super) placeholder: wgpu::Buffer,
}

/// The node arrays the octree keeps, at their exact size.
pub(super) struct KeptNodes {
    pub(super) child: wgpu::Buffer,
    pub(super) neighbours: wgpu::Buffer,
    pub(super) coord: wgpu::Buffer,
    pub(super) brick_plus_one: wgpu::Buffer,
    pub(super) static_occupied: wgpu::Buffer,
}

impl BuildNodes {
    pub(super) fn new(scratch: &mut Scratch, capacity: u32) -> BuildNodes {
        let cap = capacity as u64;
        BuildNodes {
            child: scratch.buffer("child (build)", cap),
            neighbours: scratch.buffer("neighbours (build)", cap * 3),
            coord: scratch.buffer("coordinates (build)", cap),
            brick_plus_one: scratch.buffer("brick index (build)", cap),
            occupied: scratch.buffer("occupied nodes (build)", cap.div_ceil(32)),
            placeholder: scratch.buffer("placeholder", 4),
        }
    }

    /// Copies of the first `nodes` nodes into arrays of `capacity` (the static part and
    /// the dynamic reserve); the occupied bits of the static nodes only (the walk reads the
    /// dynamic ones' state instead).
    pub(super) fn keep(
        &self,
        ctx: &GpuContext,
        timer: &mut PassTimer,
        nodes: u32,
        capacity: u32,
    ) -> KeptNodes {
        let mut copy = |label: &str, from: &wgpu::Buffer, words: u64, capacity_words: u64| {
            let buffer = word_buffer(ctx, label, capacity_words, USAGE);
            timer.untimed(|encoder| {
                encoder.copy_buffer_to_buffer(from, 0, &buffer, 0, Some(words * 4))
            });
            buffer
        };
        let (n, cap) = (nodes as u64, capacity as u64);
        KeptNodes {
            child: copy("child", &self.child, n, cap),
            neighbours: copy("neighbours", &self.neighbours, n * 3, cap * 3),
            brick_plus_one: copy("brick index", &self.brick_plus_one, n, cap),
            coord: copy("coordinates", &self.coord, n, cap),
            static_occupied: copy(
                "occupied nodes",
                &self.occupied,
                n.div_ceil(32),
                n.div_ceil(32),
            ),
        }
    }
}
