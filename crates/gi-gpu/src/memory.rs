//! Memory accounting of the GPU buffers and textures the context creates.
//!
//! Every resource made through [`GpuContext`](crate::GpuContext) is recorded with its label and
//! size. The tracker keeps a handle to each resource until it is released with
//! [`GpuContext::release_buffer`](crate::GpuContext::release_buffer),
//! [`GpuContext::release_texture`](crate::GpuContext::release_texture) or
//! [`GpuContext::release_labeled`](crate::GpuContext::release_labeled), or until the context is
//! dropped. That makes the report exact (a counted resource is a live resource) at the cost of
//! one rule: a technique releases what it replaces. wgpu resources have no drop hook, so the
//! alternative (counting until the last user handle drops) would need wrapper types at every
//! binding site.

use std::collections::BTreeMap;
use std::fmt;
use std::sync::Mutex;

/// One tracked resource: the handle keeps it alive and lets `release_*` find it.
enum Resource {
    Buffer(wgpu::Buffer),
    Texture(wgpu::Texture),
}

struct Entry {
    label: String,
    bytes: u64,
    resource: Resource,
}

/// Live tracked resources of one context. Shared (behind an `Arc`) with helpers such as
/// [`GpuTimer`](crate::GpuTimer) that release their own resources when dropped.
#[derive(Default)]
pub struct MemoryTracker {
    entries: Mutex<Vec<Entry>>,
}

impl MemoryTracker {
    pub(crate) fn track_buffer(&self, label: &str, buffer: &wgpu::Buffer) {
        self.push(label, buffer.size(), Resource::Buffer(buffer.clone()));
    }

    pub(crate) fn track_texture(&self, label: &str, bytes: u64, texture: &wgpu::Texture) {
        self.push(label, bytes, Resource::Texture(texture.clone()));
    }

    fn push(&self, label: &str, bytes: u64, resource: Resource) {
        self.lock().push(Entry {
            label: label.to_owned(),
            bytes,
            resource,
        });
    }

    /// Untracks and destroys `buffer`; returns false if it was not tracked here.
    pub(crate) fn release_buffer(&self, buffer: &wgpu::Buffer) -> bool {
        self.release_where(|r| matches!(r, Resource::Buffer(b) if b == buffer)) > 0
    }

    /// Untracks and destroys `texture`; returns false if it was not tracked here.
    pub(crate) fn release_texture(&self, texture: &wgpu::Texture) -> bool {
        self.release_where(|r| matches!(r, Resource::Texture(t) if t == texture)) > 0
    }

    /// Untracks and destroys every resource whose label starts with `prefix`; returns how many.
    pub(crate) fn release_labeled(&self, prefix: &str) -> usize {
        let mut entries = self.lock();
        let before = entries.len();
        entries.retain(|e| {
            let keep = !e.label.starts_with(prefix);
            if !keep {
                destroy(&e.resource);
            }
            keep
        });
        before - entries.len()
    }

    fn release_where(&self, matches: impl Fn(&Resource) -> bool) -> usize {
        let mut entries = self.lock();
        let before = entries.len();
        entries.retain(|e| {
            let keep = !matches(&e.resource);
            if !keep {
                destroy(&e.resource);
            }
            keep
        });
        before - entries.len()
    }

    /// A snapshot of the live tracked bytes, summed per label.
    pub(crate) fn report(&self) -> MemoryReport {
        let mut by_label = BTreeMap::new();
        for entry in self.lock().iter() {
            *by_label.entry(entry.label.clone()).or_insert(0) += entry.bytes;
        }
        MemoryReport { by_label }
    }

    /// A poisoned lock only means another thread panicked while pushing or removing an entry;
    /// the list itself is still consistent, so accounting goes on.
    fn lock(&self) -> std::sync::MutexGuard<'_, Vec<Entry>> {
        self.entries.lock().unwrap_or_else(|e| e.into_inner())
    }
}

fn destroy(resource: &Resource) {
    match resource {
        Resource::Buffer(buffer) => buffer.destroy(),
        Resource::Texture(texture) => texture.destroy(),
    }
}

/// Bytes of the live tracked GPU resources, per label. Labels follow the product's naming
/// (`"technique.resource"`), so [`MemoryReport::bytes_with_prefix`] gives one technique's
/// footprint.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct MemoryReport {
    /// Bytes per label, several resources with one label summed.
    pub by_label: BTreeMap<String, u64>,
}

impl MemoryReport {
    /// Total bytes of all live tracked resources.
    pub fn total_bytes(&self) -> u64 {
        self.by_label.values().sum()
    }

    /// Bytes of the resources labeled exactly `label` (0 if none).
    pub fn bytes(&self, label: &str) -> u64 {
        self.by_label.get(label).copied().unwrap_or(0)
    }

    /// Bytes of the resources whose labels start with `prefix`, e.g. `"bvh."`.
    pub fn bytes_with_prefix(&self, prefix: &str) -> u64 {
        self.by_label
            .iter()
            .filter(|(label, _)| label.starts_with(prefix))
            .map(|(_, bytes)| bytes)
            .sum()
    }
}

/// A table of labels and MiB, largest first, with the total last.
impl fmt::Display for MemoryReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        const MIB: f64 = 1024.0 * 1024.0;
        let mut rows: Vec<_> = self.by_label.iter().collect();
        rows.sort_by(|a, b| b.1.cmp(a.1).then(a.0.cmp(b.0)));
        let width = rows.iter().map(|(l, _)| l.len()).max().unwrap_or(0).max(5);
        writeln!(f, "{:<width$}  {:>12}", "resource", "MiB")?;
        for (label, bytes) in rows {
            writeln!(f, "{label:<width$}  {:>12.3}", *bytes as f64 / MIB)?;
        }
        writeln!(
            f,
            "{:<width$}  {:>12.3}",
            "total",
            self.total_bytes() as f64 / MIB
        )
    }
}

/// Bytes a texture occupies: every mip level of every layer at the format's block size, times
/// the sample count. Drivers add alignment and compression metadata on top; this counts what
/// the product asked for, which is what budgets are written in.
pub(crate) fn texture_bytes(desc: &wgpu::TextureDescriptor) -> u64 {
    let format = desc.format;
    // Combined depth-stencil formats have no single copy size: add the aspects.
    let block_bytes = format.block_copy_size(None).unwrap_or_else(|| {
        let depth = format.block_copy_size(Some(wgpu::TextureAspect::DepthOnly));
        let stencil = format.block_copy_size(Some(wgpu::TextureAspect::StencilOnly));
        depth.unwrap_or(4) + stencil.unwrap_or(0)
    }) as u64;
    let (block_w, block_h) = format.block_dimensions();
    let layers = match desc.dimension {
        wgpu::TextureDimension::D3 => 1,
        _ => desc.size.depth_or_array_layers as u64,
    };
    let mut bytes = 0;
    for level in 0..desc.mip_level_count {
        let Some(size) = desc.mip_level_size(level) else {
            break;
        };
        let blocks_x = size.width.div_ceil(block_w) as u64;
        let blocks_y = size.height.div_ceil(block_h) as u64;
        let depth = match desc.dimension {
            wgpu::TextureDimension::D3 => size.depth_or_array_layers as u64,
            _ => 1,
        };
        bytes += blocks_x * blocks_y * depth * layers * block_bytes;
    }
    bytes * desc.sample_count as u64
}
