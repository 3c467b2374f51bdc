//! PLY `binary_little_endian` and `binary_big_endian` data, read straight from the byte slice:
//! vertices with only scalar properties at a fixed stride, faces in the `list uchar int|uint`
//! layout (what every shipped PLY and our writer use) in a loop of their own, anything else
//! item by item. Errors name the byte offset and the element.

use std::path::Path;

use glam::Vec3;

use super::super::error::{LoadError, Location};
use super::header::{face_list, Element, Header, Kind, Scalar};
use super::mesh::{add_face, as_index, Mesh};

/// The binary data and what every element reader needs to know about it.
struct Binary<'a> {
    path: &'a Path,
    bytes: &'a [u8],
    /// Big-endian (`binary_big_endian`).
    big: bool,
    /// Vertices the header declares: face indices must be below it.
    vertex_count: u32,
}

/// Reads the binary data after the header into `mesh`, element by element in header order;
/// bytes after the last element are a load warning.
pub(super) fn read_binary(
    path: &Path,
    bytes: &[u8],
    header: &Header,
    big: bool,
    vertex_count: u32,
    mesh: &mut Mesh,
) -> Result<(), LoadError> {
    let data = Binary {
        path,
        bytes,
        big,
        vertex_count,
    };
    let mut pos = header.data_start;
    for e in &header.elements {
        let stride = e.fixed_stride();
        data.check_count(pos, e, stride)?;
        pos = if e.name == "vertex" {
            data.read_vertices(pos, e, stride, mesh)?
        } else if let Some(list) = face_list(e) {
            data.read_faces(pos, e, list, mesh)?
        } else {
            data.skip_element(pos, e, stride)?
        };
    }
    if pos < bytes.len() {
        mesh.warnings.push(format!(
            "{} bytes after the last element (from byte offset {pos}) are ignored",
            bytes.len() - pos
        ));
    }
    Ok(())
}

