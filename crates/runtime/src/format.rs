//! The `.pvs` binary layout (versions 1 and 2; the contract is `docs/pvs-format.md`): constants
//! the writer shares, the parser that checks a whole file's structure and checksums without
//! decoding its sets, and the set decoder.
//!
//! Parsing keeps only offsets: a cell's geometry is read from the file bytes when asked and a
//! set is decoded only when a query needs it, so opening a file costs one pass of CRC-32 over
//! it and a few bytes of tables per cell and object.

use std::ops::Range;

use crate::error::Error;

/// The file's first eight bytes (the CR LF and Ctrl-Z catch text-mode mangling, as PNG's do).
pub const MAGIC: [u8; 8] = *b"SLPVS\r\n\x1a";
/// The newest version: this build writes it and reads it and version 1.
pub const VERSION: u32 = 2;
/// Bytes of a version-1 cell record.
pub const CELL_RECORD_BYTES_V1: usize = 76;
/// Bytes of a version-2 cell record.
pub const CELL_RECORD_BYTES_V2: usize = 84;
/// Bytes of a version-2 cell record in a file with [`FLAG_BOUND`].
pub const CELL_RECORD_BYTES_BOUND: usize = 100;
/// Header flag: every cell also holds a conservative bound, stored as the triangles and
/// objects it adds to the cell's set ("might be visible"). Only in version 2.
pub const FLAG_BOUND: u32 = 1;
/// Bytes of a version-2 object record.
pub const OBJECT_RECORD_BYTES: usize = 40;
/// Set encoding: ascending ids as LEB128 varints of the gaps.
pub const ENCODING_DELTA_VARINT: u8 = 0;
/// Set encoding: one bit per id, LSB first.
pub const ENCODING_BITSET: u8 = 1;
/// `index` / `part` of an object that has none.
pub const NO_INDEX: u32 = u32::MAX;
/// Refuse metadata and name blobs beyond this size: a corrupted length must not allocate
/// gigabytes.
pub const MAX_BLOB_BYTES: usize = 64 << 20;

/// Where one encoded set lies in the file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SetRef {
    /// [`ENCODING_DELTA_VARINT`] or [`ENCODING_BITSET`].
    pub encoding: u8,
    /// Number of ids the record says the set holds.
    pub size: u32,
    /// Byte offset of the payload in the file.
    pub offset: usize,
    /// Payload length in bytes.
    pub len: usize,
}

impl SetRef {
    /// The payload bytes within `file`.
    pub fn payload<'a>(&self, file: &'a [u8]) -> &'a [u8] {
        &file[self.offset..self.offset + self.len]
    }
}

/// One object record of a version-2 file.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct ObjectRecord {
    pub name: Range<usize>,
    pub index: u32,
    pub part: u32,
    pub bounds_min: [f32; 3],
    pub bounds_max: [f32; 3],
}

/// Everything a parse learns, as offsets into the file.
#[derive(Clone, Debug)]
pub(crate) struct Layout {
    pub version: u32,
    /// Whether every cell holds a conservative bound ([`FLAG_BOUND`]).
    pub bound: bool,
    pub scene_hash: u64,
    pub triangle_count: u32,
    pub metadata: Range<usize>,
    pub objects: Vec<ObjectRecord>,
    /// Triangle runs of every object: object `o`'s runs are
    /// `runs[run_start[o] as usize..run_start[o + 1] as usize]`, as (first triangle, count).
    pub run_start: Vec<u32>,
    pub runs: Vec<(u32, u32)>,
    /// The runs in triangle order, as (first triangle, object): the triangle-to-object map.
    pub runs_in_order: Vec<(u32, u32)>,
    pub cell_table: usize,
    pub cell_record_bytes: usize,
    pub cell_count: u32,
    /// Offset of every cell's first payload byte, plus one past the last cell's.
    pub payload_start: Vec<usize>,
}

