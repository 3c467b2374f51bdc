//! One mesh primitive's geometry (glTF 2.0 sections 3.6.2 accessors, 3.7.2 primitives): its
//! `POSITION` and `indices` accessors read with every element checked to lie inside its
//! buffer view and buffer, and its corners turned into triangles by its mode. Errors are
//! plain messages; the scene walk names the mesh and primitive.

use std::borrow::Cow;

use glam::Vec3;
use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::Mode;

/// Reads the positions of `primitive` (from `position_accessor`, its `POSITION`) and its
/// triangles, which replace the contents of `triangles` (a buffer reused across primitives).
/// Non-indexed primitives use sequential indices.
pub(super) fn read_primitive(
    primitive: &gltf::Primitive,
    position_accessor: &gltf::Accessor,
    buffers: &[Cow<'_, [u8]>],
    triangles: &mut Vec<[u32; 3]>,
) -> Result<Vec<Vec3>, String> {
    let positions = read_positions(position_accessor, buffers)?;
    let indices = match primitive.indices() {
        Some(a) => read_indices(&a, buffers)?,
        None => (0..positions.len() as u32).collect(),
    };
    triangles.clear();
    triangulate(primitive.mode(), &indices, positions.len(), triangles)?;
    Ok(positions)
}

/// The bytes of each element of `accessor`: `(data, first element offset, stride)`, with every
/// element checked to lie inside its buffer view and buffer.
fn accessor_bytes<'b>(
    accessor: &gltf::Accessor,
    buffers: &'b [Cow<'_, [u8]>],
) -> Result<(&'b [u8], usize, usize), String> {
    let what = || format!("accessor {}", accessor.index());
    if accessor.sparse().is_some() {
        return Err(format!("{}: sparse accessors are not supported", what()));
    }
    let view = accessor
        .view()
        .ok_or_else(|| format!("{}: no buffer view (not supported)", what()))?;
    let buffer = buffers
        .get(view.buffer().index())
        .ok_or_else(|| format!("{}: missing buffer", what()))?;
    let view_end = view
        .offset()
        .checked_add(view.length())
        .filter(|&end| end <= buffer.len())
        .ok_or_else(|| {
            format!(
                "{}: buffer view {} exceeds its buffer",
                what(),
                view.index()
            )
        })?;
    let data = &buffer[view.offset()..view_end];
    let element = accessor.size();
    let stride = view.stride().unwrap_or(element);
    if stride < element {
        return Err(format!(
            "{}: byteStride {stride} < element size {element}",
            what()
        ));
    }
    if accessor.count() > 0 {
        let end = (accessor.count() - 1)
            .checked_mul(stride)
            .and_then(|x| x.checked_add(accessor.offset()))
            .and_then(|x| x.checked_add(element));
        if !matches!(end, Some(end) if end <= data.len()) {
            return Err(format!(
                "{}: {} elements at offset {} do not fit in buffer view {} ({} bytes)",
                what(),
                accessor.count(),
                accessor.offset(),
                view.index(),
                data.len()
            ));
        }
    }
    Ok((data, accessor.offset(), stride))
}

/// The positions of a `POSITION` accessor, which must be `VEC3` `FLOAT`.
fn read_positions(
    accessor: &gltf::Accessor,
    buffers: &[Cow<'_, [u8]>],
) -> Result<Vec<Vec3>, String> {
    if accessor.data_type() != DataType::F32 || accessor.dimensions() != Dimensions::Vec3 {
        return Err(format!(
            "accessor {}: POSITION must be VEC3 FLOAT",
            accessor.index()
        ));
    }
    let (data, offset, stride) = accessor_bytes(accessor, buffers)?;
    let f = |o: usize| f32::from_le_bytes([data[o], data[o + 1], data[o + 2], data[o + 3]]);
    Ok((0..accessor.count())
        .map(|i| {
            let o = offset + i * stride;
            Vec3::new(f(o), f(o + 4), f(o + 8))
        })
        .collect())
}

/// The corner indices of an `indices` accessor, which must be `SCALAR` of an unsigned type.
fn read_indices(accessor: &gltf::Accessor, buffers: &[Cow<'_, [u8]>]) -> Result<Vec<u32>, String> {
    if accessor.dimensions() != Dimensions::Scalar {
        return Err(format!(
            "accessor {}: indices must be SCALAR",
            accessor.index()
        ));
    }
    let (data, offset, stride) = accessor_bytes(accessor, buffers)?;
    let at = |i: usize| offset + i * stride;
    let n = accessor.count();
    Ok(match accessor.data_type() {
        DataType::U8 => (0..n).map(|i| u32::from(data[at(i)])).collect(),
        DataType::U16 => (0..n)
            .map(|i| u32::from(u16::from_le_bytes([data[at(i)], data[at(i) + 1]])))
            .collect(),
        DataType::U32 => (0..n)
            .map(|i| {
                let o = at(i);
                u32::from_le_bytes([data[o], data[o + 1], data[o + 2], data[o + 3]])
            })
            .collect(),
        other => {
            return Err(format!(
                "accessor {}: index type {other:?} is not an unsigned integer",
                accessor.index()
            ))
        }
    })
}

/// Appends the triangles of one primitive, given its corner indices (relative to its own
/// positions, `vertex_count` of them) and mode; modes without triangles append nothing.
fn triangulate(
    mode: Mode,
    indices: &[u32],
    vertex_count: usize,
    out: &mut Vec<[u32; 3]>,
) -> Result<(), String> {
    if let Some(bad) = indices.iter().find(|&&i| i as usize >= vertex_count) {
        return Err(format!(
            "index {bad} out of range ({vertex_count} positions)"
        ));
    }
    match mode {
        Mode::Triangles => {
            if !indices.chunks_exact(3).remainder().is_empty() {
                return Err(format!("{} indices is not a multiple of 3", indices.len()));
            }
            out.extend(indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]));
        }
        Mode::TriangleStrip => {
            // Odd triangles swap their first two corners to keep a consistent winding
            // (glTF spec 3.7.2.1, same as OpenGL).
            for k in 0..indices.len().saturating_sub(2) {
                let (a, b, c) = (indices[k], indices[k + 1], indices[k + 2]);
                out.push(if k % 2 == 0 { [a, b, c] } else { [b, a, c] });
            }
        }
        Mode::TriangleFan => {
            for k in 1..indices.len().saturating_sub(1) {
                out.push([indices[0], indices[k], indices[k + 1]]);
            }
        }
        Mode::Points | Mode::Lines | Mode::LineLoop | Mode::LineStrip => {}
    }
    Ok(())
}
