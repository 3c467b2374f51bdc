//! A streaming `city`: the core generator (`sightline_core::scene::procedural::City`, the
//! scene of `procedural:city?seed=S&size=N`) run block by block into a sink that keeps only the
//! current block, so a city of any size streams through RV without ever being in memory.
//!
//! Based on: Ivanchenko. Massively Parallel Analytic Visibility for Streaming Virtual Reality.
//! 2021, chapter 2 (the input is a stream whose size is not known to the visibility stage).
//!
//! Triangle `i` here is triangle `i` of the materialised scene (a test checks this): the
//! generator is the same code, and ids are assigned in emission order as `SceneBuilder` does.

use glam::Vec3;
use sightline_core::camera::CameraError;
use sightline_core::scene::procedural::City;
use sightline_core::scene::{CountingSink, TriangleSink};
use sightline_core::{Camera, TriangleSet};

use super::source::{SourceTriangle, TriangleSource};
use super::types::RvError;

/// Collects one block: its vertices (indices restart at every block) and its triangles, ready
/// to hand out (ids are given when they are handed out).
#[derive(Clone, Debug)]
struct BlockSink {
    vertices: Vec<Vec3>,
    triangles: Vec<SourceTriangle>,
}

impl TriangleSink for BlockSink {
    fn begin_object(&mut self, _name: std::fmt::Arguments<'_>) {}

    fn vertex_count(&self) -> u32 {
        self.vertices.len() as u32
    }

    fn add_vertex(&mut self, p: Vec3) -> u32 {
        self.vertices.push(p);
        self.vertices.len() as u32 - 1
    }

    fn add_triangle(&mut self, t: [u32; 3]) {
        // A bad index would be a generator bug; give it NaN corners (never visible) rather
        // than panic, as `SceneSource` does for bad scenes.
        let corner = |i: u32| self.vertices.get(i as usize).copied().unwrap_or(Vec3::NAN);
        self.triangles.push(SourceTriangle {
            id: 0,
            corners: [corner(t[0]), corner(t[1]), corner(t[2])],
        });
    }
}

/// The streaming city (see the module documentation). Holds O(1) state: the generator and the
/// current block's few hundred triangles not yet handed out.
#[derive(Clone, Debug)]
pub struct StreamingCity {
    city: City,
    block: BlockSink,
    /// Next triangle of `block.triangles` to hand out.
    at: usize,
    next_id: u32,
    /// The generator's parameters, to start again ([`TriangleSource::rewind`]).
    seed: u64,
    size: usize,
}

impl StreamingCity {
    /// The city of `procedural:city?seed={seed}&size={size}` (about `size` triangles).
    pub fn new(seed: u64, size: usize) -> Self {
        Self {
            city: City::new(seed, size),
            block: BlockSink {
                vertices: Vec::with_capacity(City::MAX_VERTICES_PER_BLOCK),
                triangles: Vec::with_capacity(City::MAX_TRIANGLES_PER_BLOCK),
            },
            at: 0,
            next_id: 0,
            seed,
            size,
        }
    }

    /// Blocks per side.
    pub fn blocks(&self) -> usize {
        self.city.blocks()
    }

    /// The city's extent in x and y (centred on the origin), in metres.
    pub fn half_extent(&self) -> f32 {
        self.city.half_extent()
    }

    /// The street-level view of RV's throughput measurements (`rv_stream_once`, `sightline
    /// bench rv`): 2 m above the street crossing at (-6, -6) (there is one there when the city
    /// has an even number of blocks per side, as the 10M city has), looking down the street
    /// along +x; 60°, `size`² pixels.
    pub fn street_camera(size: u32) -> Result<Camera, CameraError> {
        Camera::look_at(
            Vec3::new(-6.0, -6.0, 2.0),
            Vec3::new(1000.0, -6.0, 2.0),
            Vec3::Z,
            60.0,
            size,
            size,
            0.1,
        )
    }

    /// The aerial view of the same measurements: from 300 m above the centre, looking down
    /// over the city towards (500, 500, 0); 60°, `size`² pixels.
    pub fn aerial_camera(size: u32) -> Result<Camera, CameraError> {
        Camera::look_at(
            Vec3::new(0.0, 0.0, 300.0),
            Vec3::new(500.0, 500.0, 0.0),
            Vec3::Z,
            60.0,
            size,
            size,
            0.1,
        )
    }
}

impl TriangleSource for StreamingCity {
    fn rewind(&mut self) -> Result<bool, RvError> {
        self.city = City::new(self.seed, self.size);
        self.block.vertices.clear();
        self.block.triangles.clear();
        self.at = 0;
        self.next_id = 0;
        Ok(true)
    }

