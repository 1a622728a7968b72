//! Run-time technique switches (`Renderer::set_technique`) and the renderer's outputs
//! (`Renderer::set_output`), on the built-in Cornell box.

use crate::common::context;
use glam::Vec3;
use octolux::gi::GiSettings;
use octolux::render::{Output, RenderSettings, Renderer};
use octolux::scene::cornell;

const SIZE: u32 = 48;

fn settings(gi: &str) -> RenderSettings {
    RenderSettings {
        width: SIZE,
        height: SIZE,
        shadow_map_size: 256,
        gi: gi.into(),
        ..RenderSettings::default()
    }
}

fn max_abs_difference(a: &[Vec3], b: &[Vec3]) -> f32 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|(x, y)| (*x - *y).abs().max_element())
        .fold(0.0, f32::max)
}

fn mean(pixels: &[Vec3]) -> f32 {
    pixels.iter().map(|p| p.element_sum() / 3.0).sum::<f32>() / pixels.len() as f32
}

#[test]
fn switched_technique_renders_like_a_fresh_renderer_and_leaves_the_ledger() {
    let scene = cornell::scene();
    let fresh_ctx = context();
    let mut fresh = Renderer::new(&fresh_ctx, &scene, settings("lpv")).unwrap();
    fresh.render(&scene, 0.0).unwrap();
    let expected = fresh.read_hdr().unwrap();

    let ctx = context();
    let mut renderer = Renderer::new(&ctx, &scene, settings("none")).unwrap();
    renderer.render(&scene, 0.0).unwrap();
    let direct_only = renderer.read_hdr().unwrap();
    assert!(ctx.ledger.by_owner().iter().any(|(o, _)| o == "none"));

    renderer
        .set_technique(&scene, "lpv", &GiSettings::default())
        .unwrap();
    assert_eq!(renderer.technique().name(), "lpv");
    assert_eq!(renderer.settings().gi, "lpv");
    renderer.render(&scene, 0.0).unwrap();
    let switched = renderer.read_hdr().unwrap();

    // The LPV adds light: the switch took effect (this fails if compose still read the old
    // technique's zero image).
    assert!(
        mean(&switched.pixels) > mean(&direct_only.pixels) * 1.05,
        "lpv {} vs none {}",
        mean(&switched.pixels),
        mean(&direct_only.pixels)
    );
    // Same passes on the same inputs: the same image up to the order of atomic float sums.
    let diff = max_abs_difference(&switched.pixels, &expected.pixels);
    assert!(
        diff < 1e-3,
        "switched vs fresh renderer: max difference {diff}"
    );
    // The old technique's memory is gone from the ledger; the totals match a fresh renderer's.
    let owners: Vec<String> = ctx.ledger.by_owner().into_iter().map(|(o, _)| o).collect();
    assert!(!owners.contains(&"none".to_string()), "{owners:?}");
    assert_eq!(ctx.ledger.total(), fresh_ctx.ledger.total());

    // Switching again to the same technique with other settings replaces its entries.
    let mut smaller = GiSettings::default();
    smaller.lpv.size = 16;
    let before = ctx.ledger.total();
    renderer.set_technique(&scene, "lpv", &smaller).unwrap();
    assert!(ctx.ledger.total() < before);

    // A bad name is an error and keeps the technique in use.
    let err = renderer
        .set_technique(&scene, "no-such", &GiSettings::default())
        .unwrap_err();
    assert!(err.to_string().contains("unknown GI technique"), "{err}");
    assert_eq!(renderer.technique().name(), "lpv");
    renderer.render(&scene, 0.0).unwrap();
}

#[test]
fn outputs_split_the_frame_into_direct_and_indirect() {
    let scene = cornell::scene();
    let ctx = context();
    let mut renderer = Renderer::new(&ctx, &scene, settings("lpv")).unwrap();
    let mut images = Vec::new();
    for output in Output::ALL {
        renderer.set_output(output);
        assert_eq!(renderer.output(), output);
        renderer.render(&scene, 0.0).unwrap();
        images.push(renderer.read_hdr().unwrap().pixels);
    }
    let (total, direct, indirect) = (&images[0], &images[1], &images[2]);
    let albedo = renderer.read_gbuffer().unwrap().albedo;
    // final = direct + albedo/pi x E, and the irradiance output is E/pi.
    let rebuilt: Vec<Vec3> = direct
        .iter()
        .zip(indirect)
        .zip(&albedo)
        .map(|((d, e), a)| *d + *a * *e)
        .collect();
    let diff = max_abs_difference(total, &rebuilt);
    assert!(diff < 1e-3, "final vs direct + albedo x indirect: {diff}");
    // Both parts carry light, and the direct output matches the direct pass's own image
    // (stored as half floats).
    assert!(mean(direct) > 0.0 && mean(indirect) > 0.0);
    let direct_pass = renderer.read_direct().unwrap().pixels;
    let diff = direct
        .iter()
        .zip(&direct_pass)
        .map(|(a, b)| (*a - *b).abs().max_element() / b.max_element().max(1e-3))
        .fold(0.0, f32::max);
    assert!(diff < 1e-2, "direct output vs direct pass: relative {diff}");
}
