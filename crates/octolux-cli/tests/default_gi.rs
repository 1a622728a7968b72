//! `octolux render` without `--gi` renders with global illumination: the default technique is
//! not `none`, and the Cornell box's ceiling, which its downward spot light does not reach,
//! receives about the indirect light the unlimited-bounce reference (what the default
//! computes) gives it.

use glam::Vec3;
use octolux::gpu::{GpuContext, GpuOptions};
use octolux::image_io::HdrImage;
use octolux::render::{RenderSettings, Renderer};
use octolux::scene::cornell;
use std::process::Command;

const SIZE: u32 = 64;

fn render(dir: &std::path::Path, name: &str, extra: &[&str]) -> (HdrImage, String) {
    let exr = dir.join(format!("{name}.exr"));
    let png = dir.join(format!("{name}.png"));
    let size = SIZE.to_string();
    let output = Command::new(env!("CARGO_BIN_EXE_octolux"))
        .args(["render", "--width", &size, "--height", &size, "--out"])
        .arg(&png)
        .arg("--exr")
        .arg(&exr)
        .args(extra)
        .output()
        .expect("run octolux");
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    (
        HdrImage::read_exr(&exr).unwrap(),
        String::from_utf8_lossy(&output.stdout).into_owned(),
    )
}

/// Pixels that see the ceiling: surfaces facing straight down.
fn ceiling_mask() -> Vec<bool> {
    let scene = cornell::scene();
    let ctx = GpuContext::shared(&GpuOptions::default()).expect("a GPU adapter");
    let settings = RenderSettings {
        width: SIZE,
        height: SIZE,
        gi: "none".into(),
        ..RenderSettings::default()
    };
    let mut renderer = Renderer::new(&ctx, &scene, settings).unwrap();
    renderer.render(&scene, 0.0).unwrap();
    let gbuffer = renderer.read_gbuffer().unwrap();
    gbuffer
        .normal
        .iter()
        .zip(&gbuffer.depth)
        .map(|(n, &d)| d < 1.0 && n.dot(Vec3::NEG_Y) > 0.9)
        .collect()
}

fn mean_over(image: &HdrImage, mask: &[bool]) -> f32 {
    let picked: Vec<Vec3> = image
        .pixels
        .iter()
        .zip(mask)
        .filter(|(_, &m)| m)
        .map(|(p, _)| *p)
        .collect();
    picked.iter().map(|p| p.element_sum() / 3.0).sum::<f32>() / picked.len() as f32
}

#[test]
fn default_render_lights_the_ceiling_indirectly() {
    let tmp = tempfile::Builder::new()
        .prefix("octolux-default-gi-")
        .tempdir()
        .unwrap();
    let dir = tmp.path();
    let (default, stdout) = render(dir, "default", &[]);
    let technique = stdout
        .split("with --gi ")
        .nth(1)
        .and_then(|rest| rest.split_whitespace().next())
        .unwrap_or_else(|| panic!("no technique named in: {stdout}"));
    assert_ne!(technique, "none", "the default render has no GI");
    let (direct_only, _) = render(dir, "none", &["--gi", "none"]);

    let mask = ceiling_mask();
    let ceiling_pixels = mask.iter().filter(|&&m| m).count();
    // The ceiling fills the top of the classic Cornell view.
    assert!(
        ceiling_pixels > (SIZE * SIZE / 20) as usize,
        "{ceiling_pixels}"
    );
    let with_gi = mean_over(&default, &mask);
    let without = mean_over(&direct_only, &mask);
    let (reference, _) = render(
        dir,
        "reference",
        &[
            "--gi",
            "reference",
            "--bounces",
            "unlimited",
            "--spp",
            "256",
        ],
    );
    let expected = mean_over(&reference, &mask);
    println!("ceiling radiance: {technique} {with_gi}, reference {expected}, none {without}");
    // The spot points down and its cone does not reach the ceiling: without GI the ceiling is
    // black (exactly 0). With the default technique (`probes-grid`, settled over its history
    // with every bounce) it receives the room's light as the unlimited reference does (one
    // bounce alone gave 0.225 against 0.248 of the one-bounce reference). The bound allows
    // the probes' interpolation a quarter either way.
    assert_eq!(without, 0.0, "the ceiling has direct light: {without}");
    assert!(expected > 0.1, "reference ceiling radiance {expected}");
    let ratio = with_gi / expected;
    assert!(
        (0.75..1.33).contains(&ratio),
        "ceiling radiance with {technique}: {with_gi}, reference {expected}"
    );
}
