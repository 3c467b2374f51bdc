//! # sightline-runtime
//!
//! Reads a baked `.pvs` file (written by `sightline pvs bake`; the layout is
//! `docs/pvs-format.md`) inside a game or tool at run time:
//!
//! ```no_run
//! # fn main() -> Result<(), sightline_runtime::Error> {
//! let pvs = sightline_runtime::Pvs::open("level.pvs")?;
//! let mut visible = Vec::new();
//! match pvs.cell_at([1.0, 2.0, 1.7]) {
//!     Some(cell) => {
//!         pvs.visible_objects_into(cell, &mut visible)?;
//!         for &object in &visible {
//!             let _name = pvs.object(object)?.name; // draw the entities of `object`
//!         }
//!     }
//!     None => { /* outside every cell: draw everything */ }
//! }
//! # Ok(()) }
//! ```
//!
//! Opening checks the whole file's structure and every CRC-32 checksum, and builds a small
//! index of the cells; the sets stay encoded in the file's bytes and are decoded, and checked,
//! only when asked for. No input makes it panic: every problem is an [`Error`] naming the byte
//! where it is.
//!
//! Memory: the file's bytes (owned, or any shared buffer such as a memory map through
//! [`Pvs::from_shared`]), plus about 28 bytes per cell, 48 per object and 8 per triangle run
//! of an object.

mod cell_index;
mod error;
pub mod format;
mod types;

use std::ops::Range;
use std::path::Path;
use std::sync::Arc;

use cell_index::CellIndex;
pub use error::Error;
use format::{decode_set, read_vec3, Layout, NO_INDEX};
pub use types::{Cell, Object};

/// The largest file [`Pvs::open`] reads unless told otherwise (4 GiB: offsets in the format
/// are 32-bit per set, and a bigger file is more likely a wrong path than a bake).
pub const DEFAULT_MAX_FILE_BYTES: u64 = 4 << 30;

enum Bytes {
    Owned(Vec<u8>),
    Shared(Arc<dyn AsRef<[u8]> + Send + Sync>),
}

impl Bytes {
    fn get(&self) -> &[u8] {
        match self {
            Bytes::Owned(v) => v,
            Bytes::Shared(s) => (**s).as_ref(),
        }
    }
}

/// An opened, checked `.pvs` file.
pub struct Pvs {
    bytes: Bytes,
    layout: Layout,
    index: CellIndex,
}

impl std::fmt::Debug for Pvs {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Pvs")
            .field("version", &self.layout.version)
            .field("cells", &self.layout.cell_count)
            .field("objects", &self.layout.objects.len())
            .field("triangles", &self.layout.triangle_count)
            .finish_non_exhaustive()
    }
}

impl Pvs {
    /// Reads and checks the file at `path` (at most [`DEFAULT_MAX_FILE_BYTES`]).
    pub fn open(path: impl AsRef<Path>) -> Result<Self, Error> {
        Self::open_with_limit(path, DEFAULT_MAX_FILE_BYTES)
    }

    /// [`Pvs::open`], refusing files larger than `max_bytes` before reading them.
    pub fn open_with_limit(path: impl AsRef<Path>, max_bytes: u64) -> Result<Self, Error> {
        use std::io::Read;
        let path = path.as_ref();
        let io = |source| Error::Io {
            path: path.to_path_buf(),
            source,
        };
        let file = std::fs::File::open(path).map_err(io)?;
        let size = file.metadata().map_err(io)?.len();
        if size > max_bytes {
            return Err(Error::TooLarge {
                path: path.to_path_buf(),
                bytes: size,
                limit: max_bytes,
            });
        }
        let mut bytes = Vec::with_capacity(size as usize);
        // `take` bounds the read even when the file grows while it is read.
        file.take(max_bytes + 1)
            .read_to_end(&mut bytes)
            .map_err(io)?;
        if bytes.len() as u64 > max_bytes {
            return Err(Error::TooLarge {
                path: path.to_path_buf(),
                bytes: bytes.len() as u64,
                limit: max_bytes,
            });
        }
        Self::from_bytes(bytes)
    }