impl Layout {
    /// The record bytes of cell `i` (< cell_count).
    pub fn record<'a>(&self, file: &'a [u8], i: u32) -> &'a [u8] {
        let start = self.cell_table + i as usize * self.cell_record_bytes;
        &file[start..start + self.cell_record_bytes]
    }

    /// The triangles and objects the conservative bound of cell `i` (< cell_count) adds to
    /// its sets, in a file with [`FLAG_BOUND`].
    pub fn bound_extra(&self, file: &[u8], i: u32) -> Option<(SetRef, SetRef)> {
        if !self.bound {
            return None;
        }
        let record = self.record(file, i);
        let (triangles, objects) = self.sets(file, i);
        let start = objects.map_or(triangles.offset + triangles.len, |o| o.offset + o.len);
        let extra_triangles = SetRef {
            encoding: record[62],
            size: read_u32(record, 80),
            offset: start,
            len: read_u32(record, 84) as usize,
        };
        let extra_objects = SetRef {
            encoding: record[63],
            size: read_u32(record, 88),
            offset: start + extra_triangles.len,
            len: read_u32(record, 92) as usize,
        };
        Some((extra_triangles, extra_objects))
    }

    /// The triangle set and (version 2) object set of cell `i` (< cell_count).
    pub fn sets(&self, file: &[u8], i: u32) -> (SetRef, Option<SetRef>) {
        let record = self.record(file, i);
        let start = self.payload_start[i as usize];
        let triangles = SetRef {
            encoding: record[60],
            size: read_u32(record, 64),
            offset: start,
            len: read_u32(record, 68) as usize,
        };
        let objects = (self.version >= 2).then(|| SetRef {
            encoding: record[61],
            size: read_u32(record, 72),
            offset: start + triangles.len,
            len: read_u32(record, 76) as usize,
        });
        (triangles, objects)
    }
}

pub(crate) fn read_u32(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]])
}

pub(crate) fn read_f32(b: &[u8], at: usize) -> f32 {
    f32::from_bits(read_u32(b, at))
}

pub(crate) fn read_vec3(b: &[u8], at: usize) -> [f32; 3] {
    [read_f32(b, at), read_f32(b, at + 4), read_f32(b, at + 8)]
}

/// Bounds-checked little-endian reading with error offsets.
struct Reader<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8], Error> {
        let end = self
            .pos
            .checked_add(n)
            .filter(|&e| e <= self.bytes.len())
            .ok_or_else(|| Error::Truncated {
                offset: self.bytes.len(),
                what: format!("{what} ({n} bytes at {})", self.pos),
            })?;
        let s = &self.bytes[self.pos..end];
        self.pos = end;
        Ok(s)
    }

    fn u32(&mut self, what: &str) -> Result<u32, Error> {
        self.take(4, what).map(|b| read_u32(b, 0))
    }

    fn u64(&mut self, what: &str) -> Result<u64, Error> {
        let b = self.take(8, what)?;
        let mut a = [0u8; 8];
        a.copy_from_slice(b);
        Ok(u64::from_le_bytes(a))
    }

    fn checked_len(&mut self, count: usize, each: usize, what: &str) -> Result<usize, Error> {
        count
            .checked_mul(each)
            .ok_or_else(|| Error::corrupt(self.pos, format!("{what}: count overflows")))
    }
}

