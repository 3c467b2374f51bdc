//! The input stream: batches of (triangle id, three corners), from an in-memory scene or from
//! anything that can produce triangles on the fly (a file reader, a generator).
//!
//! Based on: Ivanchenko. Massively Parallel Analytic Visibility for Streaming Virtual Reality.
//! 2021, section 6.2 (the geometry stage fetches batches of input triangles from a stream).

use glam::Vec3;
use sightline_core::{Scene, TriangleSet};

use super::types::RvError;

/// One input triangle: its id (the bit it sets in the visible set) and world-space corners.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SourceTriangle {
    /// Triangle id, below the source's [`TriangleSource::id_bound`].
    pub id: u32,
    /// World-space corners.
    pub corners: [Vec3; 3],
}

/// A stream of triangles. Ids need not be contiguous or ordered, but must be below
/// [`TriangleSource::id_bound`]; the same id may not appear twice.
pub trait TriangleSource {
    /// Exclusive upper bound of the ids the stream yields (sizes the visible set).
    fn id_bound(&self) -> u32;

    /// Appends up to `max` triangles to `out` and returns how many; 0 means the stream ended.
    fn next_batch(&mut self, max: usize, out: &mut Vec<SourceTriangle>) -> Result<usize, RvError>;

    /// [`TriangleSource::next_batch`] for a reader that ignores every triangle whose id is not
    /// in `wanted` (RV's re-test pass reads only the triangles its first pass left visible). A
    /// source that can pass over parts of its stream more cheaply than it yields them (a
    /// generator, a file with an index) may leave unwanted triangles out; it must still yield
    /// every wanted one, in stream order, and return 0 only at the end. The default yields
    /// everything.
    fn next_wanted(
        &mut self,
        max: usize,
        out: &mut Vec<SourceTriangle>,
        wanted: &TriangleSet,
    ) -> Result<usize, RvError> {
        let _ = wanted;
        self.next_batch(max, out)
    }

    /// Starts the stream again from its first triangle, yielding the same triangles with the
    /// same ids; returns false when the source cannot (the default), in which case RV skips
    /// its re-test pass.
    fn rewind(&mut self) -> Result<bool, RvError> {
        Ok(false)
    }
}

/// Streams an in-memory [`Scene`] in id order. Triangles with out-of-range indices are yielded
/// with NaN corners (so they are never reported visible, like the rasterizer never draws them).
#[derive(Debug)]
pub struct SceneSource<'a> {
    scene: &'a Scene,
    next: usize,
}

impl<'a> SceneSource<'a> {
    /// A stream over all triangles of `scene`.
    pub fn new(scene: &'a Scene) -> Self {
        Self { scene, next: 0 }
    }
}

impl SceneSource<'_> {
    /// Triangle `id`, NaN corners where an index is out of range.
    fn triangle(&self, id: usize) -> SourceTriangle {
        let t = self.scene.triangles[id];
        let corner = |i: u32| {
            self.scene
                .positions
                .get(i as usize)
                .copied()
                .unwrap_or(Vec3::NAN)
        };
        SourceTriangle {
            id: id as u32,
            corners: [corner(t[0]), corner(t[1]), corner(t[2])],
        }
    }
}

impl TriangleSource for SceneSource<'_> {
    fn id_bound(&self) -> u32 {
        u32::try_from(self.scene.triangles.len()).unwrap_or(u32::MAX)
    }

    fn next_batch(&mut self, max: usize, out: &mut Vec<SourceTriangle>) -> Result<usize, RvError> {
        let end = (self.next + max).min(self.id_bound() as usize);
        let start = self.next;
        out.extend((start..end).map(|id| self.triangle(id)));
        self.next = end;
        Ok(end - start)
    }

    fn next_wanted(
        &mut self,
        max: usize,
        out: &mut Vec<SourceTriangle>,
        wanted: &TriangleSet,
    ) -> Result<usize, RvError> {
        let bound = self.id_bound() as usize;
        let mut n = 0;
        while n < max && self.next < bound {
            let id = self.next;
            self.next += 1;
            if wanted.contains(id) {
                out.push(self.triangle(id));
                n += 1;
            }
        }
        Ok(n)
    }

    fn rewind(&mut self) -> Result<bool, RvError> {
        self.next = 0;
        Ok(true)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sightline_core::scene::SceneBuilder;

    #[test]
    fn empty_scene_streams_nothing() {
        let scene = Scene::default();
        let mut s = SceneSource::new(&scene);
        let mut out = Vec::new();
        assert_eq!(s.next_batch(10, &mut out).ok(), Some(0));
        assert_eq!(s.id_bound(), 0);
    }

    #[test]
    fn bad_index_gives_nan_corner() {
        let mut b = SceneBuilder::new("bad");
        let v = b.add_vertex(Vec3::ZERO);
        b.add_triangle([v, v, 7]);
        let scene = b.finish();
        let mut s = SceneSource::new(&scene);
        let mut out = Vec::new();
        assert_eq!(s.next_batch(10, &mut out).ok(), Some(1));
        assert!(out[0].corners[2].is_nan());
    }

    #[test]
    fn wanted_reading_yields_only_wanted_ids() {
        let mut b = SceneBuilder::new("boxes");
        b.add_box(Vec3::ZERO, Vec3::ONE);
        let scene = b.finish();
        let mut wanted = TriangleSet::with_capacity(12);
        for id in [1, 2, 9] {
            wanted.insert(id);
        }
        let mut s = SceneSource::new(&scene);
        let mut out = Vec::new();
        // A batch of 2 holds 1 and 2; the next must skip to 9 rather than end early.
        assert_eq!(s.next_wanted(2, &mut out, &wanted).ok(), Some(2));
        assert_eq!(s.next_wanted(2, &mut out, &wanted).ok(), Some(1));
        assert_eq!(s.next_wanted(2, &mut out, &wanted).ok(), Some(0));
        let ids: Vec<u32> = out.iter().map(|t| t.id).collect();
        assert_eq!(ids, vec![1, 2, 9]);
        assert_eq!(out[2].corners, scene.triangle(9));
    }

    #[test]
    fn batches_cover_all_ids_in_order() {
        let mut b = SceneBuilder::new("boxes");
        b.add_box(Vec3::ZERO, Vec3::ONE);
        let scene = b.finish();
        let mut s = SceneSource::new(&scene);
        let mut out = Vec::new();
        while s.next_batch(5, &mut out).ok() > Some(0) {}
        let ids: Vec<u32> = out.iter().map(|t| t.id).collect();
        assert_eq!(ids, (0..12).collect::<Vec<_>>());
    }
}
