//! The IBSP v46 header, its 17-entry lump directory and the fixed-size records of the lumps the
//! loader needs, read without trusting any offset, length or count in the file.
//!
//! Layout from `shared/scenes/SOURCES.md` ("IBSP version 46 layout"), which follows the
//! "Unofficial Quake 3 Map Specs". Everything is little-endian. This module only slices and
//! decodes; cross-references between lumps (indices into other lumps) are checked in `mod.rs`.

use std::path::Path;

use super::super::error::{LoadError, Location};

/// Size of the header: magic, version, 17 directory entries of two `int32`.
pub(super) const HEADER_BYTES: usize = 8 + 17 * 8;

/// Lump numbers, in directory order.
pub(super) const ENTITIES: usize = 0;
pub(super) const SHADERS: usize = 1;
pub(super) const PLANES: usize = 2;
pub(super) const NODES: usize = 3;
pub(super) const LEAFS: usize = 4;
pub(super) const LEAFSURFACES: usize = 5;
pub(super) const MODELS: usize = 7;
pub(super) const DRAWVERTS: usize = 10;
pub(super) const DRAWINDEXES: usize = 11;
pub(super) const SURFACES: usize = 13;
pub(super) const VISDATA: usize = 16;

/// Lump names for error messages, indexed by lump number.
pub(super) const LUMP_NAMES: [&str; 17] = [
    "entities",
    "shaders",
    "planes",
    "nodes",
    "leafs",
    "leafsurfaces",
    "leafbrushes",
    "models",
    "brushes",
    "brushsides",
    "drawverts",
    "drawindexes",
    "fogs",
    "surfaces",
    "lightmaps",
    "lightgrid",
    "visdata",
];

/// Record sizes in bytes of the lumps we decode (0 = text or variable layout).
const RECORD_BYTES: [usize; 17] = [0, 72, 16, 36, 48, 4, 0, 40, 0, 0, 44, 4, 0, 104, 0, 0, 0];

/// "lump 13 (surfaces), record 12": the place of one record, for error messages.
pub(super) fn record_location(lump: usize, record: usize) -> Location {
    Location::Element(format!(
        "lump {lump} ({}), record {record}",
        LUMP_NAMES[lump]
    ))
}

/// Reads the little-endian `i32` at byte `at` of a record. Records come from `chunks_exact`
/// with the layout's size, so an out-of-range `at` is a bug in this module, not bad input.
pub(super) fn i32_at(record: &[u8], at: usize) -> i32 {
    i32::from_le_bytes([record[at], record[at + 1], record[at + 2], record[at + 3]])
}

/// Reads the little-endian `f32` at byte `at` of a record (see [`i32_at`]).
pub(super) fn f32_at(record: &[u8], at: usize) -> f32 {
    f32::from_bits(i32_at(record, at) as u32)
}

/// Reads three consecutive `i32` starting at byte `at`.
pub(super) fn i32x3_at(record: &[u8], at: usize) -> [i32; 3] {
    [
        i32_at(record, at),
        i32_at(record, at + 4),
        i32_at(record, at + 8),
    ]
}

/// Reads three consecutive `f32` starting at byte `at`.
pub(super) fn f32x3_at(record: &[u8], at: usize) -> [f32; 3] {
    [
        f32_at(record, at),
        f32_at(record, at + 4),
        f32_at(record, at + 8),
    ]
}

/// A surface record of lump 13, the fields the loader uses.
#[derive(Clone, Copy, Debug)]
pub(super) struct RawSurface {
    pub(super) shader: i32,
    pub(super) kind: i32,
    pub(super) first_vert: i32,
    pub(super) num_verts: i32,
    pub(super) first_index: i32,
    pub(super) num_indexes: i32,
    pub(super) patch_width: i32,
    pub(super) patch_height: i32,
}

impl RawSurface {
    /// Decodes one 104-byte record of lump 13.
    pub(super) fn read(record: &[u8]) -> Self {
        RawSurface {
            shader: i32_at(record, 0),
            kind: i32_at(record, 8),
            first_vert: i32_at(record, 12),
            num_verts: i32_at(record, 16),
            first_index: i32_at(record, 20),
            num_indexes: i32_at(record, 24),
            patch_width: i32_at(record, 96),
            patch_height: i32_at(record, 100),
        }
    }
}

/// The file's bytes with a checked lump directory.
pub(super) struct Lumps<'a> {
    bytes: &'a [u8],
    /// `(offset, length)` of each lump, already known to lie inside `bytes`.
    ranges: [(usize, usize); 17],
}