/// Checks the structure and every checksum of a version-1 or version-2 file; sets are not
/// decoded (see [`decode_set`]).
pub(crate) fn parse(bytes: &[u8]) -> Result<Layout, Error> {
    if bytes.len() < MAGIC.len() || bytes[..MAGIC.len()] != MAGIC {
        return Err(Error::BadMagic);
    }
    let mut r = Reader {
        bytes,
        pos: MAGIC.len(),
    };
    let version = r.u32("version")?;
    if version != 1 && version != 2 {
        return Err(Error::UnsupportedVersion(version));
    }
    let flags = r.u32("flags")?;
    let scene_hash = r.u64("scene hash")?;
    let triangle_count = r.u32("triangle count")?;
    let cell_count = r.u32("cell count")?;
    let object_count = if version >= 2 {
        r.u32("object count")? as usize
    } else {
        0
    };
    let metadata_len = r.u32("metadata length")? as usize;
    if metadata_len > MAX_BLOB_BYTES {
        return Err(Error::corrupt(
            r.pos - 4,
            format!("metadata length {metadata_len} is implausible"),
        ));
    }
    let metadata_start = r.pos;
    let metadata_bytes = r.take(metadata_len, "metadata")?;
    let header_end = r.pos;
    let header_crc = r.u32("header checksum")?;
    if crc32fast::hash(&bytes[..header_end]) != header_crc {
        return Err(Error::corrupt(header_end, "header checksum"));
    }
    if flags & !FLAG_BOUND != 0 {
        return Err(Error::corrupt(12, format!("unknown flags {flags:#x}")));
    }
    let bound = flags & FLAG_BOUND != 0;
    if bound && version < 2 {
        return Err(Error::corrupt(
            12,
            "a version-1 file cannot hold conservative bounds (flag 1)",
        ));
    }
    if std::str::from_utf8(metadata_bytes).is_err() {
        return Err(Error::corrupt(metadata_start, "metadata is not UTF-8"));
    }

    let (objects, run_start, runs, runs_in_order) = if version >= 2 {
        parse_objects(&mut r, object_count, triangle_count)?
    } else {
        (Vec::new(), vec![0], Vec::new(), Vec::new())
    };

    let cell_record_bytes = if bound {
        CELL_RECORD_BYTES_BOUND
    } else if version >= 2 {
        CELL_RECORD_BYTES_V2
    } else {
        CELL_RECORD_BYTES_V1
    };
    let cell_table = r.pos;
    let table_len = r.checked_len(cell_count as usize, cell_record_bytes, "cell table")?;
    let table = r.take(table_len, "view-cell table")?;
    let mut payload_start = Vec::with_capacity(cell_count as usize + 1);
    for i in 0..cell_count as usize {
        let record = &table[i * cell_record_bytes..(i + 1) * cell_record_bytes];
        let record_offset = cell_table + i * cell_record_bytes;
        let axes = [
            read_vec3(record, 12),
            read_vec3(record, 24),
            read_vec3(record, 36),
        ];
        check_cell_geometry(read_vec3(record, 0), axes, read_vec3(record, 48))
            .map_err(|e| Error::corrupt(record_offset, format!("cell {i}: {e}")))?;
        let crc_at = cell_record_bytes - 4;
        let payload_len = record_payload_len(record, version, bound)
            .map_err(|what| Error::corrupt(record_offset + 62, format!("cell {i}: {what}")))?;
        payload_start.push(r.pos);
        let payload = r.take(payload_len, &format!("payload of cell {i}"))?;
        let mut hasher = crc32fast::Hasher::new();
        hasher.update(&record[..crc_at]);
        hasher.update(payload);
        if hasher.finalize() != read_u32(record, crc_at) {
            return Err(Error::corrupt(
                record_offset,
                format!("checksum of cell {i}"),
            ));
        }
    }
    payload_start.push(r.pos);
    if r.pos != bytes.len() {
        return Err(Error::corrupt(
            r.pos,
            format!("{} unexpected trailing bytes", bytes.len() - r.pos),
        ));
    }
    Ok(Layout {
        version,
        bound,
        scene_hash,
        triangle_count,
        metadata: metadata_start..header_end,
        objects,
        run_start,
        runs,
        runs_in_order,
        cell_table,
        cell_record_bytes,
        cell_count,
        payload_start,
    })
}

/// The bytes of all payloads of a cell `record`: its triangle set, (version 2) its object
/// set and (with bounds) the bound's two extra sets; or why the record is wrong.
fn record_payload_len(record: &[u8], version: u32, bound: bool) -> Result<usize, &'static str> {
    let mut len = u64::from(read_u32(record, 68));
    if version >= 2 {
        if !bound && (record[62] != 0 || record[63] != 0) {
            return Err("reserved bytes are not 0");
        }
        len += u64::from(read_u32(record, 76));
    }
    if bound {
        len += u64::from(read_u32(record, 84)) + u64::from(read_u32(record, 92));
    }
    // Four lengths below 2^32 sum below 2^34; `take` refuses a sum past the file.
    Ok(usize::try_from(len).unwrap_or(usize::MAX))
}

type ObjectTables = (
    Vec<ObjectRecord>,
    Vec<u32>,
    Vec<(u32, u32)>,
    Vec<(u32, u32)>,
);

