//! Limits on what octolux reads, and the bounded readers that enforce them.
//!
//! Every file is read through [`read_file`] or [`read_text`]: a path that is not a regular file
//! (a device such as `/dev/zero`, a pipe, a folder) or that is larger than its limit is an error
//! before anything is read, and the read itself stops at the limit. Images are decoded through
//! [`decode_image`], which checks the size claimed by the header before allocating pixels.
//! Scene values are bounded too: coordinates by [`MAX_COORDINATE`], radiance and light
//! intensities by [`MAX_RADIANCE`]. The README's "Limits" section lists them.

mod budget;

pub(crate) use budget::grouped;
pub use budget::{Account, Budget, Resource};

use crate::{Error, Result};
use std::io::Read;
use std::path::Path;

/// Largest binary input file (models, images, buffers): 2 GiB.
pub const MAX_FILE_BYTES: u64 = 2 << 30;
/// Largest text input file (scene files, Mitsuba XML, MTL): 256 MiB.
pub const MAX_TEXT_BYTES: u64 = 256 << 20;
/// Largest decompressed size of a gzipped file, whatever its compressed size: 2 GiB.
pub const MAX_DECOMPRESSED_BYTES: u64 = 2 << 30;
/// A gzipped file may inflate to at most this many times its compressed size plus
/// [`DECOMPRESSED_SLACK_BYTES`]: real meshes compress by less than 10x, a gzip bomb by 1000x.
pub const MAX_INFLATION: u64 = 64;
/// Allowance added to the inflation limit, so that small files are never refused.
pub const DECOMPRESSED_SLACK_BYTES: u64 = 64 << 20;
/// Largest side of a decoded texture or environment map, in pixels.
pub const MAX_IMAGE_SIDE: u32 = 16384;
/// Largest pixel count of a decoded texture or environment map (256 Mpixel).
pub const MAX_IMAGE_PIXELS: u64 = 1 << 28;
/// No image format compresses by more than this (deflate's limit is about 1032:1): an image
/// header claiming more pixels (at 4 bytes each) than this many times the size of the file,
/// plus [`IMAGE_SLACK_BYTES`], is refused before decoding.
pub const MAX_IMAGE_COMPRESSION: u64 = 2048;
/// Allowance added to the compression bound, so that small files are never refused.
pub const IMAGE_SLACK_BYTES: u64 = 16 << 20;
/// Largest absolute world coordinate of a vertex, light or camera (metres, after the scene's
/// unit and transforms). Far beyond any real scene, and small enough that squared distances
/// and scene bounds stay finite in 32-bit floats.
pub const MAX_COORDINATE: f32 = 1e9;
/// Largest radiance (W/(m^2 sr)), light intensity (W/sr or W/m^2) and sky texel accepted: sums
/// and products of a few thousand such values stay finite in 32-bit floats.
pub const MAX_RADIANCE: f32 = 1e12;

/// Checks that `path` names a regular file of at most `limit` bytes; returns its size.
pub fn check_file(path: &Path, limit: u64) -> Result<u64> {
    let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    if !meta.is_file() {
        let what = if meta.is_dir() {
            "a folder"
        } else {
            "not a regular file (a device, pipe or socket)"
        };
        return Err(Error::parse(path, format!("is {what}; expected a file")));
    }
    if meta.len() > limit {
        return Err(too_large(path, meta.len(), limit));
    }
    Ok(meta.len())
}

fn too_large(path: &Path, size: u64, limit: u64) -> Error {
    Error::parse(
        path,
        format!(
            "file is {} bytes, more than the limit of {limit} bytes ({})",
            size,
            human(limit)
        ),
    )
}

fn human(bytes: u64) -> String {
    if bytes >= 1 << 30 {
        format!("{} GiB", bytes >> 30)
    } else if bytes >= 1 << 20 {
        format!("{} MiB", bytes >> 20)
    } else {
        format!("{bytes} bytes")
    }
}

/// The files read through this module while [`recording_reads`] runs.
static READS: std::sync::Mutex<Option<Vec<std::path::PathBuf>>> = std::sync::Mutex::new(None);

fn reads() -> std::sync::MutexGuard<'static, Option<Vec<std::path::PathBuf>>> {
    READS.lock().unwrap_or_else(|e| e.into_inner())
}

