//! The `.pvs` file: one potentially visible set per view cell, bound to the scene it was
//! computed for. Layout (all little-endian; full description in `docs/pvs-format.md`):
//!
//! ```text
//! header   magic "SLPVS\r\n\x1a" | version u32 = 1 | flags u32 = 0 | scene hash u64
//!          | scene triangle count u32 | cell count u32 | metadata length u32 | metadata (JSON)
//!          | CRC-32 of all header bytes before it
//! cells    per cell, 76 bytes: centre 3xf32 | axes 9xf32 | half extents 3xf32 | encoding u8
//!          | 3 reserved bytes | set size u32 | payload length u32
//!          | CRC-32 of the record's first 72 bytes followed by the payload
//! payloads one per cell, in cell order: encoding 0 = ascending ids as LEB128 varints of the
//!          gaps (first id, then id - previous id); encoding 1 = bitset, ceil(n/8) bytes,
//!          bit i = byte i/8, bit i%8 (LSB first). The writer picks the smaller.
//! ```
//!
//! The magic's CR LF and Ctrl-Z catch text-mode mangling (as PNG's does). The scene hash is
//! [`Scene::geometry_hash`]: a file made for another scene (or another tessellation of the
//! same map) is rejected. Files are written atomically.

use std::io::{self, Write};
use std::path::{Path, PathBuf};

use glam::Vec3;
use sightline_core::atomic_file::write_atomic;
use sightline_core::{Scene, TriangleSet};

use crate::viewcell::ViewCell;

/// The file's first eight bytes.
pub const MAGIC: [u8; 8] = *b"SLPVS\r\n\x1a";
/// The format version this code writes and reads.
pub const VERSION: u32 = 1;
/// Bytes of one cell record in the table (beside its payload).
pub const CELL_RECORD_BYTES: usize = 76;
const ENCODING_DELTA_VARINT: u8 = 0;
const ENCODING_BITSET: u8 = 1;
/// Refuse metadata blobs beyond this size: a corrupted length must not allocate gigabytes.
const MAX_METADATA_BYTES: usize = 64 << 20;

/// Why a `.pvs` file could not be read or used.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PvsError {
    /// The file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: io::Error,
    },
    /// The file does not start with the `.pvs` magic.
    #[error("not a .pvs file (bad magic bytes)")]
    BadMagic,
    /// The version is not one this build reads.
    #[error("unsupported .pvs version {0} (this build reads version {VERSION})")]
    UnsupportedVersion(u32),
    /// The file ends early.
    #[error("truncated at byte {offset}: expected {what}")]
    Truncated {
        /// Where the data ran out.
        offset: usize,
        /// What was being read.
        what: String,
    },
    /// A checksum or value does not match.
    #[error("corrupt at byte {offset}: {what}")]
    Corrupt {
        /// Where.
        offset: usize,
        /// What is wrong.
        what: String,
    },
    /// The file was made for another scene.
    #[error(
        "this PVS was computed for another scene (file: {file_triangles} triangles, hash \
         {file_hash:016x}; scene: {scene_triangles} triangles, hash {scene_hash:016x})"
    )]
    SceneMismatch {
        /// Hash in the file.
        file_hash: u64,
        /// Hash of the scene.
        scene_hash: u64,
        /// Triangle count in the file.
        file_triangles: u32,
        /// Triangle count of the scene.
        scene_triangles: usize,
    },
    /// The data to write is inconsistent (e.g. a set larger than the scene).
    #[error("cannot write: {0}")]
    Invalid(String),
}

/// The PVS of one view cell.
#[derive(Clone, Debug, PartialEq)]
pub struct CellPvs {
    /// The cell.
    pub cell: ViewCell,
    /// Triangle ids potentially visible from the cell.
    pub visible: TriangleSet,
}

/// A whole `.pvs` file in memory.
#[derive(Clone, Debug, PartialEq)]
pub struct PvsFile {
    /// [`Scene::geometry_hash`] of the scene the sets index.
    pub scene_hash: u64,
    /// Triangle count of that scene (every set has this capacity).
    pub triangle_count: u32,
    /// Free-form JSON: method, parameters, seed, statistics.
    pub metadata: serde_json::Value,
    /// One entry per view cell.
    pub cells: Vec<CellPvs>,
}