    fn id_bound(&self) -> u32 {
        let blocks = self.city.blocks();
        u32::try_from(blocks * blocks * City::MAX_TRIANGLES_PER_BLOCK).unwrap_or(u32::MAX)
    }

    fn next_batch(&mut self, max: usize, out: &mut Vec<SourceTriangle>) -> Result<usize, RvError> {
        Ok(self.fill(max, out, None))
    }

    fn next_wanted(
        &mut self,
        max: usize,
        out: &mut Vec<SourceTriangle>,
        wanted: &TriangleSet,
    ) -> Result<usize, RvError> {
        Ok(self.fill(max, out, Some(wanted)))
    }
}

impl StreamingCity {
    /// Appends up to `max` triangles; with `wanted`, blocks none of whose possible ids is
    /// wanted are only counted (about a tenth of the cost of yielding them).
    fn fill(
        &mut self,
        max: usize,
        out: &mut Vec<SourceTriangle>,
        wanted: Option<&TriangleSet>,
    ) -> usize {
        let mut n = 0;
        while n < max {
            if self.at == self.block.triangles.len() {
                self.block.vertices.clear();
                self.block.triangles.clear();
                self.at = 0;
                let first = self.next_id as usize;
                // Ids are handed out in order, so the next block's lie in this range.
                let range = first..first + City::MAX_TRIANGLES_PER_BLOCK;
                if wanted.is_some_and(|w| w.count_ones(range.start..range.end.min(w.len())) == 0) {
                    // Generated but only counted: the generator's random state and the ids
                    // stay those of the full stream.
                    let mut count = CountingSink::default();
                    if !self.city.next_block(&mut count) {
                        break;
                    }
                    self.next_id += count.triangles as u32;
                    continue;
                }
                if !self.city.next_block(&mut self.block) {
                    break;
                }
                continue;
            }
            // As many of the block's triangles as fit, numbered in stream order.
            let k = (max - n).min(self.block.triangles.len() - self.at);
            let start = out.len();
            out.extend_from_slice(&self.block.triangles[self.at..self.at + k]);
            for (t, id) in out[start..].iter_mut().zip(self.next_id..) {
                t.id = id;
            }
            self.at += k;
            self.next_id += k as u32;
            n += k;
        }
        n
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sightline_core::scene::{open, LoadOptions};

    #[test]
    fn matches_materialised_city() {
        let scene =
            open("procedural:city?seed=5&size=3000", &LoadOptions::default()).expect("city");
        let mut s = StreamingCity::new(5, 3000);
        let mut out = Vec::new();
        while s.next_batch(97, &mut out).ok() > Some(0) {}
        assert_eq!(out.len(), scene.triangle_count());
        for t in &out {
            assert_eq!(t.corners, scene.triangle(t.id));
        }
        assert!(s.id_bound() as usize >= out.len());
        // Rewinding yields the same stream again.
        assert_eq!(s.rewind().ok(), Some(true));
        let mut again = Vec::new();
        while s.next_batch(61, &mut again).ok() > Some(0) {}
        assert_eq!(again, out);
    }

    #[test]
    fn wanted_triangles_come_through_with_their_ids_and_corners() {
        let mut all = Vec::new();
        let mut s = StreamingCity::new(3, 5000);
        while s.next_batch(113, &mut all).ok() > Some(0) {}
        // A sparse choice: whole blocks are then left out.
        let mut wanted = TriangleSet::with_capacity(s.id_bound() as usize);
        for t in all.iter().filter(|t| t.id % 997 == 5) {
            wanted.insert(t.id as usize);
        }
        let mut s = StreamingCity::new(3, 5000);
        let mut got = Vec::new();
        while s.next_wanted(64, &mut got, &wanted).ok() > Some(0) {}
        assert!(got.len() < all.len() / 2, "unwanted blocks were skipped");
        let kept: Vec<&SourceTriangle> = got
            .iter()
            .filter(|t| wanted.contains(t.id as usize))
            .collect();
        let want: Vec<&SourceTriangle> = all
            .iter()
            .filter(|t| wanted.contains(t.id as usize))
            .collect();
        assert_eq!(kept, want);
    }

    #[test]
    fn zero_max_yields_nothing() {
        let mut s = StreamingCity::new(1, 100);
        let mut out = Vec::new();
        assert_eq!(s.next_batch(0, &mut out).ok(), Some(0));
    }
}