    /// Checks and keeps a file's bytes.
    pub fn from_bytes(bytes: Vec<u8>) -> Result<Self, Error> {
        Self::new(Bytes::Owned(bytes))
    }

    /// Checks and keeps a shared buffer (e.g. a memory map): nothing is copied. The buffer
    /// must not change while the `Pvs` lives.
    pub fn from_shared(bytes: Arc<dyn AsRef<[u8]> + Send + Sync>) -> Result<Self, Error> {
        Self::new(Bytes::Shared(bytes))
    }

    fn new(bytes: Bytes) -> Result<Self, Error> {
        let layout = format::parse(bytes.get())?;
        let boxes: Vec<Cell> = (0..layout.cell_count)
            .map(|i| read_cell(layout.record(bytes.get(), i)))
            .collect();
        let index = CellIndex::build(&boxes);
        Ok(Self {
            bytes,
            layout,
            index,
        })
    }

    /// The format version of the file (1 or 2).
    pub fn version(&self) -> u32 {
        self.layout.version
    }

    /// The geometry hash of the scene the file was baked for (`Scene::geometry_hash`).
    pub fn scene_hash(&self) -> u64 {
        self.layout.scene_hash
    }

    /// Number of triangles of that scene.
    pub fn triangle_count(&self) -> u32 {
        self.layout.triangle_count
    }

    /// Number of view cells.
    pub fn cell_count(&self) -> u32 {
        self.layout.cell_count
    }

    /// Number of objects (0 in a version-1 file).
    pub fn object_count(&self) -> u32 {
        self.layout.objects.len() as u32
    }

    /// The bake's metadata, a JSON document (method, parameters, statistics).
    pub fn metadata_json(&self) -> &str {
        let bytes = &self.bytes.get()[self.layout.metadata.clone()];
        // Checked as UTF-8 when the file was opened.
        std::str::from_utf8(bytes).unwrap_or("")
    }

    /// The cell at `index`.
    pub fn cell(&self, index: u32) -> Result<Cell, Error> {
        self.check_cell(index)?;
        Ok(read_cell(self.layout.record(self.bytes.get(), index)))
    }

    /// The cell that holds `position`, or `None` when no cell does (then draw everything).
    /// On a face shared by cells, and where cells overlap, the lowest index wins; the
    /// boundary counts as inside within 1e-5 of the cell's size.
    pub fn cell_at(&self, position: [f32; 3]) -> Option<u32> {
        let bytes = self.bytes.get();
        self.index
            .cell_at(position, |c| read_cell(self.layout.record(bytes, c)))
    }

