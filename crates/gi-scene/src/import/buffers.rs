//! Buffer loading and bounds-checked accessor reading.
//!
//! The gltf crate's own accessor iterators trust the document (they slice and index without
//! checking every offset, stride and count against the data that was actually loaded), so the
//! importer reads accessors itself: every byte range is checked before it is touched, and a
//! broken file becomes an error instead of a panic.

use std::path::Path;

use glam::{Vec2, Vec3, Vec4};
use gltf::json::accessor::{ComponentType, Type};
use gltf::json::validation::Checked;
use gltf::json::{Accessor, Root};

use super::{Result, malformed};

/// Most elements a sparse accessor without a buffer view may declare: such an accessor is
/// filled with zeros, so its count is not bounded by any data in the file.
const MAX_ZERO_FILLED_ELEMENTS: u64 = 1 << 22;

/// The document's buffers, loaded and length-checked.
pub(super) struct Buffers<'a> {
    root: &'a Root,
    data: Vec<Vec<u8>>,
}

impl<'a> Buffers<'a> {
    /// Loads every buffer: the GLB binary chunk for a buffer without URI, embedded `data:`
    /// URIs, and files relative to `dir`.
    pub(super) fn load(root: &'a Root, mut blob: Option<Vec<u8>>, dir: &Path) -> Result<Self> {
        let mut data = Vec::with_capacity(root.buffers.len());
        for (index, buffer) in root.buffers.iter().enumerate() {
            let label = format!("buffers[{index}]");
            let bytes = match &buffer.uri {
                Some(uri) => fetch_uri(uri, dir).map_err(|e| malformed(format!("{label}: {e}")))?,
                // Only the first buffer may live in the GLB binary chunk.
                None if index == 0 => blob.take().ok_or_else(|| {
                    malformed(format!(
                        "{label} has no uri and the file has no binary chunk"
                    ))
                })?,
                None => return Err(malformed(format!("{label} has no uri"))),
            };
            if (bytes.len() as u64) < buffer.byte_length.0 {
                return Err(malformed(format!(
                    "{label} declares {} bytes but only {} are available",
                    buffer.byte_length.0,
                    bytes.len()
                )));
            }
            data.push(bytes);
        }
        Ok(Self { root, data })
    }

    /// The bytes of buffer view `index`.
    pub(super) fn view(&self, index: usize) -> Result<&[u8]> {
        let label = || format!("bufferViews[{index}]");
        let view = self
            .root
            .buffer_views
            .get(index)
            .ok_or_else(|| malformed(format!("{} does not exist", label())))?;
        let buffer = self
            .data
            .get(view.buffer.value())
            .ok_or_else(|| malformed(format!("{} names a missing buffer", label())))?;
        let start = view.byte_offset.map_or(0, |o| o.0);
        byte_range(buffer, start, view.byte_length.0)
            .ok_or_else(|| malformed(format!("{} lies outside its buffer", label())))
    }

    /// Reads accessor `index` as three-component vectors (`what` names the use in errors).
    pub(super) fn vec3s(&self, index: usize, what: &str) -> Result<Vec<Vec3>> {
        let values = self.floats(index, Type::Vec3, what)?;
        Ok(values
            .chunks_exact(3)
            .map(|c| Vec3::new(c[0], c[1], c[2]))
            .collect())
    }

    /// Reads accessor `index` as two-component vectors.
    pub(super) fn vec2s(&self, index: usize, what: &str) -> Result<Vec<Vec2>> {
        let values = self.floats(index, Type::Vec2, what)?;
        Ok(values
            .chunks_exact(2)
            .map(|c| Vec2::new(c[0], c[1]))
            .collect())
    }

    /// Reads accessor `index` as four-component vectors.
    pub(super) fn vec4s(&self, index: usize, what: &str) -> Result<Vec<Vec4>> {
        let values = self.floats(index, Type::Vec4, what)?;
        Ok(values
            .chunks_exact(4)
            .map(|c| Vec4::new(c[0], c[1], c[2], c[3]))
            .collect())
    }

