//! Bind group layout and bind group entries of compute passes, which bind whole buffers at
//! fixed binding numbers. Passes that read the scene add [`crate::GpuScene::layout_entries`]
//! and [`crate::GpuScene::bind_group_entries`] for bindings 1..=7 of their group 0.

/// A uniform buffer at `binding`, visible to compute stages.
pub fn uniform_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    buffer_layout_entry(binding, wgpu::BufferBindingType::Uniform)
}

/// A storage buffer at `binding`, visible to compute stages.
pub fn storage_entry(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    buffer_layout_entry(binding, wgpu::BufferBindingType::Storage { read_only })
}

fn buffer_layout_entry(binding: u32, ty: wgpu::BufferBindingType) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

/// Each of `buffers`, whole, at consecutive bindings from `first_binding`.
pub fn buffer_entries<'a>(
    first_binding: u32,
    buffers: impl IntoIterator<Item = &'a wgpu::Buffer>,
) -> Vec<wgpu::BindGroupEntry<'a>> {
    buffers
        .into_iter()
        .zip(first_binding..)
        .map(|(buffer, binding)| wgpu::BindGroupEntry {
            binding,
            resource: buffer.as_entire_binding(),
        })
        .collect()
}

/// A storage binding's access as its shader declares it (`var<storage, read>` or
/// `var<storage, read_write>`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Access {
    Read,
    ReadWrite,
}

impl Access {
    /// The WGSL spelling (`read`, `read_write`).
    pub fn wgsl(self) -> &'static str {
        match self {
            Access::Read => "read",
            Access::ReadWrite => "read_write",
        }
    }
}

/// The storage bindings `(binding, name, access)` a WGSL source declares in `@group(group)`,
/// in source order: what [`storage_bindings!`](crate::storage_bindings) declarations are
/// checked against.
pub fn wgsl_storage_bindings(source: &str, group: u32) -> Vec<(u32, String, Access)> {
    let prefix = format!("@group({group}) @binding(");
    source
        .lines()
        .filter_map(|line| {
            let rest = line.trim().strip_prefix(&prefix)?;
            let (binding, rest) = rest.split_once(')')?;
            let rest = rest.trim().strip_prefix("var<storage,")?;
            let (access, rest) = rest.split_once('>')?;
            let name = rest.trim().split(':').next()?.trim();
            let access = match access.trim() {
                "read" => Access::Read,
                "read_write" => Access::ReadWrite,
                _ => return None,
            };
            Some((binding.trim().parse().ok()?, name.to_string(), access))
        })
        .collect()
}

/// Checks that every storage binding `source` declares in `@group(group)` from `first` on is
/// the buffer `slots` names at that place (`slots[binding - first]`), with the same access:
/// the WGSL side of a [`storage_bindings!`](crate::storage_bindings) declaration. A shader may
/// leave bindings out (a layout may bind more than one entry point uses). The error names the
/// first mismatch.
pub fn check_declared(
    source: &str,
    group: u32,
    first: u32,
    slots: &[(&str, Access)],
) -> Result<(), String> {
    let declared: Vec<_> = wgsl_storage_bindings(source, group)
        .into_iter()
        .filter(|(binding, ..)| *binding >= first)
        .collect();
    if declared.is_empty() {
        return Err(format!("no storage binding from {first} in group {group}"));
    }
    for (binding, name, access) in declared {
        let Some((expected, expected_access)) = slots.get((binding - first) as usize) else {
            return Err(format!("binding {binding} ({name}) is past the list"));
        };
        if (name.as_str(), access) != (*expected, *expected_access) {
            return Err(format!(
                "binding {binding} is {name} ({}), the list names {expected} ({})",
                access.wgsl(),
                expected_access.wgsl()
            ));
        }
    }
    Ok(())
}

/// Declares the storage buffers of a bind group by name, once: a struct with a
/// `&wgpu::Buffer` field per binding, numbered in declaration order from a first binding.
/// Its layout entries, its bind group entries and the names and accesses that the WGSL must
/// declare ([`wgsl_storage_bindings`]) all come from the one list, so no pass addresses a
/// buffer by number.
///
/// ```
/// gi_gpu::storage_bindings! {
///     /// Two buffers from binding 8.
///     pub struct Example from 8 {
///         depth: read,
///         output: read_write,
///     }
/// }
/// assert_eq!(Example::SLOTS[1], ("output", gi_gpu::binding::Access::ReadWrite));
/// assert_eq!(Example::layout_entries()[1].binding, 9);
/// ```
#[macro_export]
macro_rules! storage_bindings {
    (
        $(#[$meta:meta])*
        $vis:vis struct $name:ident from $first:literal {
            $($(#[$field_meta:meta])* $field:ident : $access:ident),* $(,)?
        }
    ) => {
        $(#[$meta])*
        $vis struct $name<'a> {
            $($(#[$field_meta])* pub $field: &'a $crate::wgpu::Buffer,)*
        }

        #[allow(dead_code)]
        impl<'a> $name<'a> {
            /// The binding of the first buffer.
            pub const FIRST_BINDING: u32 = $first;
            /// Each binding's WGSL name and access, in binding order from
            /// [`Self::FIRST_BINDING`].
            pub const SLOTS: &'static [(&'static str, $crate::binding::Access)] = &[
                $((stringify!($field), $crate::storage_bindings!(@access $access)),)*
            ];

            /// The layout entries of the buffers, visible to compute stages.
            pub fn layout_entries() -> Vec<$crate::wgpu::BindGroupLayoutEntry> {
                Self::SLOTS
                    .iter()
                    .zip(Self::FIRST_BINDING..)
                    .map(|((_, access), binding)| {
                        $crate::binding::storage_entry(
                            binding,
                            *access == $crate::binding::Access::Read,
                        )
                    })
                    .collect()
            }

            /// The bind group entries of the buffers, whole.
            pub fn entries(&self) -> Vec<$crate::wgpu::BindGroupEntry<'a>> {
                $crate::binding::buffer_entries(Self::FIRST_BINDING, [$(self.$field,)*])
            }
        }
    };
    (@access read) => { $crate::binding::Access::Read };
    (@access read_write) => { $crate::binding::Access::ReadWrite };
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn declarations_are_read_and_checked_by_name_and_access() {
        let source = "@group(0) @binding(0) var<uniform> u: U;\n\
                      @group(0) @binding(9) var<storage, read_write> out: array<u32>;\n\
                      @group(0) @binding(8) var<storage, read> depth: array<f32>;\n\
                      @group(1) @binding(8) var<storage, read> other: array<f32>;\n";
        assert_eq!(
            wgsl_storage_bindings(source, 0),
            [
                (9, "out".to_string(), Access::ReadWrite),
                (8, "depth".to_string(), Access::Read),
            ]
        );
        let slots = [("depth", Access::Read), ("out", Access::ReadWrite)];
        assert_eq!(check_declared(source, 0, 8, &slots), Ok(()));
        let swapped = [("out", Access::ReadWrite), ("depth", Access::Read)];
        assert!(check_declared(source, 0, 8, &swapped).is_err());
        let read_only = [("depth", Access::Read), ("out", Access::Read)];
        assert!(check_declared(source, 0, 8, &read_only).is_err());
        assert!(check_declared(source, 0, 8, &slots[..1]).is_err());
    }
}
