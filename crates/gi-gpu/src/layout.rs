//! Layouts of WGSL structs as naga computes them, to test that the `#[repr(C)]` Rust mirrors
//! of shared structs match byte for byte.

/// Size, alignment and member offsets of one WGSL struct.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct StructLayout {
    /// Size in bytes, including trailing padding (what an array stride or a buffer needs).
    pub size: u32,
    /// Alignment in bytes.
    pub align: u32,
    /// `(member name, byte offset)` in declaration order.
    pub members: Vec<(String, u32)>,
}

/// The layout of the struct called `name` in `module`. Structs from imported modules carry a
/// naga_oil suffix in the composed module; they are found by their WGSL name all the same.
/// `None` if there is no such struct or naga cannot lay the module out.
pub fn wgsl_struct_layout(module: &naga::Module, name: &str) -> Option<StructLayout> {
    let mut layouter = naga::proc::Layouter::default();
    layouter.update(module.to_ctx()).ok()?;
    module.types.iter().find_map(|(handle, ty)| {
        let naga::TypeInner::Struct { members, span } = &ty.inner else {
            return None;
        };
        let ty_name = ty.name.as_deref()?;
        let matches = ty_name == name
            || ty_name
                .strip_prefix(name)
                .is_some_and(|rest| rest.starts_with("X_naga_oil_mod_X"));
        matches.then(|| StructLayout {
            size: *span,
            align: layouter[handle].alignment.round_up(1),
            members: members
                .iter()
                .map(|m| (m.name.clone().unwrap_or_default(), m.offset))
                .collect(),
        })
    })
}

/// `(field name, byte offset)` of a `#[repr(C)]` struct's fields, to compare with
/// [`StructLayout::members`]: `rust_field_offsets!(FrameUniforms { clip_from_world, exposure })`.
#[macro_export]
macro_rules! rust_field_offsets {
    ($ty:ty { $($field:ident),* $(,)? }) => {
        vec![$((stringify!($field).to_owned(), ::core::mem::offset_of!($ty, $field) as u32)),*]
    };
}