impl PvsFile {
    /// An empty file bound to `scene`.
    pub fn for_scene(scene: &Scene, metadata: serde_json::Value) -> Self {
        Self {
            scene_hash: scene.geometry_hash(),
            triangle_count: scene.triangle_count() as u32,
            metadata,
            cells: Vec::new(),
        }
    }

    /// Checks that the file belongs to `scene`.
    pub fn check_scene(&self, scene: &Scene) -> Result<(), PvsError> {
        let scene_hash = scene.geometry_hash();
        if scene_hash != self.scene_hash || scene.triangle_count() != self.triangle_count as usize {
            return Err(PvsError::SceneMismatch {
                file_hash: self.scene_hash,
                scene_hash,
                file_triangles: self.triangle_count,
                scene_triangles: scene.triangle_count(),
            });
        }
        Ok(())
    }

    /// Serialises the file.
    pub fn write(&self, w: &mut impl Write) -> Result<(), PvsError> {
        let n = self.triangle_count as usize;
        let mut cells = Vec::with_capacity(self.cells.len());
        for (i, c) in self.cells.iter().enumerate() {
            if c.visible.ones().any(|id| id >= n) {
                return Err(PvsError::Invalid(format!(
                    "cell {i} names a triangle id >= the scene's {n} triangles"
                )));
            }
            cells.push((c.cell, EncodedSet::encode(&c.visible, n)));
        }
        write_encoded(
            w,
            self.scene_hash,
            self.triangle_count,
            &self.metadata,
            cells.iter().map(|(c, s)| (c, s)),
        )
    }

    /// Writes the file to `path` atomically (an existing file is replaced only on success).
    pub fn save(&self, path: &Path) -> Result<(), PvsError> {
        let mut bytes = Vec::new();
        self.write(&mut bytes)?;
        write_atomic(path, |w| w.write_all(&bytes)).map_err(|source| PvsError::Io {
            path: path.to_path_buf(),
            source,
        })
    }

    /// Reads a file from `path`.
    pub fn load(path: &Path) -> Result<Self, PvsError> {
        let bytes = std::fs::read(path).map_err(|source| PvsError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Self::read(&bytes)
    }

    /// Parses a file from its bytes.
    pub fn read(bytes: &[u8]) -> Result<Self, PvsError> {
        let mut cells = Vec::new();
        let (scene_hash, triangle_count, metadata) = parse(bytes, &mut |cell, _, visible| {
            cells.push(CellPvs { cell, visible })
        })?;
        Ok(Self {
            scene_hash,
            triangle_count,
            metadata,
            cells,
        })
    }
}

/// A `.pvs` file with its sets left encoded: what tools handling many cells of large scenes
/// (checkpoints, merges) read, so the sets are never all decoded at once.
#[derive(Clone, Debug, PartialEq)]
pub struct EncodedPvsFile {
    /// [`Scene::geometry_hash`] of the scene the sets index.
    pub scene_hash: u64,
    /// Triangle count of that scene.
    pub triangle_count: u32,
    /// Free-form JSON metadata.
    pub metadata: serde_json::Value,
    /// One entry per view cell.
    pub cells: Vec<(ViewCell, EncodedSet)>,
}

impl EncodedPvsFile {
    /// Parses and fully checks a file (every set is decoded once to validate it).
    pub fn read(bytes: &[u8]) -> Result<Self, PvsError> {
        let mut cells = Vec::new();
        let (scene_hash, triangle_count, metadata) =
            parse(bytes, &mut |cell, set, _| cells.push((cell, set)))?;
        Ok(Self {
            scene_hash,
            triangle_count,
            metadata,
            cells,
        })
    }