/// The version-2 object section: records, triangle runs in triangle order, names, checksum.
fn parse_objects(
    r: &mut Reader<'_>,
    object_count: usize,
    triangle_count: u32,
) -> Result<ObjectTables, Error> {
    let section_start = r.pos;
    let names_len = r.u32("object names length")? as usize;
    if names_len > MAX_BLOB_BYTES {
        return Err(Error::corrupt(
            section_start,
            format!("object names length {names_len} is implausible"),
        ));
    }
    let run_count = r.u32("object run count")? as usize;
    let records_len = r.checked_len(object_count, OBJECT_RECORD_BYTES, "object table")?;
    let records_at = r.pos;
    let records = r.take(records_len, "object table")?;
    let runs_len = r.checked_len(run_count, 8, "object runs")?;
    let runs_at = r.pos;
    let run_bytes = r.take(runs_len, "object runs")?;
    let names_at = r.pos;
    let names = r.take(names_len, "object names")?;
    let section_end = r.pos;
    let crc = r.u32("object section checksum")?;
    if crc32fast::hash(&r.bytes[section_start..section_end]) != crc {
        return Err(Error::corrupt(section_end, "object section checksum"));
    }

    // Runs cover the triangles 0..N in order, each run one object's consecutive triangles.
    let mut per_object = vec![0u32; object_count + 1];
    let mut covered: u64 = 0;
    for k in 0..run_count {
        let object = read_u32(run_bytes, 8 * k) as usize;
        let count = read_u32(run_bytes, 8 * k + 4);
        let at = runs_at + 8 * k;
        if object >= object_count {
            return Err(Error::corrupt(
                at,
                format!("run {k} names object {object} of {object_count}"),
            ));
        }
        if count == 0 {
            return Err(Error::corrupt(at, format!("run {k} is empty")));
        }
        covered += u64::from(count);
        per_object[object + 1] += 1;
    }
    if covered != u64::from(triangle_count) {
        return Err(Error::corrupt(
            runs_at,
            format!("object runs cover {covered} triangles, the scene has {triangle_count}"),
        ));
    }
    for o in 0..object_count {
        per_object[o + 1] += per_object[o];
    }
    let run_start = per_object.clone();
    let mut fill = per_object;
    let mut runs = vec![(0u32, 0u32); run_count];
    let mut runs_in_order = Vec::with_capacity(run_count);
    let mut first = 0u32;
    for k in 0..run_count {
        let object = read_u32(run_bytes, 8 * k) as usize;
        let count = read_u32(run_bytes, 8 * k + 4);
        runs[fill[object] as usize] = (first, count);
        runs_in_order.push((first, object as u32));
        fill[object] += 1;
        first += count;
    }

    let mut objects = Vec::with_capacity(object_count);
    for o in 0..object_count {
        let rec = &records[o * OBJECT_RECORD_BYTES..(o + 1) * OBJECT_RECORD_BYTES];
        let at = records_at + o * OBJECT_RECORD_BYTES;
        let name_offset = read_u32(rec, 0) as usize;
        let name_len = read_u32(rec, 4) as usize;
        let name = name_offset..name_offset.saturating_add(name_len);
        if name.end > names_len {
            return Err(Error::corrupt(
                at,
                format!("object {o}: name lies past the names"),
            ));
        }
        if std::str::from_utf8(&names[name.clone()]).is_err() {
            return Err(Error::corrupt(
                names_at + name_offset,
                format!("object {o}: name is not UTF-8"),
            ));
        }
        let bounds_min = read_vec3(rec, 16);
        let bounds_max = read_vec3(rec, 28);
        let has_triangles = run_start[o] != run_start[o + 1];
        let bounds_ok = if has_triangles {
            (0..3).all(|k| {
                bounds_min[k].is_finite()
                    && bounds_max[k].is_finite()
                    && bounds_min[k] <= bounds_max[k]
            })
        } else {
            bounds_min == [f32::INFINITY; 3] && bounds_max == [f32::NEG_INFINITY; 3]
        };
        if !bounds_ok {
            return Err(Error::corrupt(at + 16, format!("object {o}: bad bounds")));
        }
        objects.push(ObjectRecord {
            name: names_at + name.start..names_at + name.end,
            index: read_u32(rec, 8),
            part: read_u32(rec, 12),
            bounds_min,
            bounds_max,
        });
    }
    Ok((objects, run_start, runs, runs_in_order))
}

