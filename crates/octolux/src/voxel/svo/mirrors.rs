//! The octree's parameter and control blocks against the WGSL structs they are written into
//! (`crate::gpu::layout`): the same named fields at the same offsets, and the same size.

use super::control::{LevelParams, NodeRange, SvoControl};
use crate::gpu::shader::compose;
use crate::voxel::svo::aniso::AnisoParams;
use crate::voxel::svo::aniso_radiance::AnisoRadianceParams;
use crate::voxel::svo::dynamic::state::DynParams;
use crate::voxel::svo::inject::{AccumulateParams, InjectParams};
use crate::voxel::svo::pack::PackParams;
use crate::voxel::svo::sample::SvoInfo;

/// Asserts that the Rust struct `$rust` mirrors the WGSL struct `$wgsl` of `$source`
/// (`crate::gpu::layout::assert_mirrors`), listing every field of `$rust`.
macro_rules! assert_mirrors {
    ($rust:ty, $source:expr, $wgsl:expr, [$($field:ident),* $(,)?]) => {
        crate::gpu::layout::assert_mirrors(
            $source,
            $wgsl,
            std::mem::size_of::<$rust>(),
            &[$((stringify!($field), std::mem::offset_of!($rust, $field))),*],
        )
    };
}

#[test]
fn blocks_mirror_their_wgsl_structs() {
    let control = include_str!("control.wgsl");
    assert_mirrors!(NodeRange, control, "NodeRange", [first, end]);
    assert_mirrors!(NodeRange, control, "AtomicNodeRange", [first, end]);
    // The same block with atomics (the build's) and without (its readers').
    for wgsl in ["SvoControl", "SvoControlValues"] {
        assert_mirrors!(
            SvoControl,
            control,
            wgsl,
            [
                node_count,
                node_overflow,
                brick_count,
                dynamic_overflow,
                dynamic_fragments,
                occupied_count,
                needed_count,
                levels,
                dynamic_levels,
                occupied_ranges,
                needed_ranges,
            ]
        );
    }
    assert_mirrors!(
        LevelParams,
        control,
        "LevelParams",
        [d, depth, fragments, capacity, pool_bricks, range]
    );
    let dynamic = compose("voxel/svo/dynamic", &[("facing", false)], &[]).unwrap();
    assert_mirrors!(
        DynParams,
        &dynamic,
        "DynParams",
        [
            static_nodes,
            static_bricks,
            node_capacity,
            brick_capacity,
            fragment_capacity,
            occupied_capacity,
            needed_capacity,
            first_static_leaf,
            last,
        ]
    );
    let aniso = compose("voxel/svo/aniso_radiance", &[], &[]).unwrap();
    assert_mirrors!(
        AnisoRadianceParams,
        &aniso,
        "AnisoRadianceParams",
        [level, dynamic_nodes, leaf, static_leaves, first, count]
    );
    let aniso = compose("voxel/svo/aniso", &[], &[]).unwrap();
    assert_mirrors!(
        AnisoParams,
        &aniso,
        "AnisoParams",
        [first, count, first_leaf, leaf, static_leaves, _pad]
    );
    let sample = compose("voxel/svo/sample", &[], &[]).unwrap();
    assert_mirrors!(
        SvoInfo,
        &sample,
        "SvoInfo",
        [origin, voxel_size, depth, resolution, pool_bricks, _pad]
    );
    let inject = compose("voxel/svo/inject", &[("facing", false)], &[]).unwrap();
    assert_mirrors!(
        AccumulateParams,
        &inject,
        "AccumulateParams",
        [fragments, depth, first_leaf, leaf_count]
    );
    assert_mirrors!(
        InjectParams,
        &inject,
        "InjectParams",
        [
            origin,
            voxel_size,
            first_leaf,
            leaf_count,
            lights,
            pool_bricks,
            static_nodes,
            first_static_leaf,
            first_slot,
            has_dynamic,
            dynamic_leaves,
            leaf_level,
            bounce,
            bounce_table_capacity,
        ]
    );
    let pack = compose("voxel/svo/pack", &[], &[]).unwrap();
    assert_mirrors!(PackParams, &pack, "PackParams", [texels, pool_bricks]);
}
