//! The occlusion backend: where occluders are rendered and cell boxes are queried. The
//! software backend answers immediately from an [`OcclusionBuffer`]; a GPU backend (hardware
//! occlusion queries, results read a frame later) implements the same trait.
//!
//! Based on: Seletsky. Real Time Visibility Culling With Hardware Occlusion Queries and Uniform
//! Grids. 2013, sections 2.4 (queries of a box with colour and depth writes off) and 4.3.2
//! (depth pre-pass and queries interleaved in traversal order).

use glam::Vec3;
use sightline_core::{Aabb, Camera};

use crate::occlusion_buffer::OcclusionBuffer;

/// A depth buffer that takes occluders and answers box queries, in traversal order.
pub trait OcclusionBackend {
    /// Starts a frame seen from `camera`: clears the depth.
    fn begin_frame(&mut self, camera: &Camera);
    /// Renders occluder triangles (three corners each) into depth only.
    fn draw_depth(&mut self, triangles: &[Vec3]);
    /// Issues a query of `aabb` against the depth drawn so far, tagged `tag`.
    fn query(&mut self, tag: u32, aabb: &Aabb);
    /// Tests `aabb` against the depth drawn so far and answers at once, when the backend can
    /// (a software buffer); `None` when answers only come later (hardware queries).
    fn test_now(&mut self, aabb: &Aabb) -> Option<bool> {
        let _ = aabb;
        None
    }
    /// Moves the results that are ready, `(tag, visible)`, into `out` (appending).
    fn take_results(&mut self, out: &mut Vec<(u32, bool)>);
    /// A short name for reports.
    fn name(&self) -> &'static str {
        "backend"
    }
}

/// The software backend: an [`OcclusionBuffer`]; query results are ready at once.
#[derive(Clone, Debug)]
pub struct SoftwareBackend {
    buffer: OcclusionBuffer,
    camera: Option<Camera>,
    results: Vec<(u32, bool)>,
}

impl SoftwareBackend {
    /// A backend with a `width x height` occlusion buffer.
    pub fn new(width: u32, height: u32) -> Self {
        Self {
            buffer: OcclusionBuffer::new(width, height),
            camera: None,
            results: Vec::new(),
        }
    }

    /// The occlusion buffer (for inspection).
    pub fn buffer(&self) -> &OcclusionBuffer {
        &self.buffer
    }
}

impl OcclusionBackend for SoftwareBackend {
    fn begin_frame(&mut self, camera: &Camera) {
        self.buffer.clear();
        self.camera = Some(*camera);
        self.results.clear();
    }

    fn draw_depth(&mut self, triangles: &[Vec3]) {
        if let Some(cam) = &self.camera {
            self.buffer.render_occluders(triangles, cam);
        }
    }

    fn query(&mut self, tag: u32, aabb: &Aabb) {
        // Without a camera nothing is known: conservatively visible.
        let visible = match &self.camera {
            Some(cam) => self.buffer.test_box(aabb, cam),
            None => true,
        };
        self.results.push((tag, visible));
    }

    fn test_now(&mut self, aabb: &Aabb) -> Option<bool> {
        Some(match &self.camera {
            Some(cam) => self.buffer.test_box(aabb, cam),
            None => true,
        })
    }

    fn take_results(&mut self, out: &mut Vec<(u32, bool)>) {
        out.append(&mut self.results);
    }

    fn name(&self) -> &'static str {
        "sw"
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn query_without_frame_is_visible_and_results_drain() {
        let mut b = SoftwareBackend::new(16, 16);
        b.query(7, &Aabb::new(Vec3::ZERO, Vec3::ONE));
        let mut out = Vec::new();
        b.take_results(&mut out);
        b.take_results(&mut out);
        assert_eq!(out, vec![(7, true)]);
    }
}
