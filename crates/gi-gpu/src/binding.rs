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
