//! Checks that a Rust parameter block mirrors the WGSL struct it is written into: the same
//! named fields at the same byte offsets, and the same size. Rust writes such a block with
//! `bytemuck::bytes_of` and WGSL reads it by name, so a field added, removed or reordered on
//! one side only would otherwise go unnoticed until an image came out wrong.
//!
//! The WGSL side is read with naga, which lays out a struct's members as wgpu does (the
//! offsets of naga's `TypeInner::Struct` members); the Rust side is
//! [`std::mem::offset_of!`], gathered by [`assert_mirrors_wgsl!`]. Rust fields whose names
//! start with `_` and WGSL members whose names start with `_` or `pad` are padding and have no
//! counterpart. Test-only: naga is a dev dependency.

/// The members (name, byte offset) and the size of struct `name` in WGSL `source`. Panics
/// where the source does not parse or has no such struct.
pub(crate) fn wgsl_struct_layout(source: &str, name: &str) -> (Vec<(String, u32)>, u32) {
    let module = naga::front::wgsl::parse_str(source)
        .unwrap_or_else(|e| panic!("{}", e.emit_to_string(source)));
    let layout = module.types.iter().find_map(|(_, ty)| match &ty.inner {
        naga::TypeInner::Struct { members, span } if ty.name.as_deref() == Some(name) => {
            let members = members
                .iter()
                .map(|m| (m.name.clone().unwrap_or_default(), m.offset));
            Some((members.collect(), *span))
        }
        _ => None,
    });
    layout.unwrap_or_else(|| panic!("no WGSL struct {name}"))
}

/// Panics unless the Rust struct of `size` bytes with `fields` (name, offset) mirrors WGSL
/// struct `name` of `source`: every WGSL member is a Rust field at the same offset, every
/// Rust field but padding (`_...`) is a WGSL member, and the sizes agree.
pub(crate) fn assert_mirrors(source: &str, name: &str, size: usize, fields: &[(&str, usize)]) {
    let (members, span) = wgsl_struct_layout(source, name);
    // Padding members on either side (`_pad`, `pad0`) have no counterpart to match.
    let padding = |m: &str| m.starts_with('_') || m.starts_with("pad");
    for (member, offset) in members.iter().filter(|(m, _)| !padding(m)) {
        let rust = fields.iter().find(|(f, _)| f == member);
        assert_eq!(
            rust.map(|&(_, o)| o as u32),
            Some(*offset),
            "{name}.{member}: WGSL offset {offset}, Rust offset {:?}",
            rust.map(|(_, o)| o)
        );
    }
    for (field, _) in fields.iter().filter(|(f, _)| !padding(f)) {
        assert!(
            members.iter().any(|(m, _)| m == field),
            "{name}.{field}: a Rust field the WGSL struct lacks"
        );
    }
    assert_eq!(
        span as usize, size,
        "{name}: WGSL size {span}, Rust size {size}"
    );
}

/// Asserts that `#[repr(C)]` struct `$ty` mirrors WGSL struct `$name` of the library module
/// `$module` (composed with its imports by [`crate::gpu::shader::compose_alone`]):
/// `assert_mirrors_wgsl!(ClipInfo, "voxel/clipmap/sample", "ClipInfo", [voxel_size, ...])`,
/// listing every field of `$ty`. A module whose composition has `@if` flags takes them last:
/// `assert_mirrors_wgsl!(..., [...], &[("facing", false)])`.
macro_rules! assert_mirrors_wgsl {
    ($ty:ty, $module:expr, $name:expr, [$($field:ident),* $(,)?], $features:expr) => {
        $crate::gpu::layout::assert_mirrors(
            &$crate::gpu::shader::compose_alone($module, $features)
                .unwrap_or_else(|e| panic!("{e}")),
            $name,
            std::mem::size_of::<$ty>(),
            &[$((stringify!($field), std::mem::offset_of!($ty, $field))),*],
        )
    };
    ($ty:ty, $module:expr, $name:expr, [$($field:ident),* $(,)?]) => {
        $crate::gpu::layout::assert_mirrors_wgsl!($ty, $module, $name, [$($field),*], &[])
    };
}
pub(crate) use assert_mirrors_wgsl;

#[cfg(test)]
mod tests {
    use super::*;

    const WGSL: &str = "struct Block { a: vec3<f32>, b: u32, c: vec2<u32> }";

    #[repr(C)]
    struct Block {
        a: [f32; 3],
        b: u32,
        c: [u32; 2],
        _pad: [u32; 2],
    }

    fn block_fields() -> Vec<(&'static str, usize)> {
        vec![
            ("a", std::mem::offset_of!(Block, a)),
            ("b", std::mem::offset_of!(Block, b)),
            ("c", std::mem::offset_of!(Block, c)),
            ("_pad", std::mem::offset_of!(Block, _pad)),
        ]
    }

    #[test]
    fn wgsl_offsets_follow_the_alignment_rules() {
        let (members, size) = wgsl_struct_layout(WGSL, "Block");
        let offsets: Vec<(&str, u32)> = members.iter().map(|(m, o)| (m.as_str(), *o)).collect();
        assert_eq!(offsets, [("a", 0), ("b", 12), ("c", 16)]);
        assert_eq!(size, 32);
        assert_mirrors(WGSL, "Block", std::mem::size_of::<Block>(), &block_fields());
    }

    #[test]
    #[should_panic(expected = "Block.b: WGSL offset 0, Rust offset Some(12)")]
    fn a_field_reordered_on_one_side_is_caught() {
        let swapped = "struct Block { b: u32, a: vec3<f32>, c: vec2<u32> }";
        assert_mirrors(
            swapped,
            "Block",
            std::mem::size_of::<Block>(),
            &block_fields(),
        );
    }
}
