//! Why a culling method drew objects that are not visible: every drawn object without a pixel
//! in the ground-truth image is attributed to the first cause, in a fixed cascade, that would
//! have culled it. The cascade goes from the method's own occluders towards an ideal test, so
//! each step counts what the previous, more available fix would not have caught.
//!
//! The steps, for an object drawn but not exactly visible, with `T` the test the method used
//! (the box test, or the box then the triangles):
//! 1. [`ExtraCauses::sub_pixel`]: its triangles cover no pixel centre even with nothing in
//!    front (the ground truth samples pixel centres; the box test widens by a pixel).
//! 2. [`ExtraCauses::test_order`]: `T` hides it against all of this frame's pre-pass
//!    occluders, in the method's order: it was tested before occluders drawn later.
//! 3. [`ExtraCauses::merge_order`]: `T` hides it against the same occluders rendered in
//!    reverse order: a masked tile that a near occluder covers in part takes the farther
//!    depth once farther occluders fill the rest (the merge keeps the farther of the two
//!    layers); in reverse order the near occluder comes last and replaces them.
//! 4. [`ExtraCauses::prepass_class`]: `T` hides it against all drawn objects: occluders that
//!    were drawn but kept out of the depth pre-pass (the class cap, or the never class).
//! 5. [`ExtraCauses::occluders`]: `T` hides it against the exactly visible objects alone,
//!    rendered front to back: occluders that were culled (cells drawn late) or a buffer made
//!    less tight by hidden objects drawn into it.
//! 6. [`ExtraCauses::box_test`]: only where `T` is the box test: the triangle test hides it
//!    against that ideal buffer (the box's screen rectangle at its nearest corner's depth is
//!    larger and nearer than the object).
//! 7. [`ExtraCauses::widening`]: the triangle test without the one-pixel widening hides it.
//! 8. [`ExtraCauses::tile_depth`]: the rest: the buffer's conservative depth (two layers per
//!    8x4 tile, the farthest depth of merged occluders, the depth slack).
//!
//! Not based on a paper: a measurement tool for this crate's methods.

use glam::Vec3;
use serde::Serialize;
use sightline_core::{Aabb, Camera};

use crate::masked_occlusion::OcclusionBuffer;

/// Drawn objects without a pixel in the ground truth, by the first cause that explains them
/// (see the module documentation of `diagnose.rs`; zero unless the simulation diagnoses).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct ExtraCauses {
    /// Cover no pixel centre even unoccluded.
    pub sub_pixel: u32,
    /// Hidden by this frame's pre-pass occluders that were drawn after the object's test.
    pub test_order: u32,
    /// Hidden by this frame's pre-pass occluders rendered in reverse order.
    pub merge_order: u32,
    /// Hidden by drawn objects that were kept out of the pre-pass.
    pub prepass_class: u32,
    /// Hidden by the exactly visible objects alone (culled occluders, or a polluted buffer).
    pub occluders: u32,
    /// Hidden by the triangle test where the method used the box test.
    pub box_test: u32,
    /// Hidden by the triangle test without the one-pixel widening.
    pub widening: u32,
    /// Not hidden by any of these tests: the buffer's conservative tile depth.
    pub tile_depth: u32,
}

impl ExtraCauses {
    /// The counts with their names, in cascade order.
    pub fn named(&self) -> [(&'static str, u32); 8] {
        [
            ("sub-pixel", self.sub_pixel),
            ("test order", self.test_order),
            ("merge order", self.merge_order),
            ("pre-pass class", self.prepass_class),
            ("occluders", self.occluders),
            ("box test", self.box_test),
            ("widening", self.widening),
            ("tile depth", self.tile_depth),
        ]
    }

    /// Sum of all causes: the drawn objects that are not exactly visible.
    pub fn total(&self) -> u32 {
        self.named().iter().map(|(_, n)| n).sum()
    }
}

/// Reusable buffers of the diagnosis.
#[derive(Clone, Debug)]
pub(crate) struct Diagnosis {
    empty: OcclusionBuffer,
    prepass: OcclusionBuffer,
    reverse: OcclusionBuffer,
    drawn: OcclusionBuffer,
    ideal: OcclusionBuffer,
    order: Vec<u32>,
}

/// What the diagnosis needs to know of a frame's objects.
pub(crate) struct Objects<'a> {
    /// Current box of every object.
    pub boxes: &'a [Aabb],
    /// Corners of every object's triangles, object after object.
    pub corners: &'a [Vec3],
    /// Per object, its range in `corners`.
    pub ranges: &'a [(usize, usize)],
}

impl Objects<'_> {
    fn corners_of(&self, o: u32) -> &[Vec3] {
        let (a, b) = self.ranges[o as usize];
        &self.corners[a..b]
    }
}

impl Diagnosis {
    pub(crate) fn new(width: u32, height: u32) -> Self {
        let buffer = OcclusionBuffer::new(width, height);
        Self {
            empty: buffer.clone(),
            prepass: buffer.clone(),
            reverse: buffer.clone(),
            drawn: buffer.clone(),
            ideal: buffer,
            order: Vec::new(),
        }
    }

    /// Attributes every object of `drawn` that is not `visible` to a cause. `prepassed` are
    /// the objects the method rendered as occluders, in its order; `triangle_tests` says
    /// whether its test was the triangle test (else the box test).
    pub(crate) fn classify(
        &mut self,
        camera: &Camera,
        objects: &Objects,
        drawn: &[u32],
        prepassed: &[u32],
        visible: &[bool],
        triangle_tests: bool,
    ) -> ExtraCauses {
        let mut out = ExtraCauses::default();
        if drawn.iter().all(|&o| visible[o as usize]) {
            return out;
        }
        let render = |buffer: &mut OcclusionBuffer, list: &[u32]| {
            buffer.clear();
            for &o in list {
                buffer.render_occluders(objects.corners_of(o), camera);
            }
        };
        render(&mut self.prepass, prepassed);
        self.reverse.clear();
        for &o in prepassed.iter().rev() {
            self.reverse.render_occluders(objects.corners_of(o), camera);
        }
        render(&mut self.drawn, drawn);
        // The ideal occluders: the exactly visible objects among the drawn and the missed,
        // front to back by the nearest point of their boxes.
        self.order.clear();
        self.order
            .extend((0..visible.len() as u32).filter(|&o| visible[o as usize]));
        crate::front_to_back::sort_front_to_back(&mut self.order, objects.boxes, camera.eye);
        render(&mut self.ideal, &self.order);
        let method_test = |buffer: &OcclusionBuffer, o: u32| {
            buffer.test_box(&objects.boxes[o as usize], camera)
                && (!triangle_tests || buffer.test_triangles(objects.corners_of(o), camera))
        };
        for &o in drawn.iter().filter(|&&o| !visible[o as usize]) {
            let tris = objects.corners_of(o);
            let cause = if !self.empty.covers_pixel_centre(tris, camera) {
                &mut out.sub_pixel
            } else if !method_test(&self.prepass, o) {
                &mut out.test_order
            } else if !method_test(&self.reverse, o) {
                &mut out.merge_order
            } else if !method_test(&self.drawn, o) {
                &mut out.prepass_class
            } else if !method_test(&self.ideal, o) {
                &mut out.occluders
            } else if !self.ideal.test_triangles(tris, camera) {
                &mut out.box_test
            } else if !self.ideal.test_triangles_widened(tris, camera, 0.0) {
                &mut out.widening
            } else {
                &mut out.tile_depth
            };
            *cause += 1;
        }
        out
    }
}
