//! Screenshots: the rendered image alone (PNG of the display image + OpenEXR of the linear one,
//! exactly what `octolux render` writes for the same camera), and the whole window with its
//! panels (read back from the surface texture before it is presented).

use anyhow::{bail, Context, Result};
use octolux::gpu::{read_texture, GpuContext};
use octolux::image_io::write_rgb8_png;
use octolux::render::Renderer;
use std::path::{Path, PathBuf};

/// Checks that `path` names a PNG file.
pub fn check_png(path: &Path, flag: &str) -> Result<()> {
    if !path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("png"))
    {
        bail!("{flag} {}: expected a .png file", path.display());
    }
    Ok(())
}

/// Writes the last frame's display image to `png` and its linear image to the same path with
/// `.exr`; returns the EXR's path.
pub fn save_view(renderer: &Renderer, png: &Path) -> Result<PathBuf> {
    let (w, h) = (renderer.settings().width, renderer.settings().height);
    let rgb = renderer.read_display()?;
    write_rgb8_png(png, w, h, rgb).with_context(|| format!("writing {}", png.display()))?;
    let exr = png.with_extension("exr");
    renderer
        .read_hdr()?
        .write_exr(&exr)
        .with_context(|| format!("writing {}", exr.display()))?;
    Ok(exr)
}

/// The first `octolux-view-NNNN.png` in the working folder that does not exist yet (with no
/// `.exr` either).
pub fn next_name() -> PathBuf {
    (1..)
        .map(|i| PathBuf::from(format!("octolux-view-{i:04}.png")))
        .find(|p| !p.exists() && !p.with_extension("exr").exists())
        .unwrap_or_else(|| PathBuf::from("octolux-view.png"))
}

/// Reads a presentable texture (8-bit RGBA or BGRA, needs `COPY_SRC`) back as RGB8.
pub fn read_window(ctx: &GpuContext, texture: &wgpu::Texture) -> Result<Vec<u8>> {
    use wgpu::TextureFormat as F;
    let swap = match texture.format() {
        F::Rgba8Unorm | F::Rgba8UnormSrgb => false,
        F::Bgra8Unorm | F::Bgra8UnormSrgb => true,
        other => bail!("cannot capture a window of format {other:?}"),
    };
    let bytes = read_texture(ctx, texture, 0)?;
    Ok(bytes
        .chunks_exact(4)
        .flat_map(|p| {
            if swap {
                [p[2], p[1], p[0]]
            } else {
                [p[0], p[1], p[2]]
            }
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_png_paths_pass() {
        assert!(check_png(Path::new("a.PNG"), "--screenshot").is_ok());
        let err = check_png(Path::new("a.exr"), "--screenshot").unwrap_err();
        assert!(err.to_string().contains("expected a .png"), "{err}");
        assert!(check_png(Path::new("noext"), "--screenshot").is_err());
    }
}