    /// Reads a file from `path`.
    pub fn load(path: &Path) -> Result<Self, PvsError> {
        let bytes = std::fs::read(path).map_err(|source| PvsError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Self::read(&bytes)
    }

    /// Writes the file to `path` atomically.
    pub fn save(&self, path: &Path) -> Result<(), PvsError> {
        save_encoded(
            path,
            self.scene_hash,
            self.triangle_count,
            &self.metadata,
            self.cells.iter().map(|(c, s)| (c, s)),
        )
    }
}

/// Parses and checks a `.pvs` file, handing every cell to `keep` (its cell, encoded set and
/// decoded set); returns the scene hash, triangle count and metadata.
fn parse(
    bytes: &[u8],
    keep: &mut dyn FnMut(ViewCell, EncodedSet, TriangleSet),
) -> Result<(u64, u32, serde_json::Value), PvsError> {
    let mut r = Reader { bytes, pos: 0 };
    if bytes.len() < MAGIC.len() || bytes[..MAGIC.len()] != MAGIC {
        return Err(PvsError::BadMagic);
    }
    r.pos = MAGIC.len();
    let version = r.u32("version")?;
    if version != VERSION {
        return Err(PvsError::UnsupportedVersion(version));
    }
    let _flags = r.u32("flags")?;
    let scene_hash = r.u64("scene hash")?;
    let triangle_count = r.u32("triangle count")?;
    let cell_count = r.u32("cell count")? as usize;
    let metadata_len = r.u32("metadata length")? as usize;
    if metadata_len > MAX_METADATA_BYTES {
        return Err(PvsError::Corrupt {
            offset: r.pos - 4,
            what: format!("metadata length {metadata_len} is implausible"),
        });
    }
    let metadata_bytes = r.take(metadata_len, "metadata")?;
    let header_end = r.pos;
    let header_crc = r.u32("header checksum")?;
    if crc32fast::hash(&bytes[..header_end]) != header_crc {
        return Err(PvsError::Corrupt {
            offset: header_end,
            what: "header checksum".into(),
        });
    }
    let metadata = serde_json::from_slice(metadata_bytes).map_err(|e| PvsError::Corrupt {
        offset: header_end - metadata_len,
        what: format!("metadata is not JSON: {e}"),
    })?;
    let table_start = r.pos;
    let table_len = cell_count
        .checked_mul(CELL_RECORD_BYTES)
        .ok_or(PvsError::Corrupt {
            offset: table_start,
            what: "cell count overflows".into(),
        })?;
    let table = r.take(table_len, "view-cell table")?;
    let n = triangle_count as usize;
    for i in 0..cell_count {
        let record = &table[i * CELL_RECORD_BYTES..(i + 1) * CELL_RECORD_BYTES];
        let record_offset = table_start + i * CELL_RECORD_BYTES;
        let f = |k: usize| f32::from_le_bytes(le4(&record[4 * k..]));
        let v = |k: usize| Vec3::new(f(k), f(k + 1), f(k + 2));
        let encoding = record[60];
        let size = u32::from_le_bytes(le4(&record[64..])) as usize;
        let payload_len = u32::from_le_bytes(le4(&record[68..])) as usize;
        let crc = u32::from_le_bytes(le4(&record[72..]));
        let payload_offset = r.pos;
        let payload = r.take(payload_len, &format!("payload of cell {i}"))?;
        let mut hasher = crc32fast::Hasher::new();
        hasher.update(&record[..72]);
        hasher.update(payload);
        if hasher.finalize() != crc {
            return Err(PvsError::Corrupt {
                offset: record_offset,
                what: format!("checksum of cell {i}"),
            });
        }
        let corrupt = |what: String| PvsError::Corrupt {
            offset: payload_offset,
            what,
        };
        let visible =
            decode_set(encoding, payload, n).map_err(|e| corrupt(format!("cell {i}: {e}")))?;
        if visible.count_ones(..) != size {
            return Err(corrupt(format!(
                "cell {i}: set size does not match its record"
            )));
        }
        let cell =
            ViewCell::oriented(v(0), [v(3), v(6), v(9)], v(12)).map_err(|e| PvsError::Corrupt {
                offset: record_offset,
                what: format!("cell {i}: {e}"),
            })?;
        let encoded = EncodedSet {
            encoding,
            size: size as u32,
            payload: payload.to_vec(),
        };
        keep(cell, encoded, visible);
    }
    if r.pos != bytes.len() {
        return Err(PvsError::Corrupt {
            offset: r.pos,
            what: format!("{} unexpected trailing bytes", bytes.len() - r.pos),
        });
    }
    Ok((scene_hash, triangle_count, metadata))
}

/// A set in its file encoding (the smaller of delta varints and bitset): how a bake keeps
/// finished cells in memory, and what it writes without decoding them again.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct EncodedSet {
    encoding: u8,
    size: u32,
    payload: Vec<u8>,
}

impl EncodedSet {
    /// Encodes `set` for a scene of `n` triangles (ids must be below `n`).
    pub fn encode(set: &TriangleSet, n: usize) -> Self {
        let (encoding, payload) = encode_set(set, n);
        Self {
            encoding,
            size: set.count_ones(..) as u32,
            payload,
        }
    }