/// Runs `f` and returns, with its result, every file read through this module meanwhile (by
/// any thread): a scene's files, models, materials, textures and sky maps, so that a tool can
/// refuse to write over any of them.
pub fn recording_reads<T>(f: impl FnOnce() -> T) -> (T, Vec<std::path::PathBuf>) {
    *reads() = Some(Vec::new());
    let out = f();
    let files = reads().take().unwrap_or_default();
    (out, files)
}

/// Reads a whole file of at most `limit` bytes (see [`check_file`]); the read stops at the
/// limit even if the file grows meanwhile.
pub fn read_file_limited(path: &Path, limit: u64) -> Result<Vec<u8>> {
    let size = check_file(path, limit)?;
    if let Some(files) = reads().as_mut() {
        files.push(path.to_path_buf());
    }
    let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let mut out = Vec::with_capacity(size as usize);
    file.take(limit + 1)
        .read_to_end(&mut out)
        .map_err(|e| Error::io(path, e))?;
    if out.len() as u64 > limit {
        return Err(too_large(path, out.len() as u64, limit));
    }
    Ok(out)
}

/// Reads a binary input file of at most [`MAX_FILE_BYTES`].
pub fn read_file(path: &Path) -> Result<Vec<u8>> {
    read_file_limited(path, MAX_FILE_BYTES)
}

/// Reads a UTF-8 text file of at most [`MAX_TEXT_BYTES`].
pub fn read_text(path: &Path) -> Result<String> {
    text_from_bytes(path, read_file_limited(path, MAX_TEXT_BYTES)?)
}

/// `bytes` read from `path` as UTF-8 text.
fn text_from_bytes(path: &Path, bytes: Vec<u8>) -> Result<String> {
    String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let line = e.as_bytes()[..at].iter().filter(|&&b| b == b'\n').count() + 1;
        Error::parse(path, format!("line {line}: not valid UTF-8 text"))
    })
}

/// Decompresses gzip data (one or more members) read from `path`, refusing output larger than
/// [`MAX_DECOMPRESSED_BYTES`] or [`MAX_INFLATION`] times the input plus
/// [`DECOMPRESSED_SLACK_BYTES`]; the decoder stops at the limit.
pub fn gunzip(path: &Path, compressed: &[u8]) -> Result<Vec<u8>> {
    let limit = (compressed.len() as u64)
        .saturating_mul(MAX_INFLATION)
        .saturating_add(DECOMPRESSED_SLACK_BYTES)
        .min(MAX_DECOMPRESSED_BYTES);
    let mut out = Vec::new();
    flate2::read::MultiGzDecoder::new(compressed)
        .take(limit + 1)
        .read_to_end(&mut out)
        .map_err(|e| Error::parse(path, format!("cannot decompress gzip data: {e}")))?;
    if out.len() as u64 > limit {
        return Err(Error::parse(
            path,
            format!(
                "gzip data inflates to more than {limit} bytes (the limit for a {} byte file: \
                 {MAX_INFLATION} x its size + {}, at most {})",
                compressed.len(),
                human(DECOMPRESSED_SLACK_BYTES),
                human(MAX_DECOMPRESSED_BYTES)
            ),
        ));
    }
    Ok(out)
}

/// The decoder limits for images: [`MAX_IMAGE_SIDE`] per side and an allocation bound that
/// fits [`MAX_IMAGE_PIXELS`] RGBA 32-bit float pixels.
fn image_limits() -> image::Limits {
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(MAX_IMAGE_SIDE);
    limits.max_image_height = Some(MAX_IMAGE_SIDE);
    limits.max_alloc = Some(MAX_IMAGE_PIXELS * 16);
    limits
}

/// Checks an image size claimed by a header against [`MAX_IMAGE_SIDE`] and
/// [`MAX_IMAGE_PIXELS`]; the message names the size and the limits.
pub fn check_image_dimensions(width: u32, height: u32) -> std::result::Result<(), String> {
    if width == 0
        || height == 0
        || width > MAX_IMAGE_SIDE
        || height > MAX_IMAGE_SIDE
        || width as u64 * height as u64 > MAX_IMAGE_PIXELS
    {
        return Err(format!(
            "image is {width}x{height}; expected 1 to {MAX_IMAGE_SIDE} pixels per side and at \
             most {} Mpixel",
            MAX_IMAGE_PIXELS >> 20
        ));
    }
    Ok(())
}