impl Binary<'_> {
    /// "file ends early" at item `item` of `e`, which starts at `pos`.
    fn truncated(&self, pos: usize, e: &Element, item: u64) -> LoadError {
        LoadError::parse(
            self.path,
            Location::Byte(pos as u64),
            format!("element {} item {item}: file ends early", e.name),
        )
    }

    /// An error of the face that starts at `pos`.
    fn face_err(&self, pos: usize, message: String) -> LoadError {
        LoadError::parse(
            self.path,
            Location::Byte(pos as u64),
            format!("element face: {message}"),
        )
    }

    /// Rejects counts the bytes left after `pos` cannot hold (each item takes at least its
    /// scalars and list counts), before any memory is reserved for them.
    fn check_count(&self, pos: usize, e: &Element, stride: Option<usize>) -> Result<(), LoadError> {
        let remaining = self.bytes.len() - pos;
        let min_item = stride.unwrap_or_else(|| {
            e.properties
                .iter()
                .map(|p| match p.kind {
                    Kind::Scalar(s) => s.size(),
                    Kind::List { count, .. } => count.size(),
                })
                .sum()
        });
        if (e.count as u128) * (min_item as u128) > remaining as u128 {
            return Err(LoadError::parse(
                self.path,
                Location::Byte(pos as u64),
                format!(
                    "element {}: {} items need at least {} bytes, {remaining} left",
                    e.name,
                    e.count,
                    (e.count as u128) * (min_item as u128)
                ),
            ));
        }
        Ok(())
    }

    /// Reads the vertex element `e` at `pos` (`stride` when all its properties are scalars);
    /// returns the position after it.
    fn read_vertices(
        &self,
        mut pos: usize,
        e: &Element,
        stride: Option<usize>,
        mesh: &mut Mesh,
    ) -> Result<usize, LoadError> {
        let count = e.count as usize;
        mesh.positions.reserve(count);
        let axes = [e.find(&["x"]), e.find(&["y"]), e.find(&["z"])];
        match stride {
            Some(stride) => {
                let data = &self.bytes[pos..pos + count * stride];
                self.read_fixed_vertices(data, stride, axis_offsets(e, axes), mesh);
                pos += count * stride;
            }
            None => {
                let mut values = vec![0.0f64; e.properties.len()];
                for item in 0..e.count {
                    pos = read_item_binary(self.bytes, pos, e, self.big, &mut values, None)
                        .ok_or_else(|| self.truncated(pos, e, item))?;
                    let [x, y, z] = axes.map(|a| values[a.unwrap_or(0)] as f32);
                    mesh.positions.push(Vec3::new(x, y, z));
                }
            }
        }
        Ok(pos)
    }

    /// Reads fixed-size vertex items (`data` holds all of them, `stride` bytes each) whose
    /// x, y, z sit at `offsets`; little-endian `f32` coordinates skip the per-value dispatch.
    fn read_fixed_vertices(
        &self,
        data: &[u8],
        stride: usize,
        offsets: [(usize, Scalar); 3],
        mesh: &mut Mesh,
    ) {
        let all_f32 = offsets.iter().all(|&(_, t)| t == Scalar::F32);
        if all_f32 && !self.big {
            let f = |item: &[u8], o: usize| {
                f32::from_le_bytes([item[o], item[o + 1], item[o + 2], item[o + 3]])
            };
            let [(ox, _), (oy, _), (oz, _)] = offsets;
            mesh.positions.extend(
                data.chunks_exact(stride)
                    .map(|item| Vec3::new(f(item, ox), f(item, oy), f(item, oz))),
            );
        } else {
            let big = self.big;
            mesh.positions.extend(data.chunks_exact(stride).map(|item| {
                let [x, y, z] = offsets.map(|(o, t)| t.read(&item[o..], big) as f32);
                Vec3::new(x, y, z)
            }));
        }
    }

    /// Reads the face element `e` at `pos`, whose vertex list is property `list`; returns the
    /// position after it.
    fn read_faces(
        &self,
        mut pos: usize,
        e: &Element,
        list: usize,
        mesh: &mut Mesh,
    ) -> Result<usize, LoadError> {
        let fast = e.properties.len() == 1
            && matches!(
                e.properties[0].kind,
                Kind::List {
                    count: Scalar::U8,
                    item: Scalar::I32 | Scalar::U32
                }
            );
        mesh.triangles.reserve(e.count as usize);
        if fast {
            return self.read_uchar_int_faces(pos, e, mesh);
        }
        let mut values = vec![0.0f64; e.properties.len()];
        let mut face = Vec::new();
        for item in 0..e.count {
            let start = pos;
            face.clear();
            pos = read_item_binary(
                self.bytes,
                pos,
                e,
                self.big,
                &mut values,
                Some((list, &mut face)),
            )
            .ok_or_else(|| self.truncated(start, e, item))?;
            add_face(&face, item, self.vertex_count, mesh).map_err(|m| self.face_err(start, m))?;
        }
        Ok(pos)
    }

    /// Reads faces of the `list uchar int|uint` layout (one property): one count byte, then
    /// 4-byte indices; triangles (count 3) skip the general per-index conversion. Returns the
    /// position after the element.
    fn read_uchar_int_faces(
        &self,
        mut pos: usize,
        e: &Element,
        mesh: &mut Mesh,
    ) -> Result<usize, LoadError> {
        let (bytes, big, vertex_count) = (self.bytes, self.big, self.vertex_count);
        let signed = matches!(
            e.properties[0].kind,
            Kind::List {
                item: Scalar::I32,
                ..
            }
        );
        let mut face = [0i64; 255];
        for item in 0..e.count {
            let start = pos;
            let n = *bytes.get(pos).ok_or_else(|| self.truncated(pos, e, item))? as usize;
            let end = pos + 1 + 4 * n;
            let Some(data) = bytes.get(pos + 1..end) else {
                return Err(self.truncated(pos, e, item));
            };
            if n == 3 {
                let idx = |k: usize| {
                    let b = [
                        data[4 * k],
                        data[4 * k + 1],
                        data[4 * k + 2],
                        data[4 * k + 3],
                    ];
                    if big {
                        u32::from_be_bytes(b)
                    } else {
                        u32::from_le_bytes(b)
                    }
                };
                let t = [idx(0), idx(1), idx(2)];
                if let Some(&bad) = t.iter().find(|&&i| i >= vertex_count) {
                    let shown = if signed {
                        i64::from(bad as i32)
                    } else {
                        i64::from(bad)
                    };
                    return Err(self.face_err(
                        start,
                        format!(
                            "face {item}: vertex index {shown} out of range \
                             ({vertex_count} vertices)"
                        ),
                    ));
                }
                mesh.triangles.push(t);
            } else {
                let ty = match e.properties[0].kind {
                    Kind::List { item, .. } => item,
                    Kind::Scalar(s) => s,
                };
                for (k, slot) in face[..n].iter_mut().enumerate() {
                    *slot = as_index(ty.read(&data[4 * k..], big));
                }
                add_face(&face[..n], item, vertex_count, mesh)
                    .map_err(|m| self.face_err(start, m))?;
            }
            pos = end;
        }
        Ok(pos)
    }

    /// Steps over an element the loader does not read; returns the position after it.
    fn skip_element(
        &self,
        mut pos: usize,
        e: &Element,
        stride: Option<usize>,
    ) -> Result<usize, LoadError> {
        if let Some(stride) = stride {
            return Ok(pos + e.count as usize * stride);
        }
        let mut values = vec![0.0f64; e.properties.len()];
        for item in 0..e.count {
            pos = read_item_binary(self.bytes, pos, e, self.big, &mut values, None)
                .ok_or_else(|| self.truncated(pos, e, item))?;
        }
        Ok(pos)
    }
}

