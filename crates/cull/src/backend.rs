//! The occlusion backend: where occluders are rendered and cell boxes are queried. The
//! software backend answers immediately from an [`OcclusionBuffer`]; a GPU backend (hardware
//! occlusion queries, results read a frame later) implements the same trait.
//!
//! Based on: Seletsky. Real Time Visibility Culling With Hardware Occlusion Queries and Uniform
//! Grids. 2013, sections 2.4 (queries of a box with colour and depth writes off) and 4.3.2
//! (depth pre-pass and queries interleaved in traversal order).

use glam::Vec3;
use sightline_core::{Aabb, Camera};

use crate::masked_occlusion::OcclusionBuffer;

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
    /// Tests an object, given by its box and its triangles (three corners each), against the
    /// depth drawn so far and answers at once, when the backend can; `None` otherwise. The
    /// default tests the box only ([`OcclusionBackend::test_now`]); the software backend
    /// tests the triangles where the box passes.
    fn test_object_now(&mut self, aabb: &Aabb, triangles: &[Vec3]) -> Option<bool> {
        let _ = triangles;
        self.test_now(aabb)
    }
    /// Fills a second depth buffer with `occluders` (three corners per triangle), for
    /// [`OcclusionBackend::retest_now`]; the caller picks the occluders and their order. A
    /// masked tile that a near occluder covers in part takes the farther depth once farther
    /// occluders, drawn after it, fill the rest (the merge of Andersson et al. 2015 keeps the
    /// farther of two layers), so the same occluders in reverse order keep depths the
    /// first buffer lost. Backends without a second buffer ignore it (the default).
    fn begin_retest(&mut self, occluders: &[Vec3]) {
        let _ = occluders;
    }
    /// Tests an object (box, then triangles) against the second buffer and answers at once,
    /// when the backend can; `None` otherwise (the default). Visible when no
    /// [`OcclusionBackend::begin_retest`] came since the frame began.
    fn retest_now(&mut self, aabb: &Aabb, triangles: &[Vec3]) -> Option<bool> {
        let _ = (aabb, triangles);
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
    /// The second buffer of [`OcclusionBackend::begin_retest`], and whether it was filled
    /// this frame.
    second: OcclusionBuffer,
    second_ready: bool,
}

impl SoftwareBackend {
    /// A backend with a `width x height` occlusion buffer.
    pub fn new(width: u32, height: u32) -> Self {
        Self {
            buffer: OcclusionBuffer::new(width, height),
            camera: None,
            results: Vec::new(),
            second: OcclusionBuffer::new(width, height),
            second_ready: false,
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
        self.second_ready = false;
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

    fn test_object_now(&mut self, aabb: &Aabb, triangles: &[Vec3]) -> Option<bool> {
        Some(match &self.camera {
            // The box test is cheaper and usually decides; the triangles only where it passes.
            Some(cam) => {
                self.buffer.test_box(aabb, cam) && self.buffer.test_triangles(triangles, cam)
            }
            None => true,
        })
    }

    fn begin_retest(&mut self, occluders: &[Vec3]) {
        if let Some(cam) = &self.camera {
            self.second.clear();
            self.second.render_occluders(occluders, cam);
            self.second_ready = true;
        }
    }

    fn retest_now(&mut self, aabb: &Aabb, triangles: &[Vec3]) -> Option<bool> {
        Some(match &self.camera {
            Some(cam) if self.second_ready => {
                self.second.test_box(aabb, cam) && self.second.test_triangles(triangles, cam)
            }
            _ => true,
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

    fn quad(x0: f32, x1: f32, y0: f32, y1: f32, z: f32) -> Vec<Vec3> {
        let (a, b, c, d) = (
            Vec3::new(x0, y0, z),
            Vec3::new(x1, y0, z),
            Vec3::new(x1, y1, z),
            Vec3::new(x0, y1, z),
        );
        vec![a, b, c, a, c, d]
    }

    #[test]
    fn retest_without_frame_is_visible() {
        let mut b = SoftwareBackend::new(16, 8);
        let aabb = Aabb::new(Vec3::ZERO, Vec3::ONE);
        assert_eq!(b.retest_now(&aabb, &[]), Some(true));
    }

    /// A near wall over part of a tile, then a far wall over everything: the tile merges to
    /// the far depth, so an object between them passes the test as drawn; in the second
    /// buffer, in reverse order, the near wall comes last and hides it. An object in front of
    /// both stays visible.
    #[test]
    fn retest_hides_what_a_farther_occluder_merged_away() {
        let cam =
            Camera::look_at(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 60.0, 16, 8, 0.1).expect("camera");
        let mut b = SoftwareBackend::new(16, 8);
        b.begin_frame(&cam);
        // 16x8 pixels at depth 2 span about 2.3 x 1.15: the near wall covers the left 6.5
        // pixel columns, inside the first 8-pixel tile.
        let near = quad(-5.0, -0.22, -5.0, 5.0, -2.0);
        let far = quad(-50.0, 50.0, -50.0, 50.0, -20.0);
        b.draw_depth(&near);
        b.draw_depth(&far);
        b.begin_retest(&[far, near].concat());
        // At depth 5 a pixel is 0.72 wide: this square covers the centre of pixel (3, 3), and
        // its one-pixel widening stays within the near wall's columns.
        let between = Aabb::new(Vec3::new(-3.4, 0.2, -5.2), Vec3::new(-3.1, 0.5, -5.0));
        let tris: Vec<Vec3> = quad(-3.4, -3.1, 0.2, 0.5, -5.0);
        assert_eq!(b.test_object_now(&between, &tris), Some(true));
        assert_eq!(b.retest_now(&between, &tris), Some(false));
        let front = Aabb::new(Vec3::new(-0.8, 0.0, -1.2), Vec3::new(-0.5, 0.2, -1.0));
        let tris: Vec<Vec3> = quad(-0.8, -0.5, 0.0, 0.2, -1.0);
        assert_eq!(b.retest_now(&front, &tris), Some(true));
    }
}