    /// The object at `index`.
    pub fn object(&self, index: u32) -> Result<Object<'_>, Error> {
        let record = self
            .layout
            .objects
            .get(index as usize)
            .ok_or(Error::NoSuchObject {
                object: index,
                count: self.object_count(),
            })?;
        let name = std::str::from_utf8(&self.bytes.get()[record.name.clone()]).unwrap_or("");
        let opt = |v: u32| (v != NO_INDEX).then_some(v);
        Ok(Object {
            name,
            index: opt(record.index),
            part: opt(record.part),
            bounds_min: record.bounds_min,
            bounds_max: record.bounds_max,
        })
    }

    /// Every object, in index order.
    pub fn objects(&self) -> impl Iterator<Item = Object<'_>> + '_ {
        (0..self.object_count()).filter_map(|i| self.object(i).ok())
    }

    /// The triangle ids of object `index`, as ascending ranges.
    pub fn object_triangles(
        &self,
        index: u32,
    ) -> Result<impl Iterator<Item = Range<u32>> + '_, Error> {
        if index as usize >= self.layout.objects.len() {
            return Err(Error::NoSuchObject {
                object: index,
                count: self.object_count(),
            });
        }
        let l = &self.layout;
        let runs =
            &l.runs[l.run_start[index as usize] as usize..l.run_start[index as usize + 1] as usize];
        Ok(runs.iter().map(|&(first, count)| first..first + count))
    }

    /// The object that triangle `id` belongs to.
    /// `None` for an id past the scene's triangles or in a version-1 file.
    pub fn object_of_triangle(&self, id: u32) -> Option<u32> {
        if id >= self.layout.triangle_count {
            return None;
        }
        let runs = &self.layout.runs_in_order;
        let k = runs.partition_point(|&(first, _)| first <= id);
        k.checked_sub(1).map(|k| runs[k].1)
    }

    /// Number of objects visible from `cell`.
    pub fn visible_object_count(&self, cell: u32) -> Result<u32, Error> {
        self.check_cell(cell)?;
        match self.layout.sets(self.bytes.get(), cell).1 {
            Some(set) => Ok(set.size),
            None => Err(Error::NoObjects(self.layout.version)),
        }
    }

    /// Number of triangles visible from `cell`.
    pub fn visible_triangle_count(&self, cell: u32) -> Result<u32, Error> {
        self.check_cell(cell)?;
        Ok(self.layout.sets(self.bytes.get(), cell).0.size)
    }

    /// Replaces `out` with the ids of the objects visible from `cell`, ascending (an object is
    /// visible when any of its triangles is). Allocates only when `out` must grow.
    pub fn visible_objects_into(&self, cell: u32, out: &mut Vec<u32>) -> Result<(), Error> {
        self.check_cell(cell)?;
        let Some(set) = self.layout.sets(self.bytes.get(), cell).1 else {
            return Err(Error::NoObjects(self.layout.version));
        };
        {
            out.clear();
            self.decode_into(cell, set, self.object_count(), "objects", out)
        }
    }

    /// The objects visible from `cell`, ascending.
    pub fn visible_objects(&self, cell: u32) -> Result<Vec<u32>, Error> {
        let mut out = Vec::new();
        self.visible_objects_into(cell, &mut out)?;
        Ok(out)
    }

    /// Replaces `out` with the ids of the triangles visible from `cell`, ascending.
    pub fn visible_triangles_into(&self, cell: u32, out: &mut Vec<u32>) -> Result<(), Error> {
        self.check_cell(cell)?;
        let set = self.layout.sets(self.bytes.get(), cell).0;
        {
            out.clear();
            self.decode_into(cell, set, self.layout.triangle_count, "triangles", out)
        }
    }

    /// The triangles visible from `cell`, ascending.
    pub fn visible_triangles(&self, cell: u32) -> Result<Vec<u32>, Error> {
        let mut out = Vec::new();
        self.visible_triangles_into(cell, &mut out)?;
        Ok(out)
    }

    /// Whether every cell also holds a conservative bound: a superset of its set that is
    /// never missing a visible triangle (`pvs bake --bound`). The cell's own set is the
    /// aggressive one (sampled: every triangle in it is visible, a few visible ones may be
    /// absent); the bound adds the triangles that might be visible.
    pub fn has_bound(&self) -> bool {
        self.layout.bound
    }

    /// Number of triangles in the conservative bound of `cell` (its set and what the bound
    /// adds).
    pub fn bound_triangle_count(&self, cell: u32) -> Result<u32, Error> {
        let (extra, _) = self.bound_extra(cell)?;
        Ok(self
            .visible_triangle_count(cell)?
            .saturating_add(extra.size))
    }

    /// Number of objects in the conservative bound of `cell`.
    pub fn bound_object_count(&self, cell: u32) -> Result<u32, Error> {
        let (_, extra) = self.bound_extra(cell)?;
        Ok(self.visible_object_count(cell)?.saturating_add(extra.size))
    }

    /// Replaces `out` with the triangles the bound of `cell` adds to its set (ascending):
    /// the triangles that might be visible from the cell but were not found visible — the
    /// gap between the two sides. Draw them after the set when a frame must be complete.
    pub fn bound_extra_triangles_into(&self, cell: u32, out: &mut Vec<u32>) -> Result<(), Error> {
        self.bound_into(cell, Ids::Triangles, false, out)
    }

    /// Replaces `out` with the objects the bound of `cell` adds to its object set
    /// (ascending): objects that own a triangle of the bound and none of the set.
    pub fn bound_extra_objects_into(&self, cell: u32, out: &mut Vec<u32>) -> Result<(), Error> {
        self.bound_into(cell, Ids::Objects, false, out)
    }

    /// Replaces `out` with the conservative bound of `cell`: its triangle set and what the
    /// bound adds, ascending. Allocates only when `out` must grow.
    pub fn bound_triangles_into(&self, cell: u32, out: &mut Vec<u32>) -> Result<(), Error> {
        self.bound_into(cell, Ids::Triangles, true, out)
    }

    /// Replaces `out` with the objects of the conservative bound of `cell`, ascending.
    /// Allocates only when `out` must grow.
    pub fn bound_objects_into(&self, cell: u32, out: &mut Vec<u32>) -> Result<(), Error> {
        self.bound_into(cell, Ids::Objects, true, out)
    }

    /// The bound's extra `ids` of `cell` into `out`, after the cell's own set of them when
    /// `whole` (ascending either way).
    fn bound_into(
        &self,
        cell: u32,
        ids: Ids,
        whole: bool,
        out: &mut Vec<u32>,
    ) -> Result<(), Error> {
        let (triangles, objects) = self.bound_extra(cell)?;
        let (extra, capacity, what) = match ids {
            Ids::Triangles => (triangles, self.layout.triangle_count, "bound triangles"),
            Ids::Objects => (objects, self.object_count(), "bound objects"),
        };
        out.clear();
        if !whole {
            return self.decode_into(cell, extra, capacity, what, out);
        }
        match ids {
            Ids::Triangles => self.visible_triangles_into(cell, out)?,
            Ids::Objects => self.visible_objects_into(cell, out)?,
        }
        let set_len = out.len();
        self.decode_into(cell, extra, capacity, what, out)?;
        merge_runs(out, set_len);
        Ok(())
    }

    /// The objects of the conservative bound of `cell`, ascending.
    pub fn bound_objects(&self, cell: u32) -> Result<Vec<u32>, Error> {
        let mut out = Vec::new();
        self.bound_objects_into(cell, &mut out)?;
        Ok(out)
    }

    /// The triangles of the conservative bound of `cell`, ascending.
    pub fn bound_triangles(&self, cell: u32) -> Result<Vec<u32>, Error> {
        let mut out = Vec::new();
        self.bound_triangles_into(cell, &mut out)?;
        Ok(out)
    }

    /// The extra sets of `cell`'s bound, or why there are none.
    fn bound_extra(&self, cell: u32) -> Result<(format::SetRef, format::SetRef), Error> {
        self.check_cell(cell)?;
        self.layout
            .bound_extra(self.bytes.get(), cell)
            .ok_or(Error::NoBound)
    }

    /// Decodes every set of every cell once: the complete check beyond what opening does.
    /// Sets are otherwise checked as they are decoded.
    pub fn verify_sets(&self) -> Result<(), Error> {
        let mut scratch = Vec::new();
        for cell in 0..self.cell_count() {
            self.visible_triangles_into(cell, &mut scratch)?;
            if self.layout.version >= 2 {
                self.visible_objects_into(cell, &mut scratch)?;
            }
            if self.layout.bound {
                self.bound_extra_triangles_into(cell, &mut scratch)?;
                self.bound_extra_objects_into(cell, &mut scratch)?;
            }
        }
        Ok(())
    }

    /// Heap bytes held beside the file's bytes (cell index, object tables).
    pub fn index_heap_bytes(&self) -> usize {
        let l = &self.layout;
        self.index.heap_bytes()
            + l.payload_start.capacity() * std::mem::size_of::<usize>()
            + l.objects.capacity() * std::mem::size_of::<format::ObjectRecord>()
            + l.run_start.capacity() * 4
            + l.runs.capacity() * 8
            + l.runs_in_order.capacity() * 8
    }

    /// The file's bytes.
    pub fn as_bytes(&self) -> &[u8] {
        self.bytes.get()
    }

    /// Where the extra triangle and object sets of cell `cell`'s bound lie in
    /// [`Pvs::as_bytes`] (`None` in a file without bounds).
    pub fn raw_bound_sets(
        &self,
        cell: u32,
    ) -> Result<Option<(format::SetRef, format::SetRef)>, Error> {
        self.check_cell(cell)?;
        Ok(self.layout.bound_extra(self.bytes.get(), cell))
    }

    /// Where cell `cell`'s sets lie in [`Pvs::as_bytes`] (for tools that copy encoded sets).
    pub fn raw_sets(&self, cell: u32) -> Result<(format::SetRef, Option<format::SetRef>), Error> {
        self.check_cell(cell)?;
        Ok(self.layout.sets(self.bytes.get(), cell))
    }

    fn check_cell(&self, cell: u32) -> Result<(), Error> {
        if cell >= self.layout.cell_count {
            return Err(Error::NoSuchCell {
                cell,
                count: self.layout.cell_count,
            });
        }
        Ok(())
    }

    /// Appends `set`'s ids to `out`.
    fn decode_into(
        &self,
        cell: u32,
        set: format::SetRef,
        capacity: u32,
        what: &str,
        out: &mut Vec<u32>,
    ) -> Result<(), Error> {
        out.reserve(set.size.min(capacity) as usize);
        decode_set(
            set.encoding,
            set.payload(self.bytes.get()),
            capacity,
            set.size,
            |id| out.push(id),
        )
        .map_err(|e| Error::corrupt(set.offset, format!("cell {cell}, visible {what}: {e}")))
    }
}