    /// Reads accessor `index` as `TANGENT` values: like [`Buffers::vec4s`], but NaN and
    /// infinite values are kept for the caller to repair.
    pub(super) fn tangents(&self, index: usize, what: &str) -> Result<Vec<Vec4>> {
        let accessor = self.accessor(index, what)?;
        let raw = self.raw(accessor, index, Type::Vec4, what)?;
        Ok(raw
            .chunks_exact(4)
            .map(|c| Vec4::new(c[0] as f32, c[1] as f32, c[2] as f32, c[3] as f32))
            .collect())
    }

    /// Reads accessor `index` as scalars.
    pub(super) fn scalars(&self, index: usize, what: &str) -> Result<Vec<f32>> {
        self.floats(index, Type::Scalar, what)
    }

    /// Reads accessor `index` as vertex indices (unsigned integer scalars).
    pub(super) fn indices(&self, index: usize, what: &str) -> Result<Vec<u32>> {
        let accessor = self.accessor(index, what)?;
        let component = component_type(accessor, index)?;
        if !matches!(
            component,
            ComponentType::U8 | ComponentType::U16 | ComponentType::U32
        ) || accessor.normalized
        {
            return Err(malformed(format!(
                "{what}: accessors[{index}] must hold unsigned integers to be used as indices"
            )));
        }
        let raw = self.raw(accessor, index, Type::Scalar, what)?;
        // Unsigned components up to 32 bits are exact in f64, so the cast back is lossless.
        Ok(raw.into_iter().map(|v| v as u32).collect())
    }

    /// Reads accessor `index` as `JOINTS_n` values: four unsigned 8- or 16-bit integers per
    /// vertex.
    pub(super) fn joints(&self, index: usize, what: &str) -> Result<Vec<[u16; 4]>> {
        let accessor = self.accessor(index, what)?;
        let component = component_type(accessor, index)?;
        if !matches!(component, ComponentType::U8 | ComponentType::U16) || accessor.normalized {
            return Err(malformed(format!(
                "{what}: accessors[{index}] must hold unsigned 8- or 16-bit integers"
            )));
        }
        let raw = self.raw(accessor, index, Type::Vec4, what)?;
        // Unsigned components up to 16 bits are exact in f64, so the cast back is lossless.
        Ok(raw
            .chunks_exact(4)
            .map(|c| [c[0] as u16, c[1] as u16, c[2] as u16, c[3] as u16])
            .collect())
    }

    /// Reads accessor `index` as `WEIGHTS_n` values: floats, or normalized unsigned 8- or
    /// 16-bit integers; negative values are an error.
    pub(super) fn weights(&self, index: usize, what: &str) -> Result<Vec<Vec4>> {
        let accessor = self.accessor(index, what)?;
        let component = component_type(accessor, index)?;
        let valid = match component {
            ComponentType::F32 => true,
            ComponentType::U8 | ComponentType::U16 => accessor.normalized,
            _ => false,
        };
        if !valid {
            return Err(malformed(format!(
                "{what}: accessors[{index}] must hold floats or normalized unsigned 8- or 16-bit integers"
            )));
        }
        let weights = self.vec4s(index, what)?;
        if weights.iter().any(|w| w.min_element() < 0.0) {
            return Err(malformed(format!(
                "{what}: accessors[{index}] has negative weights"
            )));
        }
        Ok(weights)
    }

    /// Reads accessor `index` as column-major 4x4 matrices.
    pub(super) fn mat4s(&self, index: usize, what: &str) -> Result<Vec<glam::Mat4>> {
        let values = self.floats(index, Type::Mat4, what)?;
        Ok(values
            .chunks_exact(16)
            .map(glam::Mat4::from_cols_slice)
            .collect())
    }

