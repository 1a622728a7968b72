//! Image metrics against values computed by hand on tiny images.

use glam::Vec3;
use octolux::image_io::HdrImage;
use octolux::metrics::{self, compare, MetricOptions, Metrics};
use octolux::Error;

fn image(width: u32, height: u32, pixels: &[[f32; 3]]) -> HdrImage {
    HdrImage {
        width,
        height,
        pixels: pixels.iter().map(|p| Vec3::from_array(*p)).collect(),
    }
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * b.abs().max(1e-12)
}

#[test]
fn mse_and_rel_mse_by_hand_2x2() {
    let a = image(2, 2, &[[1.0; 3], [0.0; 3], [0.5; 3], [2.0; 3]]);
    let b = image(2, 2, &[[1.0; 3], [1.0; 3], [0.5; 3], [1.0; 3]]);
    // Squared differences per pixel (all channels equal): 0, 1, 0, 1.
    assert!(close(metrics::mse(&a, &b, None).unwrap(), 0.5, 1e-12));
    // relMSE: (0 + 1/1.01 + 0 + 1/1.01) / 4.
    let want = 2.0 / 1.01 / 4.0;
    assert!(close(metrics::rel_mse(&a, &b, None).unwrap(), want, 1e-9));
    let mask = [false, true, false, false];
    assert!(close(
        metrics::mse(&a, &b, Some(&mask)).unwrap(),
        1.0,
        1e-12
    ));
    let mask = [true, false, true, false];
    assert_eq!(metrics::mse(&a, &b, Some(&mask)).unwrap(), 0.0);
}

#[test]
fn mse_and_rel_mse_by_hand_3x3() {
    let mut a = image(3, 3, &[[0.25, 0.5, 0.75]; 9]);
    let b = a.clone();
    a.pixels[4] = Vec3::new(3.0, 0.5, 1.75);
    let mut b = b;
    b.pixels[4] = Vec3::new(1.0, 0.5, 0.0);
    // Only the centre differs: squared errors 4, 0, 3.0625 over 27 values.
    assert!(close(
        metrics::mse(&a, &b, None).unwrap(),
        7.0625 / 27.0,
        1e-9
    ));
    // relMSE: 4 / (1 + 0.01) + 0 + 3.0625 / (0 + 0.01), over 27.
    let want = (4.0 / 1.01 + 306.25) / 27.0;
    assert!(close(metrics::rel_mse(&a, &b, None).unwrap(), want, 1e-9));
}

/// The display transform written out from its definition (ACES fit, then sRGB encoding).
fn display_by_hand(x: f64) -> f64 {
    let f = (x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14);
    if f <= 0.0031308 {
        12.92 * f
    } else {
        1.055 * f.powf(1.0 / 2.4) - 0.055
    }
}

#[test]
fn psnr_and_ssim_of_flat_images_by_hand() {
    let a = image(3, 3, &[[1.0; 3]; 9]);
    let b = image(3, 3, &[[0.25; 3]; 9]);
    let (da, db) = (display_by_hand(1.0), display_by_hand(0.25));
    let options = MetricOptions::default();
    let psnr = metrics::psnr(&a, &b, None, &options).unwrap();
    assert!(
        close(psnr, -10.0 * ((da - db) * (da - db)).log10(), 1e-5),
        "{psnr}"
    );
    // Flat images: no variance, SSIM is the luminance term alone (grey: luma = value).
    let c1 = 1e-4;
    let want = (2.0 * da * db + c1) / (da * da + db * db + c1);
    let ssim = metrics::ssim(&a, &b, None, &options).unwrap();
    assert!(close(ssim, want, 1e-5), "{ssim} vs {want}");
    // One stop of exposure doubles the linear values before the curve.
    let bright = MetricOptions {
        exposure: 1.0,
        ..options
    };
    let psnr = metrics::psnr(&a, &b, None, &bright).unwrap();
    let (da, db) = (display_by_hand(2.0), display_by_hand(0.5));
    assert!(close(psnr, -10.0 * ((da - db) * (da - db)).log10(), 1e-5));
}