/// Merges the two ascending runs `ids[..split]` and `ids[split..]` into one ascending run
/// (they are disjoint in a valid file; a shared id is kept once), in linear time: the second
/// run is copied past the end (the buffer grows once and is reused by later calls) and the
/// two are merged from the back.
fn merge_runs(ids: &mut Vec<u32>, split: usize) {
    let second = ids.len() - split;
    ids.extend_from_within(split..);
    let (mut a, mut b) = (split, second);
    let mut w = split + second;
    while b > 0 {
        let next = ids[split + second + b - 1];
        w -= 1;
        if a > 0 && ids[a - 1] > next {
            ids[w] = ids[a - 1];
            a -= 1;
        } else {
            if a > 0 && ids[a - 1] == next {
                a -= 1;
            }
            ids[w] = next;
            b -= 1;
        }
    }
    // Ids kept once leave a gap before the written part: close it.
    ids.truncate(split + second);
    if w > a {
        ids.drain(a..w);
    }
}

/// Which ids of a cell: its triangles or its objects.
#[derive(Clone, Copy)]
enum Ids {
    Triangles,
    Objects,
}

fn read_cell(record: &[u8]) -> Cell {
    Cell {
        center: read_vec3(record, 0),
        axes: [
            read_vec3(record, 12),
            read_vec3(record, 24),
            read_vec3(record, 36),
        ],
        half_extents: read_vec3(record, 48),
    }
}

#[cfg(test)]
mod tests {
    use super::merge_runs;

    #[test]
    fn merging_two_ascending_runs_keeps_order_and_shared_ids_once() {
        let cases: [(&[u32], &[u32], &[u32]); 5] = [
            (&[], &[], &[]),
            (&[1, 5, 9], &[], &[1, 5, 9]),
            (&[], &[2, 3], &[2, 3]),
            (&[1, 5, 9], &[0, 6, 10], &[0, 1, 5, 6, 9, 10]),
            (&[1, 5, 9], &[5, 9, 11], &[1, 5, 9, 11]),
        ];
        for (set, extra, merged) in cases {
            let mut ids = [set, extra].concat();
            merge_runs(&mut ids, set.len());
            assert_eq!(ids, merged, "{set:?} + {extra:?}");
        }
    }
}
