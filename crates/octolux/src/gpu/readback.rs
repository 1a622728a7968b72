//! Copying GPU data back to the CPU (for outputs and tests).

use super::GpuContext;
use crate::{Error, Result};

/// Reads `size` bytes of `buffer` from `offset` (the buffer needs `COPY_SRC`). Blocks.
pub fn read_buffer(
    ctx: &GpuContext,
    buffer: &wgpu::Buffer,
    offset: u64,
    size: u64,
) -> Result<Vec<u8>> {
    let padded = size.next_multiple_of(wgpu::COPY_BUFFER_ALIGNMENT);
    let staging = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size: padded.max(4),
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    encoder.copy_buffer_to_buffer(buffer, offset, &staging, 0, padded);
    ctx.queue.submit([encoder.finish()]);
    let mut bytes = map_read(ctx, &staging)?;
    bytes.truncate(size as usize);
    Ok(bytes)
}

/// The whole of `buffer` as 32-bit words (the buffer needs `COPY_SRC`). Blocks.
pub fn read_words(ctx: &GpuContext, buffer: &wgpu::Buffer) -> Result<Vec<u32>> {
    let bytes = read_buffer(ctx, buffer, 0, buffer.size())?;
    Ok(bytemuck::cast_slice(&bytes).to_vec())
}

/// Reads mip level 0 / layer `layer` of a 2D texture (or the whole of a 3D one) tightly packed,
/// rows top to bottom. The texture needs `COPY_SRC`. Blocks.
pub fn read_texture(ctx: &GpuContext, texture: &wgpu::Texture, layer: u32) -> Result<Vec<u8>> {
    let format = texture.format();
    let aspect = if format.is_depth_stencil_format() {
        wgpu::TextureAspect::DepthOnly
    } else {
        wgpu::TextureAspect::All
    };
    let texel = format
        .block_copy_size(Some(aspect))
        .ok_or_else(|| Error::Gpu(format!("cannot read back {format:?}")))?;
    let (width, height) = (texture.width(), texture.height());
    let depth = match texture.dimension() {
        wgpu::TextureDimension::D3 => texture.depth_or_array_layers(),
        _ => 1,
    };
    let row = width * texel;
    let padded_row = row.next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
    let staging = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("texture readback"),
        size: padded_row as u64 * height as u64 * depth as u64,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    encoder.copy_texture_to_buffer(
        wgpu::TexelCopyTextureInfo {
            texture,
            mip_level: 0,
            origin: wgpu::Origin3d {
                x: 0,
                y: 0,
                z: if depth > 1 { 0 } else { layer },
            },
            aspect,
        },
        wgpu::TexelCopyBufferInfo {
            buffer: &staging,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(padded_row),
                rows_per_image: Some(height),
            },
        },
        wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: depth,
        },
    );
    ctx.queue.submit([encoder.finish()]);
    let padded = map_read(ctx, &staging)?;
    let mut out = Vec::with_capacity((row * height * depth) as usize);
    for r in 0..(height * depth) as usize {
        let start = r * padded_row as usize;
        out.extend_from_slice(&padded[start..start + row as usize]);
    }
    Ok(out)
}

fn map_read(ctx: &GpuContext, staging: &wgpu::Buffer) -> Result<Vec<u8>> {
    let (tx, rx) = std::sync::mpsc::channel();
    staging.map_async(wgpu::MapMode::Read, .., move |r| {
        let _ = tx.send(r);
    });
    ctx.wait_idle()?;
    rx.recv()
        .map_err(|_| Error::Gpu("buffer mapping was abandoned".into()))?
        .map_err(|e| Error::Gpu(format!("buffer mapping failed: {e}")))?;
    let bytes = staging
        .get_mapped_range(..)
        .map_err(|e| Error::Gpu(format!("buffer mapping failed: {e}")))?
        .to_vec();
    staging.unmap();
    ctx.check_errors()?;
    Ok(bytes)
}

/// Reads an `Rgba16Float` texture back as an image of its rgb (waits for the GPU).
pub fn read_half_image(
    ctx: &GpuContext,
    texture: &wgpu::Texture,
) -> Result<crate::image_io::HdrImage> {
    let bytes = read_texture(ctx, texture, 0)?;
    let values: Vec<f32> = bytes
        .chunks_exact(2)
        .map(|c| super::pack::f16_to_f32(u16::from_le_bytes([c[0], c[1]])))
        .collect();
    Ok(crate::image_io::HdrImage {
        width: texture.width(),
        height: texture.height(),
        pixels: values
            .chunks_exact(4)
            .map(|p| glam::Vec3::new(p[0], p[1], p[2]))
            .collect(),
    })
}
