// Sparse shading's blocks (`frame/sparse.rs`): a technique shades one pixel per f x f block of
// the image and `upsample.wgsl` reconstructs the others.

// The pixel traced for block b: the block's centre, inside the image.
fn block_pixel(b: vec2<u32>, f: u32, size: vec2<u32>) -> vec2<u32> {
    return min(b * f + vec2<u32>(f / 2u), size - vec2<u32>(1u));
}