/// Offsets and types of x, y, z (property indices `axes`) inside one fixed-size item of `e`.
fn axis_offsets(e: &Element, axes: [Option<usize>; 3]) -> [(usize, Scalar); 3] {
    let mut offsets = [(0usize, Scalar::F32); 3];
    for (slot, axis) in offsets.iter_mut().zip(axes) {
        let axis = axis.unwrap_or(0);
        let offset: usize = e.properties[..axis]
            .iter()
            .map(|p| match p.kind {
                Kind::Scalar(s) => s.size(),
                Kind::List { .. } => 0,
            })
            .sum();
        let ty = match e.properties[axis].kind {
            Kind::Scalar(s) => s,
            Kind::List { .. } => Scalar::F32,
        };
        *slot = (offset, ty);
    }
    offsets
}

/// Reads one binary item of `e` at `pos`: scalars go to `values`, the items of list property
/// `list.0` (if given) to `list.1`, other lists are skipped. Returns the position after the
/// item, or `None` when the data ends early.
fn read_item_binary(
    bytes: &[u8],
    mut pos: usize,
    e: &Element,
    big: bool,
    values: &mut [f64],
    mut list: Option<(usize, &mut Vec<i64>)>,
) -> Option<usize> {
    for (i, p) in e.properties.iter().enumerate() {
        match p.kind {
            Kind::Scalar(s) => {
                values[i] = s.read(bytes.get(pos..pos + s.size())?, big);
                pos += s.size();
            }
            Kind::List { count, item } => {
                let n = as_index(count.read(bytes.get(pos..pos + count.size())?, big));
                pos += count.size();
                let n = usize::try_from(n).ok()?;
                let len = n.checked_mul(item.size())?;
                let data = bytes.get(pos..pos.checked_add(len)?)?;
                if let Some((target, out)) = list.as_mut() {
                    if *target == i {
                        out.extend(
                            data.chunks_exact(item.size())
                                .map(|b| as_index(item.read(b, big))),
                        );
                    }
                }
                pos += len;
            }
        }
    }
    Some(pos)
}