    fn accessor(&self, index: usize, what: &str) -> Result<&'a Accessor> {
        self.root
            .accessors
            .get(index)
            .ok_or_else(|| malformed(format!("{what}: accessor {index} does not exist")))
    }

    /// Reads a float-valued accessor, applying integer normalization, and rejects NaN and
    /// infinite values.
    fn floats(&self, index: usize, expected: Type, what: &str) -> Result<Vec<f32>> {
        let accessor = self.accessor(index, what)?;
        let raw = self.raw(accessor, index, expected, what)?;
        let values: Vec<f32> = raw.into_iter().map(|v| v as f32).collect();
        if values.iter().any(|v| !v.is_finite()) {
            return Err(malformed(format!(
                "{what}: accessors[{index}] contains NaN or infinite values"
            )));
        }
        Ok(values)
    }

    /// Reads every component of an accessor (dense data, then sparse substitutions) as f64,
    /// normalized when the accessor says so.
    fn raw(
        &self,
        accessor: &Accessor,
        index: usize,
        expected: Type,
        what: &str,
    ) -> Result<Vec<f64>> {
        let label = format!("{what}: accessors[{index}]");
        let component = component_type(accessor, index)?;
        let ty = match accessor.type_ {
            Checked::Valid(ty) => ty,
            Checked::Invalid => return Err(malformed(format!("{label} has an invalid type"))),
        };
        if ty != expected {
            return Err(malformed(format!(
                "{label} has type {ty:?}, expected {expected:?}"
            )));
        }
        let dims = ty.multiplicity();
        let element_size = dims * component.size();
        let count = accessor.count.0;
        let decode = |bytes: &[u8], out: &mut Vec<f64>| {
            decode_element(bytes, component, dims, accessor.normalized, out)
        };

        let mut values = match accessor.buffer_view {
            Some(view_index) => {
                let view = self.view(view_index.value())?;
                let stride = self
                    .root
                    .buffer_views
                    .get(view_index.value())
                    .and_then(|v| v.byte_stride)
                    .map_or(element_size, |s| s.0);
                if stride < element_size {
                    return Err(malformed(format!(
                        "{label}: byte stride {stride} is smaller than an element ({element_size} bytes)"
                    )));
                }
                let offset = accessor.byte_offset.map_or(0, |o| o.0);
                read_elements(view, offset, count, stride, element_size, dims, decode).ok_or_else(
                    || malformed(format!("{label} reads past the end of its buffer view")),
                )?
            }
            None if count <= MAX_ZERO_FILLED_ELEMENTS => vec![0.0; count as usize * dims],
            None => {
                return Err(malformed(format!(
                    "{label} declares {count} zero-initialized elements, more than supported"
                )));
            }
        };

        if let Some(sparse) = &accessor.sparse {
            let n = sparse.count.0;
            let index_type = match sparse.indices.component_type {
                Checked::Valid(t) => t.0,
                Checked::Invalid => {
                    return Err(malformed(format!("{label}: invalid sparse index type")));
                }
            };
            let index_view = self.view(sparse.indices.buffer_view.value())?;
            let sparse_indices = read_elements(
                index_view,
                sparse.indices.byte_offset.0,
                n,
                index_type.size(),
                index_type.size(),
                1,
                |b, out| decode_element(b, index_type, 1, false, out),
            )
            .ok_or_else(|| malformed(format!("{label}: sparse indices lie outside their view")))?;
            let value_view = self.view(sparse.values.buffer_view.value())?;
            let sparse_values = read_elements(
                value_view,
                sparse.values.byte_offset.0,
                n,
                element_size,
                element_size,
                dims,
                decode,
            )
            .ok_or_else(|| malformed(format!("{label}: sparse values lie outside their view")))?;
            for (target, value) in sparse_indices.iter().zip(sparse_values.chunks_exact(dims)) {
                let start = *target as usize * dims;
                let slot = values.get_mut(start..start + dims).ok_or_else(|| {
                    malformed(format!("{label}: sparse index {target} is out of range"))
                })?;
                slot.copy_from_slice(value);
            }
        }
        Ok(values)
    }
}

fn component_type(accessor: &Accessor, index: usize) -> Result<ComponentType> {
    match accessor.component_type {
        Checked::Valid(t) => Ok(t.0),
        Checked::Invalid => Err(malformed(format!(
            "accessors[{index}] has an invalid component type"
        ))),
    }
}

/// `len` bytes of `data` from `start`, or `None` when the range does not fit.
fn byte_range(data: &[u8], start: u64, len: u64) -> Option<&[u8]> {
    let start = usize::try_from(start).ok()?;
    let end = start.checked_add(usize::try_from(len).ok()?)?;
    data.get(start..end)
}