    /// The set, with capacity `n`.
    pub fn decode(&self, n: usize) -> Result<TriangleSet, String> {
        decode_set(self.encoding, &self.payload, n)
    }

    /// Number of ids in the set.
    pub fn len(&self) -> usize {
        self.size as usize
    }

    /// True when the set is empty.
    pub fn is_empty(&self) -> bool {
        self.size == 0
    }

    /// Bytes of the encoded payload (what the set costs in memory and on disk, beyond the
    /// fixed 76-byte record).
    pub fn payload_bytes(&self) -> usize {
        self.payload.len()
    }
}

/// Writes a `.pvs` stream from already encoded sets, so a bake of thousands of cells never
/// holds them all decoded. The caller guarantees every set was encoded for `triangle_count`.
pub fn write_encoded<'a>(
    w: &mut impl Write,
    scene_hash: u64,
    triangle_count: u32,
    metadata: &serde_json::Value,
    cells: impl ExactSizeIterator<Item = (&'a ViewCell, &'a EncodedSet)>,
) -> Result<(), PvsError> {
    let metadata =
        serde_json::to_vec(metadata).map_err(|e| PvsError::Invalid(format!("metadata: {e}")))?;
    let cell_count = cells.len();
    let mut header = Vec::with_capacity(40 + metadata.len());
    header.extend_from_slice(&MAGIC);
    header.extend_from_slice(&VERSION.to_le_bytes());
    header.extend_from_slice(&0u32.to_le_bytes());
    header.extend_from_slice(&scene_hash.to_le_bytes());
    header.extend_from_slice(&triangle_count.to_le_bytes());
    header.extend_from_slice(&(cell_count as u32).to_le_bytes());
    header.extend_from_slice(&(metadata.len() as u32).to_le_bytes());
    header.extend_from_slice(&metadata);
    header.extend_from_slice(&crc32fast::hash(&header).to_le_bytes());

    let mut records = Vec::with_capacity(cell_count * CELL_RECORD_BYTES);
    let mut payloads: Vec<&[u8]> = Vec::with_capacity(cell_count);
    for (cell, set) in cells {
        let mut record = Vec::with_capacity(CELL_RECORD_BYTES);
        let floats = [cell.center, cell.axes[0], cell.axes[1], cell.axes[2]]
            .into_iter()
            .chain([cell.half_extents])
            .flat_map(|v| v.to_array());
        for f in floats {
            record.extend_from_slice(&f.to_le_bytes());
        }
        record.push(set.encoding);
        record.extend_from_slice(&[0; 3]);
        record.extend_from_slice(&set.size.to_le_bytes());
        record.extend_from_slice(&(set.payload.len() as u32).to_le_bytes());
        let mut crc = crc32fast::Hasher::new();
        crc.update(&record);
        crc.update(&set.payload);
        record.extend_from_slice(&crc.finalize().to_le_bytes());
        records.extend_from_slice(&record);
        payloads.push(&set.payload);
    }
    let io = |source| PvsError::Io {
        path: PathBuf::from("<stream>"),
        source,
    };
    w.write_all(&header).map_err(io)?;
    w.write_all(&records).map_err(io)?;
    for p in payloads {
        w.write_all(p).map_err(io)?;
    }
    Ok(())
}

/// [`write_encoded`] to `path`, atomically (an existing file is replaced only on success).
pub fn save_encoded<'a>(
    path: &Path,
    scene_hash: u64,
    triangle_count: u32,
    metadata: &serde_json::Value,
    cells: impl ExactSizeIterator<Item = (&'a ViewCell, &'a EncodedSet)>,
) -> Result<(), PvsError> {
    let mut bytes = Vec::new();
    write_encoded(&mut bytes, scene_hash, triangle_count, metadata, cells)?;
    write_atomic(path, |w| w.write_all(&bytes)).map_err(|source| PvsError::Io {
        path: path.to_path_buf(),
        source,
    })
}

