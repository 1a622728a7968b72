//! Spectra of the Mitsuba importer: `wavelength:value` lists converted to linear RGB.

use super::numbers;
use glam::{Mat3, Vec3};

/// A spectrum value: one number (grey), or `wavelength:value` pairs (nm), which are converted
/// to linear RGB through the CIE 1931 observer (the analytic fit of Wyman et al. 2013) and the
/// XYZ-to-sRGB matrix, normalised so that a constant spectrum over the same wavelengths gives
/// that constant as grey. This is an approximation of Mitsuba's own conversion.
pub(super) fn to_rgb(value: &str) -> Option<Vec3> {
    if !value.contains(':') {
        return match numbers(value).as_deref() {
            Some([v]) => Some(Vec3::splat(*v)),
            _ => None,
        };
    }
    let mut samples: Vec<(f32, f32)> = Vec::new();
    for pair in value.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        let (w, v) = pair.split_once(':')?;
        let w: f32 = w.trim().parse().ok().filter(|x: &f32| x.is_finite())?;
        let v: f32 = v.trim().parse().ok().filter(|x: &f32| x.is_finite())?;
        samples.push((w, v));
    }
    if samples.is_empty() || samples.windows(2).any(|p| p[1].0 <= p[0].0) {
        return None;
    }
    if samples.len() == 1 {
        return Some(Vec3::splat(samples[0].1));
    }
    let (lo, hi) = (samples[0].0, samples[samples.len() - 1].0);
    let at = |w: f32| -> f32 {
        let i = samples
            .partition_point(|s| s.0 <= w)
            .clamp(1, samples.len() - 1);
        let (a, b) = (samples[i - 1], samples[i]);
        let t = ((w - a.0) / (b.0 - a.0)).clamp(0.0, 1.0);
        a.1 + (b.1 - a.1) * t
    };
    let (mut xyz, mut white) = (Vec3::ZERO, Vec3::ZERO);
    let mut w = lo;
    while w <= hi {
        let cmf = cie_xyz(w);
        xyz += cmf * at(w);
        white += cmf;
        w += 1.0;
    }
    let to_rgb = Mat3::from_cols(
        Vec3::new(3.2406, -0.9689, 0.0557),
        Vec3::new(-1.5372, 1.8758, -0.2040),
        Vec3::new(-0.4986, 0.0415, 1.0570),
    );
    let rgb = to_rgb * xyz;
    let white = to_rgb * white;
    if white.min_element() <= 0.0 {
        // Wavelengths that the eye barely sees: keep the mean.
        let mean = samples.iter().map(|s| s.1).sum::<f32>() / samples.len() as f32;
        return Some(Vec3::splat(mean));
    }
    Some((rgb / white).max(Vec3::ZERO))
}

/// CIE 1931 colour matching functions at wavelength `w` nm (Wyman, Sloan and Shirley 2013,
/// multi-lobe fit).
fn cie_xyz(w: f32) -> Vec3 {
    let g = |mu: f32, s1: f32, s2: f32| {
        let t = (w - mu) / if w < mu { s1 } else { s2 };
        (-0.5 * t * t).exp()
    };
    Vec3::new(
        1.056 * g(599.8, 37.9, 31.0) + 0.362 * g(442.0, 16.0, 26.7) - 0.065 * g(501.1, 20.4, 26.2),
        0.821 * g(568.8, 46.9, 40.5) + 0.286 * g(530.9, 16.3, 31.1),
        1.217 * g(437.0, 11.8, 36.0) + 0.681 * g(459.0, 26.0, 13.8),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spectra() {
        assert_eq!(to_rgb("0.5"), Some(Vec3::splat(0.5)));
        let flat = to_rgb("400:0.7, 550:0.7, 700:0.7").unwrap();
        assert!(
            (flat - Vec3::splat(0.7)).abs().max_element() < 1e-4,
            "{flat}"
        );
        // More at long wavelengths: red.
        let red = to_rgb("400:0.05, 550:0.05, 600:0.6, 700:0.65").unwrap();
        assert!(red.x > 0.3 && red.y < 0.2 && red.z < 0.1, "{red}");
        assert_eq!(to_rgb("400:x"), None);
        assert_eq!(to_rgb("500:1, 400:1"), None);
    }
}