/// Decodes `count` elements of `element_size` bytes (`dims` components each), `stride` bytes
/// apart from `offset` in `data`, into a flat list; `None` when any element falls outside.
fn read_elements(
    data: &[u8],
    offset: u64,
    count: u64,
    stride: usize,
    element_size: usize,
    dims: usize,
    decode: impl Fn(&[u8], &mut Vec<f64>),
) -> Option<Vec<f64>> {
    if count == 0 {
        return Some(Vec::new());
    }
    // Check the whole span once, so the allocation below is bounded by the data size.
    let span = (count - 1)
        .checked_mul(stride as u64)?
        .checked_add(element_size as u64)?;
    let data = byte_range(data, offset, span)?;
    let mut out = Vec::with_capacity(count as usize * dims);
    for i in 0..count as usize {
        let start = i * stride;
        let element = data.get(start..start + element_size)?;
        decode(element, &mut out);
    }
    Some(out)
}

/// Decodes one element of `dims` components from little-endian bytes, appending them to
/// `out`. Matrices (16 components) of 4-byte components have no column padding.
fn decode_element(
    bytes: &[u8],
    component: ComponentType,
    dims: usize,
    normalized: bool,
    out: &mut Vec<f64>,
) {
    let size = component.size();
    for b in bytes.chunks_exact(size).take(dims) {
        // Normalization follows the glTF specification's integer-to-float rules.
        out.push(match component {
            ComponentType::I8 => {
                let v = f64::from(b[0] as i8);
                if normalized { (v / 127.0).max(-1.0) } else { v }
            }
            ComponentType::U8 => {
                let v = f64::from(b[0]);
                if normalized { v / 255.0 } else { v }
            }
            ComponentType::I16 => {
                let v = f64::from(i16::from_le_bytes([b[0], b[1]]));
                if normalized {
                    (v / 32767.0).max(-1.0)
                } else {
                    v
                }
            }
            ComponentType::U16 => {
                let v = f64::from(u16::from_le_bytes([b[0], b[1]]));
                if normalized { v / 65535.0 } else { v }
            }
            ComponentType::U32 => {
                let v = f64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]]));
                if normalized { v / 4_294_967_295.0 } else { v }
            }
            ComponentType::F32 => f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
        });
    }
}

/// Reads the bytes a buffer or image URI points to: an embedded `data:` URI, or a file
/// relative to `dir` (percent-encoded, as glTF URIs are). Other schemes (`file:`, `http:`...)
/// are not supported.
pub(super) fn fetch_uri(uri: &str, dir: &Path) -> std::result::Result<Vec<u8>, String> {
    if uri.starts_with("data:") {
        // The gltf crate decodes base64 data URIs; the directory is not used for them.
        return gltf::buffer::Data::from_source(gltf::buffer::Source::Uri(uri), None)
            .map(|data| data.0)
            .map_err(|e| format!("cannot decode embedded data: {e}"));
    }
    if uri.contains(':') {
        return Err(format!(
            "unsupported URI \"{uri}\" (only relative paths and data: URIs)"
        ));
    }
    let relative = percent_decode(uri)
        .ok_or_else(|| format!("URI \"{uri}\" does not decode to valid UTF-8"))?;
    let path = dir.join(&relative);
    std::fs::read(&path).map_err(|e| format!("cannot read \"{relative}\": {e}"))
}

/// Decodes `%XX` escapes; `None` when the result is not UTF-8.
fn percent_decode(uri: &str) -> Option<String> {
    let bytes = uri.as_bytes();
    let hex = |i: usize| bytes.get(i).and_then(|&b| (b as char).to_digit(16));
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        match (bytes[i], hex(i + 1), hex(i + 2)) {
            (b'%', Some(high), Some(low)) => {
                out.push((high * 16 + low) as u8);
                i += 3;
            }
            (byte, _, _) => {
                out.push(byte);
                i += 1;
            }
        }
    }
    String::from_utf8(out).ok()
}
