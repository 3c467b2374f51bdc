//! The `.pvs` file: one potentially visible set per view cell, bound to the scene it was
//! computed for, and (version 2) the scene's objects with each cell's visible-object set.
//! The layout is `docs/pvs-format.md`; reading is `sightline-runtime`'s (one parser for the
//! tools and the engines), writing is here:
//!
//! ```text
//! header   magic "SLPVS\r\n\x1a" | version u32 = 2 | flags u32 = 0 | scene hash u64
//!          | scene triangle count u32 | cell count u32 | object count u32
//!          | metadata length u32 | metadata (JSON) | CRC-32 of all header bytes before it
//! objects  names length u32 | run count u32 | 40-byte object records | runs (object u32,
//!          triangle count u32) in triangle order | names (UTF-8) | CRC-32 of the section
//! cells    per cell, 84 bytes: centre 3xf32 | axes 9xf32 | half extents 3xf32
//!          | triangle-set encoding u8 | object-set encoding u8 | 2 reserved bytes
//!          | triangle-set size u32 | its payload length u32 | object-set size u32
//!          | its payload length u32 | CRC-32 of the record's first 80 bytes and both payloads
//! payloads per cell, in cell order: triangle set then object set; encoding 0 = ascending
//!          ids as LEB128 varints of the gaps, encoding 1 = bitset (LSB first). The writer
//!          picks the smaller.
//! ```
//!
//! A file without an object table (a version-1 file read back, a checkpoint) is written as
//! version 1. The scene hash is [`Scene::geometry_hash`]: a file made for another scene (or
//! another tessellation of the same map) is rejected. Files are written atomically.

use std::io::{self, Write};
use std::path::{Path, PathBuf};

use glam::Vec3;
use sightline_core::atomic_file::write_atomic;
use sightline_core::{Scene, TriangleSet};
use sightline_runtime::format::{
    decode_set, SetError, SetRef, CELL_RECORD_BYTES_BOUND, CELL_RECORD_BYTES_V1, FLAG_BOUND, MAGIC,
};
use sightline_runtime::Pvs;

use crate::pvs_encoding::{encode_set, object_section};
pub use crate::pvs_objects::{ObjectTable, ObjectTableError, PvsObject};
use crate::viewcell::ViewCell;

/// The format version this code writes (it reads it and version 1).
pub const VERSION: u32 = sightline_runtime::format::VERSION;
/// Bytes of one version-1 cell record in the table (beside its payload).
pub const CELL_RECORD_BYTES: usize = CELL_RECORD_BYTES_V1;