fn noisy(width: u32, height: u32, seed: u32) -> HdrImage {
    let mut state = seed.wrapping_mul(747_796_405).wrapping_add(1);
    let pixels = (0..width * height)
        .map(|i| {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            let n = (state >> 8) as f32 / 16_777_216.0;
            Vec3::new(0.2 + 0.5 * n, (i % 7) as f32 * 0.1 + 0.4 * n, 0.3)
        })
        .collect();
    HdrImage {
        width,
        height,
        pixels,
    }
}

#[test]
fn identical_images_are_perfect() {
    let a = noisy(16, 12, 1);
    let m = compare(&a, &a, None).unwrap();
    assert_eq!(m.mse, 0.0);
    assert_eq!(m.rel_mse, 0.0);
    assert_eq!(m.psnr, metrics::PSNR_CAP_DB);
    assert_eq!(m.ssim, 1.0);
    assert_eq!(m.flip, 0.0);
    let map = metrics::flip_map(&a, &a, &MetricOptions::default()).unwrap();
    assert!(map.values.iter().all(|&v| v == 0.0));
}

#[test]
fn different_images_score_worse() {
    let a = noisy(16, 12, 1);
    let b = noisy(16, 12, 2);
    let m = compare(&a, &b, None).unwrap();
    assert!(m.mse > 0.0 && m.rel_mse > 0.0);
    assert!(m.psnr < 40.0);
    assert!(m.ssim < 0.99 && m.ssim > -1.0);
    assert!(m.flip > 0.0 && m.flip <= 1.0);
    // Masking the whole image equals no mask.
    let all = vec![true; 16 * 12];
    assert_eq!(compare(&a, &b, Some(&all)).unwrap(), m);
    // JSON round trip.
    let json = serde_json::to_string(&m).unwrap();
    let back: Metrics = serde_json::from_str(&json).unwrap();
    // serde_json's default float parser may differ in the last bit.
    for (x, y) in [
        (back.mse, m.mse),
        (back.rel_mse, m.rel_mse),
        (back.psnr, m.psnr),
        (back.ssim, m.ssim),
        (back.flip, m.flip),
    ] {
        assert!(close(x, y, 1e-14));
    }
    assert!(json.contains("\"rel_mse\""));
}

#[test]
fn size_and_mask_errors() {
    let a = image(2, 2, &[[0.0; 3]; 4]);
    let b = image(3, 3, &[[0.0; 3]; 9]);
    match compare(&a, &b, None) {
        Err(Error::InvalidArgument(message)) => {
            assert!(
                message.contains("2x2") && message.contains("3x3"),
                "{message}"
            )
        }
        other => panic!("expected a size error, got {other:?}"),
    }
    assert!(matches!(
        compare(&a, &a, Some(&[true; 3])),
        Err(Error::InvalidArgument(_))
    ));
    assert!(matches!(
        compare(&a, &a, Some(&[false; 4])),
        Err(Error::InvalidArgument(_))
    ));
}

#[test]
fn error_map_png_and_mask_loading() {
    let tmp = tempfile::Builder::new()
        .prefix("octolux-metrics-")
        .tempdir()
        .unwrap();
    let dir = tmp.path();
    let a = noisy(8, 6, 3);
    let b = noisy(8, 6, 4);
    let map = metrics::flip_map(&a, &b, &MetricOptions::default()).unwrap();
    let mut mask = vec![true; 48];
    mask[0] = false;
    let rgb = map.to_magma_rgb8(Some(&mask));
    assert_eq!(rgb.len(), 48 * 3);
    assert_eq!(&rgb[0..3], &[0, 0, 0]);
    let path = dir.join("err.png");
    map.write_png(&path, None).unwrap();
    // A written PNG works as a mask: bright magma pixels count, dark ones do not.
    let loaded = metrics::load_mask(&path, 8, 6).unwrap();
    assert_eq!(loaded.len(), 48);
    assert!(matches!(
        metrics::load_mask(&path, 4, 4),
        Err(Error::InvalidArgument(_))
    ));
    let exr = dir.join("a.exr");
    a.write_exr(&exr).unwrap();
    assert_eq!(metrics::load_image(&exr).unwrap(), a);
}