fn le4(b: &[u8]) -> [u8; 4] {
    [b[0], b[1], b[2], b[3]]
}

/// Bounds-checked little-endian reading with error offsets.
struct Reader<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8], PvsError> {
        let end = self
            .pos
            .checked_add(n)
            .filter(|&e| e <= self.bytes.len())
            .ok_or_else(|| PvsError::Truncated {
                offset: self.bytes.len(),
                what: format!("{what} ({n} bytes at {})", self.pos),
            })?;
        let s = &self.bytes[self.pos..end];
        self.pos = end;
        Ok(s)
    }

    fn u32(&mut self, what: &str) -> Result<u32, PvsError> {
        self.take(4, what).map(|b| u32::from_le_bytes(le4(b)))
    }

    fn u64(&mut self, what: &str) -> Result<u64, PvsError> {
        let b = self.take(8, what)?;
        let mut a = [0u8; 8];
        a.copy_from_slice(b);
        Ok(u64::from_le_bytes(a))
    }
}

/// Encodes a set both ways and keeps the smaller (ties go to the bitset, faster to decode).
fn encode_set(set: &TriangleSet, n: usize) -> (u8, Vec<u8>) {
    let mut varints = Vec::new();
    let mut previous = 0usize;
    for (k, id) in set.ones().enumerate() {
        let gap = if k == 0 { id } else { id - previous };
        previous = id;
        let mut g = gap as u64;
        loop {
            let byte = (g & 0x7f) as u8;
            g >>= 7;
            if g == 0 {
                varints.push(byte);
                break;
            }
            varints.push(byte | 0x80);
        }
    }
    let bitset_len = n.div_ceil(8);
    if varints.len() < bitset_len {
        return (ENCODING_DELTA_VARINT, varints);
    }
    let mut bits = vec![0u8; bitset_len];
    for id in set.ones() {
        bits[id / 8] |= 1 << (id % 8);
    }
    (ENCODING_BITSET, bits)
}

fn decode_set(encoding: u8, payload: &[u8], n: usize) -> Result<TriangleSet, String> {
    let mut set = TriangleSet::with_capacity(n);
    match encoding {
        ENCODING_BITSET => {
            if payload.len() != n.div_ceil(8) {
                return Err(format!(
                    "bitset of {} bytes for {n} triangles",
                    payload.len()
                ));
            }
            for (byte_index, &byte) in payload.iter().enumerate() {
                let mut b = byte;
                while b != 0 {
                    let id = byte_index * 8 + b.trailing_zeros() as usize;
                    if id >= n {
                        return Err(format!("bit {id} set past the {n} triangles"));
                    }
                    set.insert(id);
                    b &= b - 1;
                }
            }
        }
        ENCODING_DELTA_VARINT => {
            let mut id: u64 = 0;
            let mut first = true;
            let mut value: u64 = 0;
            let mut shift = 0u32;
            for &byte in payload {
                if shift > 35 {
                    return Err("varint longer than 5 bytes".into());
                }
                value |= u64::from(byte & 0x7f) << shift;
                shift += 7;
                if byte & 0x80 != 0 {
                    continue;
                }
                if !first && value == 0 {
                    return Err("repeated id (zero gap)".into());
                }
                id = if first { value } else { id + value };
                first = false;
                if id >= n as u64 {
                    return Err(format!("id {id} past the {n} triangles"));
                }
                set.insert(id as usize);
                value = 0;
                shift = 0;
            }
            if shift != 0 {
                return Err("payload ends inside a varint".into());
            }
        }
        other => return Err(format!("unknown set encoding {other}")),
    }
    Ok(set)
}

#[cfg(test)]
mod tests {
    use super::*;
    use sightline_core::scene::SceneBuilder;

    fn two_box_scene() -> Scene {
        let mut b = SceneBuilder::new("two boxes");
        b.add_box(Vec3::ZERO, Vec3::ONE);
        b.add_box(Vec3::splat(2.0), Vec3::splat(3.0));
        b.finish()
    }

    fn set(n: usize, ids: &[usize]) -> TriangleSet {
        let mut s = TriangleSet::with_capacity(n);
        ids.iter().for_each(|&i| s.insert(i));
        s
    }

