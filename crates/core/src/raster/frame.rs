//! The rasterizer's output: a frame of triangle ids and view depths. A leaf of `raster`: the
//! driver (`tiled.rs`) fills a [`Frame`] taken from here, never from the module's face
//! (`mod.rs`), which re-exports it.

use crate::geometry::Hit;
use crate::TriangleSet;

/// Frame background value for ids.
const BACKGROUND: u32 = Hit::NONE;

/// A rendered frame: per-pixel triangle id ([`crate::Hit::NONE`] for background) and view depth.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Triangle id per pixel, row-major, top row first.
    pub ids: Vec<u32>,
    /// View depth per pixel (`f32::INFINITY` for background).
    pub depth: Vec<f32>,
}

impl Frame {
    /// A `width × height` frame of background.
    pub fn new(width: u32, height: u32) -> Self {
        let mut f = Self {
            width: 0,
            height: 0,
            ids: Vec::new(),
            depth: Vec::new(),
        };
        f.reset(width, height);
        f
    }

    /// Resizes to `width × height` (keeping the allocation) and fills with background.
    pub(crate) fn reset(&mut self, width: u32, height: u32) {
        let n = width as usize * height as usize;
        self.width = width;
        self.height = height;
        self.ids.clear();
        self.ids.resize(n, BACKGROUND);
        self.depth.clear();
        self.depth.resize(n, f32::INFINITY);
    }

    /// The id at pixel `(x, y)`, `None` for background or outside the frame.
    pub fn id_at(&self, x: u32, y: u32) -> Option<u32> {
        if x >= self.width || y >= self.height {
            return None;
        }
        let id = self.ids[y as usize * self.width as usize + x as usize];
        (id != BACKGROUND).then_some(id)
    }

    /// The set of triangle ids visible in the frame, over `n_triangles` ids (ids at or above
    /// `n_triangles` are ignored).
    pub fn visible_set(&self, n_triangles: usize) -> TriangleSet {
        let mut set = TriangleSet::with_capacity(n_triangles);
        for &id in &self.ids {
            if (id as usize) < n_triangles {
                set.insert(id as usize);
            }
        }
        set
    }
}