/// Why a cell's geometry is not a view cell.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum CellGeometryError {
    /// A coordinate is NaN or infinite.
    #[error("view cell has a non-finite coordinate")]
    NotFinite,
    /// Negative extent, or zero extent along two or more axes (a line or a point).
    #[error("view cell extents {0:?} must be >= 0 with at most one zero (a rectangle)")]
    BadExtent([f32; 3]),
    /// The axes are not orthonormal.
    #[error("view cell axes are not orthonormal")]
    BadAxes,
}

/// The rule a view cell's geometry obeys, in the file and in memory (sightline-region's
/// `ViewCell::oriented` applies it too): finite, half extents >= 0 with at most one 0, axes
/// orthonormal within 1e-4.
pub fn check_cell_geometry(
    center: [f32; 3],
    axes: [[f32; 3]; 3],
    half_extents: [f32; 3],
) -> Result<(), CellGeometryError> {
    let all = center
        .iter()
        .chain(axes.iter().flatten())
        .chain(&half_extents);
    if all.clone().any(|v| !v.is_finite()) {
        return Err(CellGeometryError::NotFinite);
    }
    let zeros = half_extents.iter().filter(|&&h| h == 0.0).count();
    if half_extents.iter().any(|&h| h < 0.0) || zeros > 1 {
        return Err(CellGeometryError::BadExtent(half_extents));
    }
    let dot = |a: [f32; 3], b: [f32; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let orthonormal = axes.iter().all(|&a| (dot(a, a).sqrt() - 1.0).abs() < 1e-4)
        && dot(axes[0], axes[1]).abs() < 1e-4
        && dot(axes[1], axes[2]).abs() < 1e-4
        && dot(axes[0], axes[2]).abs() < 1e-4;
    if !orthonormal {
        return Err(CellGeometryError::BadAxes);
    }
    Ok(())
}

/// Why an encoded set of ids is malformed (the set's record and payload disagree, or the
/// payload breaks its encoding's rules).
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum SetError {
    /// A bitset payload whose length is not one bit per id, rounded up to whole bytes.
    #[error("bitset of {bytes} bytes for {ids} ids")]
    BitsetLength {
        /// Bytes of the payload.
        bytes: usize,
        /// Ids the set can hold (its capacity).
        ids: u64,
    },
    /// A bitset with a padding bit set, past the last id.
    #[error("bit set past the {ids} ids")]
    BitPastEnd {
        /// Ids the set can hold (its capacity).
        ids: u64,
    },
    /// A delta varint of more than 5 bytes (a `u32` gap takes at most 5).
    #[error("varint longer than 5 bytes")]
    VarintTooLong,
    /// A gap of 0 after the first id: an id listed twice.
    #[error("repeated id (zero gap)")]
    RepeatedId,
    /// An id at or past the capacity.
    #[error("id {id} past the {ids} ids")]
    IdPastEnd {
        /// The id.
        id: u64,
        /// Ids the set can hold (its capacity).
        ids: u64,
    },
    /// The payload ends inside a varint.
    #[error("payload ends inside a varint")]
    TruncatedVarint,
    /// An encoding byte that is neither [`ENCODING_BITSET`] nor [`ENCODING_DELTA_VARINT`].
    #[error("unknown set encoding {0}")]
    UnknownEncoding(u8),
    /// The payload holds another number of ids than the set's record says.
    #[error("set holds {count} ids, its record says {size}")]
    CountMismatch {
        /// Ids in the payload.
        count: u64,
        /// Ids the record says.
        size: u32,
    },
}

/// Decodes one set of ids below `capacity`, handing each id to `each` in ascending order, and
/// checks it completely: known encoding, bitset length, no bit past `capacity`, no varint
/// longer than 5 bytes, strictly ascending ids, no varint cut off, and exactly `size` ids.
pub fn decode_set(
    encoding: u8,
    payload: &[u8],
    capacity: u32,
    size: u32,
    mut each: impl FnMut(u32),
) -> Result<(), SetError> {
    let n = capacity as u64;
    let mut count: u64 = 0;
    match encoding {
        ENCODING_BITSET => {
            if payload.len() as u64 != n.div_ceil(8) {
                return Err(SetError::BitsetLength {
                    bytes: payload.len(),
                    ids: n,
                });
            }
            // Only the last byte can hold bits past the capacity.
            if let Some(&last) = payload.last() {
                let used = n - 8 * (payload.len() as u64 - 1);
                if used < 8 && last >> used != 0 {
                    return Err(SetError::BitPastEnd { ids: n });
                }
            }
            for (byte_index, &byte) in payload.iter().enumerate() {
                let mut b = byte;
                while b != 0 {
                    each(byte_index as u32 * 8 + b.trailing_zeros());
                    b &= b - 1;
                    count += 1;
                }
            }
        }
        ENCODING_DELTA_VARINT => {
            let mut id: u64 = 0;
            let mut value: u64 = 0;
            let mut shift = 0u32;
            for &byte in payload {
                if shift > 28 {
                    return Err(SetError::VarintTooLong);
                }
                value |= u64::from(byte & 0x7f) << shift;
                shift += 7;
                if byte & 0x80 != 0 {
                    continue;
                }
                if count > 0 && value == 0 {
                    return Err(SetError::RepeatedId);
                }
                id = if count == 0 { value } else { id + value };
                if id >= n {
                    return Err(SetError::IdPastEnd { id, ids: n });
                }
                each(id as u32);
                count += 1;
                value = 0;
                shift = 0;
            }
            if shift != 0 {
                return Err(SetError::TruncatedVarint);
            }
        }
        other => return Err(SetError::UnknownEncoding(other)),
    }
    if count != u64::from(size) {
        return Err(SetError::CountMismatch { count, size });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ids(encoding: u8, payload: &[u8], capacity: u32, size: u32) -> Result<Vec<u32>, String> {
        let mut out = Vec::new();
        decode_set(encoding, payload, capacity, size, |id| out.push(id))
            .map_err(|e| e.to_string())?;
        Ok(out)
    }

    #[test]
    fn varints_decode_gaps_and_refuse_bad_streams() {
        // 3, then +1 -> 4, then +200 (two bytes: 0xC8 0x01) -> 204.
        assert_eq!(
            ids(ENCODING_DELTA_VARINT, &[3, 1, 0xC8, 0x01], 300, 3).unwrap(),
            [3, 4, 204]
        );
        assert!(ids(ENCODING_DELTA_VARINT, &[3, 0], 300, 2)
            .unwrap_err()
            .contains("repeated"));
        assert!(ids(ENCODING_DELTA_VARINT, &[3, 0x80], 300, 2)
            .unwrap_err()
            .contains("inside a varint"));
        assert!(ids(ENCODING_DELTA_VARINT, &[0x80; 6], u32::MAX, 1)
            .unwrap_err()
            .contains("5 bytes"));
        assert!(ids(ENCODING_DELTA_VARINT, &[10], 10, 1)
            .unwrap_err()
            .contains("past"));
        assert!(ids(ENCODING_DELTA_VARINT, &[1, 1], 10, 3)
            .unwrap_err()
            .contains("record says 3"));
        // The largest u32 gap takes five bytes and is accepted.
        let max = [0xFE, 0xFF, 0xFF, 0xFF, 0x0F];
        assert_eq!(
            ids(ENCODING_DELTA_VARINT, &max, u32::MAX, 1).unwrap(),
            [u32::MAX - 1]
        );
    }

    #[test]
    fn bitsets_check_length_and_padding_bits() {
        assert_eq!(
            ids(ENCODING_BITSET, &[0b101, 0b1], 9, 3).unwrap(),
            [0, 2, 8]
        );
        assert!(ids(ENCODING_BITSET, &[0, 0b10], 9, 1)
            .unwrap_err()
            .contains("past"));
        assert!(ids(ENCODING_BITSET, &[0], 9, 0)
            .unwrap_err()
            .contains("bytes"));
        assert_eq!(ids(ENCODING_BITSET, &[], 0, 0).unwrap(), Vec::<u32>::new());
        assert!(ids(7, &[], 0, 0).unwrap_err().contains("unknown"));
    }
}