impl<'a> Lumps<'a> {
    /// Checks magic, version and every directory entry.
    pub(super) fn parse(path: &Path, bytes: &'a [u8]) -> Result<Self, LoadError> {
        if bytes.len() < HEADER_BYTES {
            return Err(LoadError::parse(
                path,
                Location::Byte(bytes.len() as u64),
                format!(
                    "file is {} bytes, shorter than the {HEADER_BYTES}-byte IBSP header",
                    bytes.len()
                ),
            ));
        }
        if &bytes[0..4] != b"IBSP" {
            return Err(LoadError::parse(
                path,
                Location::Byte(0),
                format!(
                    "magic is {:?}, expected \"IBSP\" (not a Quake 3 BSP file)",
                    String::from_utf8_lossy(&bytes[0..4])
                ),
            ));
        }
        let version = i32_at(bytes, 4);
        if version != 46 {
            return Err(LoadError::parse(
                path,
                Location::Byte(4),
                format!("IBSP version {version}, only version 46 (Quake 3 Arena) is supported"),
            ));
        }
        let mut ranges = [(0usize, 0usize); 17];
        for (lump, range) in ranges.iter_mut().enumerate() {
            let entry = 8 + lump * 8;
            let offset = i32_at(bytes, entry);
            let length = i32_at(bytes, entry + 4);
            let name = LUMP_NAMES[lump];
            let here = Location::Byte(entry as u64);
            if offset < 0 || length < 0 {
                return Err(LoadError::parse(
                    path,
                    here,
                    format!("lump {lump} ({name}): negative offset {offset} or length {length}"),
                ));
            }
            // Both fit in i32, so the sum cannot overflow i64 / u64 arithmetic.
            let end = offset as u64 + length as u64;
            if end > bytes.len() as u64 {
                return Err(LoadError::parse(
                    path,
                    here,
                    format!(
                        "lump {lump} ({name}) at offset {offset} with length {length} ends at \
                         byte {end}, past the end of the file ({} bytes)",
                        bytes.len()
                    ),
                ));
            }
            let record = RECORD_BYTES[lump];
            if record != 0 && (length as usize) / record * record != length as usize {
                return Err(LoadError::parse(
                    path,
                    here,
                    format!(
                        "lump {lump} ({name}) at offset {offset}: length {length} is not a \
                         multiple of its {record}-byte record size"
                    ),
                ));
            }
            *range = (offset as usize, length as usize);
        }
        Ok(Self { bytes, ranges })
    }

    /// The raw bytes of a lump.
    pub(super) fn raw(&self, lump: usize) -> &'a [u8] {
        let (offset, length) = self.ranges[lump];
        &self.bytes[offset..offset + length]
    }

    /// File offset of a lump (for error locations inside variable-layout lumps).
    pub(super) fn offset(&self, lump: usize) -> usize {
        self.ranges[lump].0
    }

    /// The records of a fixed-size lump (the directory check made the length a multiple).
    pub(super) fn records(&self, lump: usize) -> std::slice::ChunksExact<'a, u8> {
        debug_assert!(
            RECORD_BYTES[lump] != 0,
            "lump {lump} has no fixed record size"
        );
        self.raw(lump).chunks_exact(RECORD_BYTES[lump])
    }

    /// Number of records of a fixed-size lump.
    pub(super) fn count(&self, lump: usize) -> usize {
        self.ranges[lump].1 / RECORD_BYTES[lump]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header() -> Vec<u8> {
        let mut b = vec![0u8; HEADER_BYTES];
        b[0..4].copy_from_slice(b"IBSP");
        b[4..8].copy_from_slice(&46i32.to_le_bytes());
        for lump in 0..17 {
            b[8 + lump * 8..12 + lump * 8].copy_from_slice(&(HEADER_BYTES as i32).to_le_bytes());
        }
        b
    }

    #[test]
    fn empty_lumps_parse() {
        let b = header();
        let l = Lumps::parse(Path::new("x.bsp"), &b).expect("valid header");
        for lump in 0..17 {
            assert!(l.raw(lump).is_empty());
        }
    }

    #[test]
    fn short_file_is_error() {
        let e = Lumps::parse(Path::new("x.bsp"), b"IBSP")
            .err()
            .expect("error");
        assert!(e.to_string().contains("header"), "{e}");
    }

    #[test]
    fn odd_record_length_names_lump() {
        let mut b = header();
        b.extend_from_slice(&[0; 10]);
        b[8 + SURFACES * 8 + 4..8 + SURFACES * 8 + 8].copy_from_slice(&10i32.to_le_bytes());
        let e = Lumps::parse(Path::new("x.bsp"), &b).err().expect("error");
        let s = e.to_string();
        assert!(
            s.contains("lump 13 (surfaces)") && s.contains("multiple"),
            "{s}"
        );
    }

    #[test]
    fn lump_past_end_names_lump_and_offset() {
        let mut b = header();
        b[8 + PLANES * 8..12 + PLANES * 8].copy_from_slice(&1000i32.to_le_bytes());
        b[8 + PLANES * 8 + 4..8 + PLANES * 8 + 8].copy_from_slice(&16i32.to_le_bytes());
        let e = Lumps::parse(Path::new("x.bsp"), &b).err().expect("error");
        let s = e.to_string();
        assert!(
            s.contains("lump 2 (planes)") && s.contains("offset 1000"),
            "{s}"
        );
    }
}