/// Checks that `encoded_bytes` of data can plausibly hold a `width` x `height` image (see
/// [`MAX_IMAGE_COMPRESSION`]), so that a tiny file claiming a huge size fails before the
/// decoder allocates its pixels.
pub fn check_image_data(
    width: u32,
    height: u32,
    encoded_bytes: usize,
) -> std::result::Result<(), String> {
    let claimed = width as u64 * height as u64 * 4;
    let most = (encoded_bytes as u64)
        .saturating_mul(MAX_IMAGE_COMPRESSION)
        .saturating_add(IMAGE_SLACK_BYTES);
    if claimed > most {
        return Err(format!(
            "header claims {width}x{height} pixels, more than {encoded_bytes} bytes of data can \
             hold (truncated or corrupt file)"
        ));
    }
    Ok(())
}

/// Decodes an image held in memory (`path` names it in errors). The format is `format` when
/// given and the data decodes as it, otherwise it is guessed from the content. The size in the
/// header is checked against [`check_image_dimensions`] before any pixel is allocated.
pub fn decode_image(
    path: &Path,
    bytes: &[u8],
    format: Option<image::ImageFormat>,
) -> Result<image::DynamicImage> {
    let reader = |format: Option<image::ImageFormat>| -> Result<_> {
        let reader = image::ImageReader::new(std::io::Cursor::new(bytes));
        match format {
            Some(f) => Ok(image::ImageReader::with_format(
                std::io::Cursor::new(bytes),
                f,
            )),
            None => reader.with_guessed_format().map_err(|e| Error::io(path, e)),
        }
    };
    let decode = |format: Option<image::ImageFormat>| -> Result<image::DynamicImage> {
        let (width, height) = reader(format)?
            .into_dimensions()
            .map_err(|e| Error::parse(path, format!("cannot decode image: {e}")))?;
        check_image_dimensions(width, height)
            .and_then(|()| check_image_data(width, height, bytes.len()))
            .map_err(|e| Error::parse(path, e))?;
        let mut reader = reader(format)?;
        reader.limits(image_limits());
        reader
            .decode()
            .map_err(|e| Error::parse(path, format!("cannot decode image: {e}")))
    };
    match format {
        Some(f) => decode(Some(f)).or_else(|first| decode(None).map_err(|_| first)),
        None => decode(None),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn devices_and_folders_are_refused_before_reading() {
        let dir = std::env::temp_dir();
        let e = read_file(&dir).unwrap_err().to_string();
        assert!(e.contains("folder"), "{e}");
        #[cfg(unix)]
        {
            let e = read_file(Path::new("/dev/zero")).unwrap_err().to_string();
            assert!(e.contains("not a regular file"), "{e}");
        }
    }

    #[test]
    fn files_over_the_limit_are_refused() {
        let file = tempfile::Builder::new()
            .prefix("octolux-limit-")
            .tempfile()
            .unwrap();
        let path = file.path();
        std::fs::write(path, [0u8; 100]).unwrap();
        assert_eq!(read_file_limited(path, 100).unwrap().len(), 100);
        let e = read_file_limited(path, 99).unwrap_err().to_string();
        assert!(e.contains("100 bytes") && e.contains("99"), "{e}");
    }

    #[test]
    fn gzip_bombs_stop_at_the_limit() {
        use std::io::Write;
        let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::best());
        let zeros = vec![0u8; 1 << 20];
        for _ in 0..(DECOMPRESSED_SLACK_BYTES >> 20) + 8 {
            enc.write_all(&zeros).unwrap();
        }
        let small = enc.finish().unwrap();
        assert!(small.len() < 1 << 20);
        let e = gunzip(Path::new("bomb.ply.gz"), &small)
            .unwrap_err()
            .to_string();
        assert!(e.contains("inflates to more than"), "{e}");
    }

    #[test]
    fn image_headers_are_checked_before_decoding() {
        // A Radiance header claiming 100000 x 100000 pixels in a few bytes.
        let hdr = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 100000 +X 100000\n\0\0\0\0";
        let e = decode_image(Path::new("big.hdr"), hdr, Some(image::ImageFormat::Hdr))
            .unwrap_err()
            .to_string();
        assert!(e.contains("100000x100000"), "{e}");
        // Within the size limits, but more pixels than a few bytes can hold.
        let hdr = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 16000 +X 16000\n\0\0\0\0";
        let e = decode_image(Path::new("big.hdr"), hdr, Some(image::ImageFormat::Hdr))
            .unwrap_err()
            .to_string();
        assert!(e.contains("16000x16000") && e.contains("can hold"), "{e}");
        assert!(check_image_data(1024, 1024, 10).is_ok());
    }
}