/// Why a `.pvs` file could not be read, written or used.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PvsError {
    /// The file could not be written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: io::Error,
    },
    /// The file could not be read: what the reader (`sightline-runtime`) reports, and the
    /// further checks of this crate's full reader, as [`sightline_runtime::Error::Corrupt`].
    #[error(transparent)]
    Read(#[from] sightline_runtime::Error),
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
    /// The object table to write does not fit the scene.
    #[error("cannot write: {0}")]
    ObjectTable(#[from] ObjectTableError),
    /// An encoded set to write does not decode.
    #[error("cannot write: {0}")]
    Set(#[from] EncodedSetError),
}

/// Why an [`EncodedSet`] does not decode.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum EncodedSetError {
    /// The capacity asked for is past the format's `u32` ids.
    #[error("{ids} ids do not fit the format")]
    TooManyIds {
        /// The capacity asked for.
        ids: usize,
    },
    /// The payload is malformed.
    #[error(transparent)]
    Set(#[from] SetError),
}

fn corrupt(offset: usize, what: String) -> PvsError {
    PvsError::Read(sightline_runtime::Error::Corrupt { offset, what })
}

/// The PVS of one view cell.
#[derive(Clone, Debug, PartialEq)]
pub struct CellPvs {
    /// The cell.
    pub cell: ViewCell,
    /// Triangle ids potentially visible from the cell.
    pub visible: TriangleSet,
    /// The cell's conservative bound (`pvs bake --bound`): a superset of `visible` that
    /// misses no visible triangle. Either every cell of a file has one or none has.
    pub bound: Option<TriangleSet>,
}

impl CellPvs {
    /// A cell with its set and no bound.
    pub fn new(cell: ViewCell, visible: TriangleSet) -> Self {
        Self {
            cell,
            visible,
            bound: None,
        }
    }
}

/// A whole `.pvs` file in memory.
#[derive(Clone, Debug, PartialEq)]
pub struct PvsFile {
    /// [`Scene::geometry_hash`] of the scene the sets index.
    pub scene_hash: u64,
    /// Triangle count of that scene (every set has this capacity).
    pub triangle_count: u32,
    /// The scene's objects (`None`: written as version 1, no object sets).
    pub objects: Option<ObjectTable>,
    /// Free-form JSON: method, parameters, seed, statistics.
    pub metadata: serde_json::Value,
    /// One entry per view cell.
    pub cells: Vec<CellPvs>,
}

impl PvsFile {
    /// An empty file bound to `scene`, with its object table.
    pub fn for_scene(scene: &Scene, metadata: serde_json::Value) -> Self {
        Self {
            scene_hash: scene.geometry_hash(),
            triangle_count: scene.triangle_count() as u32,
            objects: Some(ObjectTable::from_scene(scene)),
            metadata,
            cells: Vec::new(),
        }
    }

    /// Checks that the file belongs to `scene`.
    pub fn check_scene(&self, scene: &Scene) -> Result<(), PvsError> {
        check_scene(self.scene_hash, self.triangle_count, scene)
    }

    /// The objects visible from cell `index` (`None` without an object table or cell).
    pub fn visible_objects(&self, index: usize) -> Option<TriangleSet> {
        let cell = self.cells.get(index)?;
        Some(self.objects.as_ref()?.visible_objects(&cell.visible))
    }

    /// Whether the cells carry conservative bounds (checked to be all or none on write).
    pub fn has_bounds(&self) -> bool {
        self.cells.first().is_some_and(|c| c.bound.is_some())
    }

    /// Serialises the file.
    pub fn write(&self, w: &mut impl Write) -> Result<(), PvsError> {
        let n = self.triangle_count as usize;
        // The table is checked before it maps any set (its ids index the sets' bits).
        check_object_table(self.objects.as_ref(), self.triangle_count)?;
        let bounds = self.has_bounds();
        let mut cells = Vec::with_capacity(self.cells.len());
        for (i, c) in self.cells.iter().enumerate() {
            if c.visible.ones().any(|id| id >= n) {
                return Err(PvsError::Invalid(format!(
                    "cell {i} names a triangle id >= the scene's {n} triangles"
                )));
            }
            // The sets are at hand decoded: their object sets come from them directly.
            let objects = self.objects.as_ref().map(|table| {
                EncodedSet::encode(&table.visible_objects(&c.visible), table.objects.len())
            });
            let extra = match (&c.bound, bounds) {
                (None, false) => None,
                (Some(bound), true) => Some(self.encode_bound_extra(i, &c.visible, bound)?),
                _ => {
                    return Err(PvsError::Invalid(format!(
                        "cell {i} {} a conservative bound and cell 0 {}: a file has bounds \
                         for every cell or for none",
                        if bounds { "lacks" } else { "has" },
                        if bounds { "has" } else { "lacks" },
                    )))
                }
            };
            cells.push(CellRecord {
                cell: c.cell,
                triangles: EncodedSet::encode(&c.visible, n),
                objects,
                bound_extra: extra,
            });
        }
        write_cells(
            w,
            self.scene_hash,
            self.triangle_count,
            self.objects.as_ref(),
            &self.metadata,
            cells,
        )
    }

    /// What the bound of cell `index` adds to `visible`, as encoded triangle and object
    /// sets; refuses a bound that is not a superset, or one past the scene.
    fn encode_bound_extra(
        &self,
        index: usize,
        visible: &TriangleSet,
        bound: &TriangleSet,
    ) -> Result<(EncodedSet, EncodedSet), PvsError> {
        let n = self.triangle_count as usize;
        let Some(table) = &self.objects else {
            return Err(PvsError::Invalid(
                "conservative bounds need the object table (a version-2 file)".into(),
            ));
        };
        if bound.ones().any(|id| id >= n) {
            return Err(PvsError::Invalid(format!(
                "the bound of cell {index} names a triangle id >= the scene's {n} triangles"
            )));
        }
        if let Some(id) = visible.ones().find(|&id| !bound.contains(id)) {
            return Err(PvsError::Invalid(format!(
                "the bound of cell {index} lacks triangle {id} of its set: a bound is a superset"
            )));
        }
        let mut extra = bound.clone();
        extra.difference_with(visible);
        let extra_objects = table.objects_added(&table.visible_objects(visible), bound);
        Ok((
            EncodedSet::encode(&extra, n),
            EncodedSet::encode(&extra_objects, table.objects.len()),
        ))
    }

    /// Writes the file to `path` atomically (an existing file is replaced only on success).
    pub fn save(&self, path: &Path) -> Result<(), PvsError> {
        save_with(path, |bytes| self.write(bytes))
    }

    /// Reads a file from `path` (bounded: see [`sightline_runtime::Pvs::open`]).
    pub fn load(path: &Path) -> Result<Self, PvsError> {
        Self::from_runtime(&Pvs::open(path)?)
    }

    /// Parses a file from its bytes.
    pub fn read(bytes: &[u8]) -> Result<Self, PvsError> {
        Self::from_runtime(&Pvs::from_bytes(bytes.to_vec())?)
    }

    fn from_runtime(pvs: &Pvs) -> Result<Self, PvsError> {
        let mut cells = Vec::with_capacity(pvs.cell_count() as usize);
        let (metadata, objects) = parse(pvs, &mut |cell, _, visible, bound| {
            cells.push(CellPvs {
                cell,
                visible,
                bound,
            })
        })?;
        Ok(Self {
            scene_hash: pvs.scene_hash(),
            triangle_count: pvs.triangle_count(),
            objects,
            metadata,
            cells,
        })
    }
}

fn check_scene(file_hash: u64, file_triangles: u32, scene: &Scene) -> Result<(), PvsError> {
    let scene_hash = scene.geometry_hash();
    if scene_hash != file_hash || scene.triangle_count() != file_triangles as usize {
        return Err(PvsError::SceneMismatch {
            file_hash,
            scene_hash,
            file_triangles,
            scene_triangles: scene.triangle_count(),
        });
    }
    Ok(())
}

/// A `.pvs` file with its sets left encoded: what tools handling many cells of large scenes
/// (checkpoints, merges) read, so the sets are never all decoded at once.
#[derive(Clone, Debug, PartialEq)]
pub struct EncodedPvsFile {
    /// [`Scene::geometry_hash`] of the scene the sets index.
    pub scene_hash: u64,
    /// Triangle count of that scene.
    pub triangle_count: u32,
    /// The scene's objects (`None`: version 1).
    pub objects: Option<ObjectTable>,
    /// Free-form JSON metadata.
    pub metadata: serde_json::Value,
    /// One entry per view cell (the triangle sets; object sets are derived when written).
    pub cells: Vec<(ViewCell, EncodedSet)>,
    /// A two-sided file's bounds: per cell, the triangles its bound adds to its set (their
    /// objects are derived when written); empty for a file without bounds.
    pub bound_extras: Vec<EncodedSet>,
}

impl EncodedPvsFile {
    /// Parses and fully checks a file (every set is decoded once to validate it).
    pub fn read(bytes: &[u8]) -> Result<Self, PvsError> {
        Self::from_runtime(&Pvs::from_bytes(bytes.to_vec())?)
    }

    /// Reads a file from `path`.
    pub fn load(path: &Path) -> Result<Self, PvsError> {
        Self::from_runtime(&Pvs::open(path)?)
    }

    fn from_runtime(pvs: &Pvs) -> Result<Self, PvsError> {
        let mut cells = Vec::with_capacity(pvs.cell_count() as usize);
        let (metadata, objects) = parse(pvs, &mut |cell, set, _, _| cells.push((cell, set)))?;
        // `parse` checked every bound; their extra triangle sets are kept as they are encoded.
        let mut bound_extras = Vec::new();
        for i in 0..pvs.cell_count() {
            if let Some((extra, _)) = pvs.raw_bound_sets(i)? {
                bound_extras.push(EncodedSet {
                    encoding: extra.encoding,
                    size: extra.size,
                    payload: extra.payload(pvs.as_bytes()).to_vec(),
                });
            }
        }
        Ok(Self {
            scene_hash: pvs.scene_hash(),
            triangle_count: pvs.triangle_count(),
            objects,
            metadata,
            cells,
            bound_extras,
        })
    }

    /// Writes the file to `path` atomically (a two-sided file's object sets and bounds' extra
    /// objects are derived one cell at a time, as for its sets).
    pub fn save(&self, path: &Path) -> Result<(), PvsError> {
        let extras: Vec<Option<&EncodedSet>> = if self.bound_extras.is_empty() {
            vec![None; self.cells.len()]
        } else if self.bound_extras.len() == self.cells.len() {
            self.bound_extras.iter().map(Some).collect()
        } else {
            return Err(PvsError::Invalid(format!(
                "{} bounds for {} cells",
                self.bound_extras.len(),
                self.cells.len()
            )));
        };
        save_with(path, |bytes| {
            write_encoded_sides(
                bytes,
                self.scene_hash,
                self.triangle_count,
                self.objects.as_ref(),
                &self.metadata,
                self.cells.iter().zip(extras).map(|((c, s), e)| (c, s, e)),
            )
        })
    }
}

/// What [`parse`] hands every cell to: the cell, its encoded and decoded set, and its bound.
type CellKeeper<'a> = dyn FnMut(ViewCell, EncodedSet, TriangleSet, Option<TriangleSet>) + 'a;

/// Checks everything the runtime's open does not (metadata JSON, every set decoded, every
/// object set equal to the one its triangles give, every bound's extra sets disjoint from the
/// cell's and its objects those of its triangles) and hands every cell to `keep`; returns the
/// metadata and object table.
fn parse(
    pvs: &Pvs,
    keep: &mut CellKeeper<'_>,
) -> Result<(serde_json::Value, Option<ObjectTable>), PvsError> {
    let bytes = pvs.as_bytes();
    let metadata = serde_json::from_str(pvs.metadata_json())
        .map_err(|e| corrupt(0, format!("metadata is not JSON: {e}")))?;
    let objects = (pvs.version() >= 2).then(|| read_objects(pvs));
    let n = pvs.triangle_count();
    for i in 0..pvs.cell_count() {
        let c = pvs.cell(i)?;
        let v = Vec3::from_array;
        // Opening checked the geometry with `ViewCell::oriented`'s rule (one function).
        let cell = ViewCell {
            center: v(c.center),
            axes: c.axes.map(v),
            half_extents: v(c.half_extents),
        };
        let (triangles, object_set) = pvs.raw_sets(i)?;
        let visible = decode_bits(bytes, triangles, n, i, "triangles")?;
        if let (Some(table), Some(set)) = (&objects, object_set) {
            let decoded = decode_bits(bytes, set, table.objects.len() as u32, i, "objects")?;
            if decoded != table.visible_objects(&visible) {
                return Err(corrupt(
                    set.offset,
                    format!("cell {i}: its visible objects are not those of its triangles"),
                ));
            }
        }
        let bound = match (&objects, pvs.raw_bound_sets(i)?) {
            (Some(table), Some(extra)) => Some(read_bound(bytes, table, &visible, extra, i)?),
            _ => None,
        };
        let encoded = EncodedSet {
            encoding: triangles.encoding,
            size: triangles.size,
            payload: triangles.payload(bytes).to_vec(),
        };
        keep(cell, encoded, visible, bound);
    }
    Ok((metadata, objects))
}

/// The bound of cell `i`: its set with the bound's extra triangles, checked against the
/// extra objects.
fn read_bound(
    bytes: &[u8],
    table: &ObjectTable,
    visible: &TriangleSet,
    (extra_triangles, extra_objects): (SetRef, SetRef),
    i: u32,
) -> Result<TriangleSet, PvsError> {
    let n = visible.len() as u32;
    let extra = decode_bits(bytes, extra_triangles, n, i, "bound triangles")?;
    if let Some(id) = extra.intersection(visible).next() {
        return Err(corrupt(
            extra_triangles.offset,
            format!("cell {i}: its bound adds triangle {id}, which its set already holds"),
        ));
    }
    let objects = decode_bits(
        bytes,
        extra_objects,
        table.objects.len() as u32,
        i,
        "bound objects",
    )?;
    let mut bound = visible.clone();
    bound.union_with(&extra);
    if objects != table.objects_added(&table.visible_objects(visible), &bound) {
        return Err(corrupt(
            extra_objects.offset,
            format!("cell {i}: the objects its bound adds are not those of its triangles"),
        ));
    }
    Ok(bound)
}

fn decode_bits(
    bytes: &[u8],
    set: SetRef,
    capacity: u32,
    cell: u32,
    what: &str,
) -> Result<TriangleSet, PvsError> {
    let mut bits = TriangleSet::with_capacity(capacity as usize);
    decode_set(set.encoding, set.payload(bytes), capacity, set.size, |id| {
        bits.insert(id as usize)
    })
    .map_err(|e| corrupt(set.offset, format!("cell {cell}, visible {what}: {e}")))?;
    Ok(bits)
}

fn read_objects(pvs: &Pvs) -> ObjectTable {
    let mut object_of_triangle = vec![0u32; pvs.triangle_count() as usize];
    let objects = pvs
        .objects()
        .enumerate()
        .map(|(i, o)| {
            for range in pvs.object_triangles(i as u32).into_iter().flatten() {
                object_of_triangle[range.start as usize..range.end as usize].fill(i as u32);
            }
            PvsObject {
                name: o.name.to_string(),
                index: o.index,
                part: o.part,
                bounds_min: Vec3::from_array(o.bounds_min),
                bounds_max: Vec3::from_array(o.bounds_max),
            }
        })
        .collect();
    ObjectTable {
        objects,
        object_of_triangle,
    }
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
    pub fn decode(&self, n: usize) -> Result<TriangleSet, EncodedSetError> {
        let mut set = TriangleSet::with_capacity(n);
        let capacity = u32::try_from(n).map_err(|_| EncodedSetError::TooManyIds { ids: n })?;
        decode_set(self.encoding, &self.payload, capacity, self.size, |id| {
            set.insert(id as usize)
        })?;
        Ok(set)
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
    /// fixed cell record).
    pub fn payload_bytes(&self) -> usize {
        self.payload.len()
    }
}

/// Writes a `.pvs` stream from already encoded sets, so a bake of thousands of cells never
/// holds them all decoded. The caller guarantees every set was encoded for `triangle_count`.
/// With `objects`, the file is version 2 and every cell's object set is derived from its
/// triangle set (decoded one cell at a time); without, version 1.
pub fn write_encoded<'a>(
    w: &mut impl Write,
    scene_hash: u64,
    triangle_count: u32,
    objects: Option<&ObjectTable>,
    metadata: &serde_json::Value,
    cells: impl ExactSizeIterator<Item = (&'a ViewCell, &'a EncodedSet)>,
) -> Result<(), PvsError> {
    write_encoded_sides(
        w,
        scene_hash,
        triangle_count,
        objects,
        metadata,
        cells.map(|(cell, set)| (cell, set, None)),
    )
}

/// [`write_encoded`] of cells that may carry the triangles their bound adds: each cell's object
/// set and, with a bound, the objects the bound adds are derived from the decoded sets, one
/// cell at a time.
fn write_encoded_sides<'a>(
    w: &mut impl Write,
    scene_hash: u64,
    triangle_count: u32,
    objects: Option<&ObjectTable>,
    metadata: &serde_json::Value,
    cells: impl ExactSizeIterator<Item = (&'a ViewCell, &'a EncodedSet, Option<&'a EncodedSet>)>,
) -> Result<(), PvsError> {
    check_object_table(objects, triangle_count)?;
    let n = triangle_count as usize;
    let mut records = Vec::with_capacity(cells.len());
    for (i, (cell, set, extra)) in cells.enumerate() {
        let (object_set, bound_extra) = match (objects, extra) {
            (Some(table), extra) => {
                let triangles = set.decode(n)?;
                let visible_objects = table.visible_objects(&triangles);
                let bound_extra = match extra {
                    None => None,
                    Some(extra) => {
                        let mut bound = extra.decode(n)?;
                        if let Some(id) = bound.intersection(&triangles).next() {
                            return Err(PvsError::Invalid(format!(
                                "the bound of cell {i} adds triangle {id}, which its set holds"
                            )));
                        }
                        bound.union_with(&triangles);
                        let added = table.objects_added(&visible_objects, &bound);
                        Some((
                            extra.clone(),
                            EncodedSet::encode(&added, table.objects.len()),
                        ))
                    }
                };
                let object_set = EncodedSet::encode(&visible_objects, table.objects.len());
                (Some(object_set), bound_extra)
            }
            (None, None) => (None, None),
            (None, Some(_)) => {
                return Err(PvsError::Invalid(
                    "conservative bounds need the object table (a version-2 file)".into(),
                ))
            }
        };
        records.push(CellRecord {
            cell: *cell,
            triangles: set,
            objects: object_set,
            bound_extra,
        });
    }
    write_cells(w, scene_hash, triangle_count, objects, metadata, records)
}

fn check_object_table(objects: Option<&ObjectTable>, triangle_count: u32) -> Result<(), PvsError> {
    match objects {
        Some(table) => Ok(table.check(triangle_count as usize)?),
        None => Ok(()),
    }
}

/// One cell as the writer lays it out.
struct CellRecord<S> {
    cell: ViewCell,
    triangles: S,
    /// Given exactly when the file has an object table.
    objects: Option<EncodedSet>,
    /// What the bound adds (triangles, objects), in a file with bounds.
    bound_extra: Option<(EncodedSet, EncodedSet)>,
}

/// The writer: each cell with its encoded triangle set and, exactly when `objects` is given,
/// its encoded object set; and, when the cells carry them, their bounds' extra sets.
fn write_cells<S: std::borrow::Borrow<EncodedSet>>(
    w: &mut impl Write,
    scene_hash: u64,
    triangle_count: u32,
    objects: Option<&ObjectTable>,
    metadata: &serde_json::Value,
    cells: Vec<CellRecord<S>>,
) -> Result<(), PvsError> {
    check_object_table(objects, triangle_count)?;
    if cells
        .iter()
        .any(|c| c.objects.is_some() != objects.is_some())
    {
        return Err(PvsError::Invalid(
            "object sets are given exactly when there is an object table".into(),
        ));
    }
    let bounds = cells.first().is_some_and(|c| c.bound_extra.is_some());
    if cells.iter().any(|c| c.bound_extra.is_some() != bounds) || (bounds && objects.is_none()) {
        return Err(PvsError::Invalid(
            "bounds are given for every cell or none, and only with an object table".into(),
        ));
    }
    let version: u32 = if objects.is_some() { VERSION } else { 1 };
    let flags = if bounds { FLAG_BOUND } else { 0 };
    let metadata =
        serde_json::to_vec(metadata).map_err(|e| PvsError::Invalid(format!("metadata: {e}")))?;
    let cell_count = cells.len();
    let mut header = Vec::with_capacity(44 + metadata.len());
    header.extend_from_slice(&MAGIC);
    header.extend_from_slice(&version.to_le_bytes());
    header.extend_from_slice(&flags.to_le_bytes());
    header.extend_from_slice(&scene_hash.to_le_bytes());
    header.extend_from_slice(&triangle_count.to_le_bytes());
    header.extend_from_slice(&(cell_count as u32).to_le_bytes());
    if let Some(table) = objects {
        header.extend_from_slice(&(table.objects.len() as u32).to_le_bytes());
    }
    header.extend_from_slice(&(metadata.len() as u32).to_le_bytes());
    header.extend_from_slice(&metadata);
    header.extend_from_slice(&crc32fast::hash(&header).to_le_bytes());
    if let Some(table) = objects {
        header.extend_from_slice(&object_section(table));
    }

    let mut records = Vec::with_capacity(cell_count * CELL_RECORD_BYTES_BOUND);
    let mut payloads: Vec<u8> = Vec::new();
    for c in &cells {
        let (cell, object_set) = (&c.cell, &c.objects);
        let set: &EncodedSet = c.triangles.borrow();
        let mut record = Vec::with_capacity(CELL_RECORD_BYTES_BOUND);
        let floats = [cell.center, cell.axes[0], cell.axes[1], cell.axes[2]]
            .into_iter()
            .chain([cell.half_extents])
            .flat_map(|v| v.to_array());
        for f in floats {
            record.extend_from_slice(&f.to_le_bytes());
        }
        record.push(set.encoding);
        record.push(object_set.as_ref().map_or(0, |o| o.encoding));
        match &c.bound_extra {
            Some((t, o)) => record.extend_from_slice(&[t.encoding, o.encoding]),
            None => record.extend_from_slice(&[0; 2]),
        }
        // Size and payload length of each set, in payload order.
        let sets: Vec<&EncodedSet> = std::iter::once(set)
            .chain(object_set)
            .chain(c.bound_extra.iter().flat_map(|(t, o)| [t, o]))
            .collect();
        for s in &sets {
            record.extend_from_slice(&s.size.to_le_bytes());
            record.extend_from_slice(&(s.payload.len() as u32).to_le_bytes());
        }
        let mut crc = crc32fast::Hasher::new();
        crc.update(&record);
        for s in &sets {
            crc.update(&s.payload);
            payloads.extend_from_slice(&s.payload);
        }
        record.extend_from_slice(&crc.finalize().to_le_bytes());
        records.extend_from_slice(&record);
    }
    let io = |source| PvsError::Io {
        path: PathBuf::from("<stream>"),
        source,
    };
    w.write_all(&header).map_err(io)?;
    w.write_all(&records).map_err(io)?;
    w.write_all(&payloads).map_err(io)?;
    Ok(())
}

/// [`write_encoded`] to `path`, atomically (an existing file is replaced only on success).
pub fn save_encoded<'a>(
    path: &Path,
    scene_hash: u64,
    triangle_count: u32,
    objects: Option<&ObjectTable>,
    metadata: &serde_json::Value,
    cells: impl ExactSizeIterator<Item = (&'a ViewCell, &'a EncodedSet)>,
) -> Result<(), PvsError> {
    save_with(path, |bytes| {
        write_encoded(bytes, scene_hash, triangle_count, objects, metadata, cells)
    })
}

/// Lays a file out in memory with `write`, then replaces `path` with it atomically (an
/// existing file survives any failure): the one way every `.pvs` writer saves.
fn save_with(
    path: &Path,
    write: impl FnOnce(&mut Vec<u8>) -> Result<(), PvsError>,
) -> Result<(), PvsError> {
    let mut bytes = Vec::new();
    write(&mut bytes)?;
    write_atomic(path, |w| w.write_all(&bytes)).map_err(|source| PvsError::Io {
        path: path.to_path_buf(),
        source,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use sightline_core::scene::SceneBuilder;
    use sightline_runtime::format::{ENCODING_BITSET, ENCODING_DELTA_VARINT};

    fn two_box_scene() -> Scene {
        let mut b = SceneBuilder::new("two boxes");
        b.begin_object("first box");
        b.add_box(Vec3::ZERO, Vec3::ONE);
        b.begin_object("second box");
        b.add_box(Vec3::splat(2.0), Vec3::splat(3.0));
        b.finish()
    }

    /// The sample file as version 1 (no object table).
    fn sample_file_v1() -> PvsFile {
        PvsFile {
            objects: None,
            ..sample_file()
        }
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
        f.cells.push(CellPvs::new(cell, set(24, &[0, 5, 23])));
        f.cells
            .push(CellPvs::new(cell, set(24, &(0..20).collect::<Vec<_>>())));
        f.cells.push(CellPvs::new(cell, set(24, &[])));
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
            f.objects.as_ref(),
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
        assert_every_truncation_refused(&bytes_of(&sample_file()));
        assert_every_truncation_refused(&bytes_of(&sample_file_v1()));
    }

    #[test]
    fn every_single_byte_corruption_is_detected() {
        assert_every_flip_refused(&bytes_of(&sample_file()));
        assert_every_flip_refused(&bytes_of(&sample_file_v1()));
    }

    fn assert_every_truncation_refused(b: &[u8]) {
        for len in 0..b.len() {
            assert!(
                PvsFile::read(&b[..len]).is_err(),
                "truncated to {len} accepted"
            );
        }
    }

    fn assert_every_flip_refused(b: &[u8]) {
        for i in 0..b.len() {
            let mut c = b.to_vec();
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
            Err(PvsError::Read(
                sightline_runtime::Error::UnsupportedVersion(9)
            ))
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

    #[test]
    fn version_2_holds_objects_and_their_sets() {
        let f = sample_file();
        let b = bytes_of(&f);
        assert_eq!(u32::from_le_bytes([b[8], b[9], b[10], b[11]]), 2);
        let table = f.objects.as_ref().unwrap();
        assert_eq!(table.objects.len(), 2);
        assert_eq!(table.objects[1].name, "second box");
        assert_eq!(table.objects[1].bounds_min, Vec3::splat(2.0));
        assert_eq!(table.objects[1].bounds_max, Vec3::splat(3.0));
        // Cell 0 sees triangles 0, 5 (first box) and 23 (second box); cell 1 only the first
        // box's 12 and 8 of the second's; cell 2 nothing.
        let ones = |c: usize| f.visible_objects(c).unwrap().ones().collect::<Vec<_>>();
        assert_eq!(ones(0), [0, 1]);
        assert_eq!(ones(1), [0, 1]);
        assert!(ones(2).is_empty());
        let pvs = Pvs::from_bytes(b).unwrap();
        assert_eq!(pvs.visible_objects(0).unwrap(), [0, 1]);
        assert!(pvs.visible_objects(2).unwrap().is_empty());
        assert_eq!(pvs.object(0).unwrap().name, "first box");
        let runs: Vec<_> = pvs.object_triangles(1).unwrap().collect();
        assert_eq!(runs.len(), 1);
        assert_eq!(runs[0], 12..24);
    }

    #[test]
    fn version_1_files_are_still_read_and_written() {
        let f = sample_file_v1();
        let b = bytes_of(&f);
        assert_eq!(u32::from_le_bytes([b[8], b[9], b[10], b[11]]), 1);
        let back = PvsFile::read(&b).unwrap();
        assert_eq!(back, f);
        assert!(back.visible_objects(0).is_none());
        let pvs = Pvs::from_bytes(b).unwrap();
        assert!(matches!(
            pvs.visible_objects(0),
            Err(sightline_runtime::Error::NoObjects(1))
        ));
    }

    #[test]
    fn object_set_disagreeing_with_the_triangles_is_refused() {
        // A file whose object sets were written from another object table: consistent
        // checksums, wrong sets. The runtime accepts it (it cannot know); the full reader not.
        let mut f = sample_file();
        let table = f.objects.as_mut().unwrap();
        table.object_of_triangle = vec![0; 24];
        let good_checksums = bytes_of(&f);
        let mut forged = f.clone();
        forged.objects.as_mut().unwrap().object_of_triangle =
            (0..24).map(|t| u32::from(t >= 12)).collect();
        let forged_bytes = bytes_of(&forged);
        // Splice the first file's cell records and payloads after the second's object section.
        let object_section_end = |b: &[u8]| b.len() - f.cells.len() * 84 - payload_len(&f);
        let mut spliced = forged_bytes[..object_section_end(&forged_bytes)].to_vec();
        spliced.extend_from_slice(&good_checksums[object_section_end(&good_checksums)..]);
        assert!(Pvs::from_bytes(spliced.clone()).is_ok());
        let e = PvsFile::read(&spliced).unwrap_err();
        assert!(e.to_string().contains("not those of its triangles"), "{e}");
    }

    fn payload_len(f: &PvsFile) -> usize {
        let n = f.triangle_count as usize;
        let table = f.objects.as_ref().unwrap();
        f.cells
            .iter()
            .map(|c| {
                EncodedSet::encode(&c.visible, n).payload_bytes()
                    + EncodedSet::encode(&table.visible_objects(&c.visible), table.objects.len())
                        .payload_bytes()
            })
            .sum()
    }

    #[test]
    fn object_table_past_the_scene_cannot_be_written() {
        let mut f = sample_file();
        f.objects.as_mut().unwrap().object_of_triangle[3] = 7;
        let e = f.write(&mut Vec::new()).unwrap_err();
        assert!(e.to_string().contains("triangle 3"), "{e}");
        let mut f = sample_file();
        f.objects.as_mut().unwrap().object_of_triangle.pop();
        assert!(matches!(
            f.write(&mut Vec::new()),
            Err(PvsError::ObjectTable(ObjectTableError::TriangleCount {
                mapped: 23,
                triangles: 24
            }))
        ));
    }

    /// The sample file with a bound per cell: cell 0 adds a triangle of the second box
    /// (a new object), cell 1 one of the first box (no new object), cell 2 adds nothing.
    fn sample_file_with_bounds() -> PvsFile {
        let mut f = sample_file();
        let extra: [&[usize]; 3] = [&[1, 13], &[21], &[]];
        for (c, extra) in f.cells.iter_mut().zip(extra) {
            let mut bound = c.visible.clone();
            extra.iter().for_each(|&i| bound.insert(i));
            c.bound = Some(bound);
        }
        f
    }

    #[test]
    fn bounds_round_trip_and_the_runtime_reads_both_sides() {
        let f = sample_file_with_bounds();
        let b = bytes_of(&f);
        assert_eq!(u32::from_le_bytes([b[12], b[13], b[14], b[15]]), FLAG_BOUND);
        assert_eq!(PvsFile::read(&b).unwrap(), f);
        let pvs = Pvs::from_bytes(b).unwrap();
        assert!(pvs.has_bound());
        pvs.verify_sets().unwrap();
        let mut out = Vec::new();
        pvs.bound_triangles_into(0, &mut out).unwrap();
        assert_eq!(out, [0, 1, 5, 13, 23]);
        pvs.bound_extra_triangles_into(0, &mut out).unwrap();
        assert_eq!(out, [1, 13]);
        assert_eq!(pvs.bound_triangle_count(0).unwrap(), 5);
        // Cell 1's set holds 0..20: the bound adds 21 and no object (both boxes are in).
        pvs.bound_triangles_into(1, &mut out).unwrap();
        assert_eq!(out, (0..20).chain([21]).collect::<Vec<u32>>());
        pvs.bound_extra_objects_into(1, &mut out).unwrap();
        assert!(out.is_empty());
        // Cell 2 sees nothing and its bound adds nothing.
        pvs.bound_objects_into(2, &mut out).unwrap();
        assert!(out.is_empty());
        assert_eq!(pvs.bound_object_count(0).unwrap(), 2);
        // A file without bounds says so.
        let plain = Pvs::from_bytes(bytes_of(&sample_file())).unwrap();
        assert!(!plain.has_bound());
        assert!(matches!(
            plain.bound_triangles_into(0, &mut out),
            Err(sightline_runtime::Error::NoBound)
        ));
    }

    #[test]
    fn every_damage_to_a_file_with_bounds_is_refused() {
        let b = bytes_of(&sample_file_with_bounds());
        assert_every_truncation_refused(&b);
        assert_every_flip_refused(&b);
    }

    #[test]
    fn bounds_that_are_not_supersets_or_not_everywhere_cannot_be_written() {
        let mut f = sample_file_with_bounds();
        f.cells[0].bound = Some(set(24, &[0]));
        let e = f.write(&mut Vec::new()).unwrap_err().to_string();
        assert!(e.contains("lacks triangle 5"), "{e}");
        let mut f = sample_file_with_bounds();
        f.cells[2].bound = None;
        let e = f.write(&mut Vec::new()).unwrap_err().to_string();
        assert!(e.contains("cell 2 lacks a conservative bound"), "{e}");
        let mut f = sample_file_with_bounds();
        f.objects = None;
        let e = f.write(&mut Vec::new()).unwrap_err().to_string();
        assert!(e.contains("object table"), "{e}");
    }

    #[test]
    fn a_bound_repeating_the_set_or_with_wrong_objects_is_refused() {
        let f = sample_file_with_bounds();
        let table = f.objects.as_ref().unwrap();
        let write = |extra: &[usize], extra_objects: &[usize]| {
            let cells = vec![CellRecord {
                cell: f.cells[0].cell,
                triangles: EncodedSet::encode(&f.cells[0].visible, 24),
                objects: Some(EncodedSet::encode(
                    &table.visible_objects(&f.cells[0].visible),
                    2,
                )),
                bound_extra: Some((
                    EncodedSet::encode(&set(24, extra), 24),
                    EncodedSet::encode(&set(2, extra_objects), 2),
                )),
            }];
            let mut b = Vec::new();
            write_cells(&mut b, f.scene_hash, 24, Some(table), &f.metadata, cells).unwrap();
            b
        };
        assert!(PvsFile::read(&write(&[1], &[])).is_ok());
        let e = PvsFile::read(&write(&[1, 5], &[])).unwrap_err().to_string();
        assert!(
            e.contains("adds triangle 5, which its set already holds"),
            "{e}"
        );
        let e = PvsFile::read(&write(&[1], &[1])).unwrap_err().to_string();
        assert!(e.contains("objects its bound adds"), "{e}");
    }

    #[test]
    fn encoded_files_carry_bounds_unchanged() {
        let dir = tempfile::tempdir().unwrap();
        let f = sample_file_with_bounds();
        let encoded = EncodedPvsFile::read(&bytes_of(&f)).unwrap();
        assert_eq!(encoded.bound_extras.len(), 3);
        assert_eq!(encoded.bound_extras[0].len(), 2);
        encoded.save(&dir.path().join("b.pvs")).unwrap();
        assert_eq!(PvsFile::load(&dir.path().join("b.pvs")).unwrap(), f);
        // One side only: no bounds read, none written.
        let plain = EncodedPvsFile::read(&bytes_of(&sample_file())).unwrap();
        assert!(plain.bound_extras.is_empty());
    }
}