    fn sample_file() -> PvsFile {
        let scene = two_box_scene();
        let mut f = PvsFile::for_scene(&scene, serde_json::json!({"method": "test"}));
        let cell = ViewCell::aabb(Vec3::splat(-2.0), Vec3::splat(-1.0)).unwrap();
        // A sparse set (varint wins) and a dense one (bitset wins).
        f.cells.push(CellPvs {
            cell,
            visible: set(24, &[0, 5, 23]),
        });
        f.cells.push(CellPvs {
            cell,
            visible: set(24, &(0..20).collect::<Vec<_>>()),
        });
        f.cells.push(CellPvs {
            cell,
            visible: set(24, &[]),
        });
        f
    }

    fn bytes_of(f: &PvsFile) -> Vec<u8> {
        let mut b = Vec::new();
        f.write(&mut b).unwrap();
        b
    }

    #[test]
    fn round_trip_is_identical() {
        let f = sample_file();
        assert_eq!(PvsFile::read(&bytes_of(&f)).unwrap(), f);
    }

    #[test]
    fn encoded_sets_write_the_same_bytes_and_decode_back() {
        let f = sample_file();
        let encoded: Vec<EncodedSet> = f
            .cells
            .iter()
            .map(|c| EncodedSet::encode(&c.visible, 24))
            .collect();
        for (e, c) in encoded.iter().zip(&f.cells) {
            assert_eq!(e.decode(24).unwrap(), c.visible);
            assert_eq!(e.len(), c.visible.count_ones(..));
            assert!(e.payload_bytes() <= 3);
        }
        let mut b = Vec::new();
        write_encoded(
            &mut b,
            f.scene_hash,
            f.triangle_count,
            &f.metadata,
            f.cells.iter().map(|c| &c.cell).zip(&encoded),
        )
        .unwrap();
        assert_eq!(b, bytes_of(&f));
    }

    #[test]
    fn picks_smaller_encoding() {
        assert_eq!(
            encode_set(&set(1000, &[1, 900]), 1000).0,
            ENCODING_DELTA_VARINT
        );
        assert_eq!(
            encode_set(&set(16, &(0..16).collect::<Vec<_>>()), 16).0,
            ENCODING_BITSET
        );
    }

    #[test]
    fn every_truncation_is_an_error() {
        let b = bytes_of(&sample_file());
        for len in 0..b.len() {
            assert!(
                PvsFile::read(&b[..len]).is_err(),
                "truncated to {len} accepted"
            );
        }
    }

    #[test]
    fn every_single_byte_corruption_is_detected() {
        let b = bytes_of(&sample_file());
        for i in 0..b.len() {
            let mut c = b.clone();
            c[i] ^= 0x10;
            assert!(PvsFile::read(&c).is_err(), "flip at byte {i} not detected");
        }
    }

    #[test]
    fn unknown_version_is_named() {
        let mut b = bytes_of(&sample_file());
        b[8] = 9;
        assert!(matches!(
            PvsFile::read(&b),
            Err(PvsError::UnsupportedVersion(9))
        ));
    }

    #[test]
    fn other_scene_is_rejected() {
        let f = sample_file();
        assert!(f.check_scene(&two_box_scene()).is_ok());
        let mut other = two_box_scene();
        other.positions[0].x += 0.5;
        let e = f.check_scene(&other).unwrap_err();
        assert!(e.to_string().contains("another scene"), "{e}");
    }

    #[test]
    fn set_past_scene_cannot_be_written() {
        let mut f = sample_file();
        f.cells[0].visible = set(100, &[50]);
        assert!(matches!(
            f.write(&mut Vec::new()),
            Err(PvsError::Invalid(_))
        ));
    }

    #[test]
    fn save_is_atomic_and_loadable() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.pvs");
        let f = sample_file();
        f.save(&p).unwrap();
        assert_eq!(PvsFile::load(&p).unwrap(), f);
        let e = PvsFile::load(&dir.path().join("missing.pvs")).unwrap_err();
        assert!(e.to_string().contains("missing.pvs"));
    }

    #[test]
    fn empty_file_has_no_cells() {
        let f = PvsFile::for_scene(&Scene::default(), serde_json::Value::Null);
        let back = PvsFile::read(&bytes_of(&f)).unwrap();
        assert!(back.cells.is_empty());
        assert_eq!(back.triangle_count, 0);
    }
}
