//! [`BspData`]: what a Quake 3 map holds beyond triangles (BSP tree, leaves, clusters, the
//! compiled cluster PVS, shader flags, models, spawn points) as plain data, with the few
//! queries that need the tree: point in leaf, box in leaves, and "which triangles may be seen
//! from cluster c".

use std::ops::Range;

use glam::Vec3;

use super::entities::Entity;
use crate::geometry::Aabb;

/// Shader-derived properties of a surface that matter for visibility, as bits.
///
/// Derived at load time from the shader's `surfaceFlags` / `contentFlags` (constants in the
/// docs of each bit). The compiler only sets them when it found the shader script, so maps
/// may lack them (q3dm6ish has none).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct SurfaceFlags(pub u8);

impl SurfaceFlags {
    /// No flag set: an ordinary opaque surface.
    pub const NONE: Self = Self(0);
    /// Sky (`surfaceFlags & 0x4`): drawn as the sky box, still blocks sight lines.
    pub const SKY: Self = Self(1);
    /// Not drawn (`surfaceFlags & 0x80`); q3map2 drops such surfaces, so usually absent.
    pub const NODRAW: Self = Self(2);
    /// Translucent (`contentFlags & 0x20000000`): glass, grates, water surfaces.
    pub const TRANSLUCENT: Self = Self(4);
    /// Liquid (`contentFlags & (8 | 16 | 32)`): lava, slime or water.
    pub const LIQUID: Self = Self(8);
    /// Fog volume boundary (`contentFlags & 64`).
    pub const FOG: Self = Self(16);

    /// Flags from a shader's `surfaceFlags` and `contentFlags`.
    pub fn from_shader(surface_flags: i32, content_flags: i32) -> Self {
        let mut f = 0;
        if surface_flags & 0x4 != 0 {
            f |= Self::SKY.0;
        }
        if surface_flags & 0x80 != 0 {
            f |= Self::NODRAW.0;
        }
        if content_flags & 0x2000_0000 != 0 {
            f |= Self::TRANSLUCENT.0;
        }
        if content_flags & (8 | 16 | 32) != 0 {
            f |= Self::LIQUID.0;
        }
        if content_flags & 64 != 0 {
            f |= Self::FOG.0;
        }
        Self(f)
    }

    /// True when every bit of `other` is set.
    pub fn contains(self, other: Self) -> bool {
        self.0 & other.0 == other.0
    }

    /// True when the surface hides what is behind it: anything not nodraw, translucent,
    /// liquid or fog. Sky occludes (it is the opaque boundary of the map).
    pub fn occludes(self) -> bool {
        self.0 & (Self::NODRAW.0 | Self::TRANSLUCENT.0 | Self::LIQUID.0 | Self::FOG.0) == 0
    }
}

impl std::ops::BitOr for SurfaceFlags {
    type Output = Self;
    fn bitor(self, rhs: Self) -> Self {
        Self(self.0 | rhs.0)
    }
}

/// A shader (texture) record of lump 1.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Shader {
    /// Shader name, e.g. `textures/base_wall/concrete`.
    pub name: String,
    /// Raw `surfaceFlags`.
    pub surface_flags: i32,
    /// Raw `contentFlags`.
    pub content_flags: i32,
}

/// A splitting plane of lump 2: points `p` with `normal · p = dist`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Plane {
    /// Plane normal (unit length in valid maps).
    pub normal: Vec3,
    /// Distance from the origin along `normal`.
    pub dist: f32,
}

/// An inner node of the BSP tree (lump 3).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Node {
    /// Index into [`BspData::planes`].
    pub plane: u32,
    /// Front (`normal · p - dist >= 0`) and back child: `>= 0` a node index, negative a leaf
    /// `-(c + 1)`. Checked at load time: in range, and the nodes reachable from node 0 form a
    /// tree (no node is reached twice), so a descent always ends in a leaf.
    pub children: [i32; 2],
    /// Integer bounding box, smallest corner.
    pub mins: [i32; 3],
    /// Integer bounding box, largest corner.
    pub maxs: [i32; 3],
}

/// A convex BSP leaf (lump 4).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Leaf {
    /// PVS cluster, or negative (-1) for solid / outside leaves.
    pub cluster: i32,
    /// Area portal area (doors split areas); negative when none.
    pub area: i32,
    /// Integer bounding box, smallest corner.
    pub mins: [i32; 3],
    /// Integer bounding box, largest corner.
    pub maxs: [i32; 3],
    /// Range into [`BspData::leaf_surfaces`] (checked at load time).
    pub surfaces: Range<u32>,
}

impl Leaf {
    /// The leaf's box as floats.
    pub fn bounds(&self) -> Aabb {
        let v = |a: [i32; 3]| Vec3::new(a[0] as f32, a[1] as f32, a[2] as f32);
        Aabb::new(v(self.mins), v(self.maxs))
    }
}

/// A model of lump 7: model 0 is the static world, the others brush entities (doors, lifts,
/// platforms) whose triangles the loader emits at their compiled (closed) position.
#[derive(Clone, Debug, PartialEq)]
pub struct Model {
    /// Bounding box from the file.
    pub bounds: Aabb,
    /// Range of surface indices (checked at load time; models never share a surface).
    pub surfaces: Range<u32>,
}

/// Surface types of lump 13.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SurfaceKind {
    /// Type 1: planar polygon, pre-triangulated by the compiler.
    Polygon,
    /// Type 2: bezier patch, tessellated by the loader.
    Patch,
    /// Type 3: triangle mesh (models baked into the map).
    Mesh,
    /// Type 4: billboard / flare, no geometry.
    Billboard,
}

/// One surface of lump 13 and where its triangles went.
#[derive(Clone, Debug, PartialEq)]
pub struct Surface {
    /// Type.
    pub kind: SurfaceKind,
    /// Index into [`BspData::shaders`].
    pub shader: u32,
    /// Flags of that shader.
    pub flags: SurfaceFlags,
    /// The model that lists this surface, if any.
    pub model: Option<u32>,
    /// Ids of this surface's triangles in the [`crate::Scene`] (contiguous; empty for
    /// billboards, for patches when `patch_subdivisions` is 0, and for surfaces of no model).
    pub triangles: Range<u32>,
    /// Patch control grid `(width, height)`; `(0, 0)` for other kinds.
    pub patch_size: (u32, u32),
}

/// Quake 3 map data beyond triangles: BSP tree, clusters, leaves, the compiled PVS and the
/// mapping from surfaces to triangle ids. Stored in [`crate::Scene::bsp`] by the loader.
///
/// ```no_run
/// # use sightline_core::scene::{open, LoadOptions};
/// let scene = open("maps/q3dm6ish.bsp", &LoadOptions::default())?;
/// let bsp = scene.bsp.as_deref().expect("a .bsp has BSP data");
/// let eye = bsp.spawn_points[0];
/// if let Some(c) = bsp.cluster_at(eye) {
///     let visible = bsp.triangles_visible_from_cluster(c);
///     println!("{} of {} triangles potentially visible", visible.len(), scene.triangle_count());
/// }
/// # Ok::<(), sightline_core::LoadError>(())
/// ```
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BspData {
    /// Number of PVS clusters (from lump 16; without vis data, one more than the largest leaf
    /// cluster).
    pub clusters: u32,
    /// Bytes per row of [`BspData::vis`] (0 without vis data).
    pub bytes_per_cluster: u32,
    /// The cluster PVS, `clusters` rows of `bytes_per_cluster` bytes: cluster `b` may be seen
    /// from `a` iff bit `b % 8` (LSB first) of byte `a * bytes_per_cluster + b / 8` is set.
    /// Empty when the map has no vis data (then every cluster sees every cluster).
    pub vis: Vec<u8>,
    /// Splitting planes.
    pub planes: Vec<Plane>,
    /// BSP nodes; node 0 is the root (the tree is empty, one leaf, when there are none).
    pub nodes: Vec<Node>,
    /// BSP leaves.
    pub leaves: Vec<Leaf>,
    /// Surface indices of the leaves (lump 5); each leaf owns a range of it. A surface can be
    /// in several leaves.
    pub leaf_surfaces: Vec<u32>,
    /// Models (model 0 = world).
    pub models: Vec<Model>,
    /// Shaders.
    pub shaders: Vec<Shader>,
    /// Surfaces, in file order, with their triangle ids.
    pub surfaces: Vec<Surface>,
    /// For each triangle id, its surface index.
    pub surface_of_triangle: Vec<u32>,
    /// Origins of the player spawn points (see [`Entity::is_spawn_point`]), in file order.
    pub spawn_points: Vec<Vec3>,
    /// All entities of lump 0.
    pub entities: Vec<Entity>,
}

impl BspData {
    /// True when cluster `b` may be seen from cluster `a` by the compiled PVS. False when
    /// either is out of range; true for any two valid clusters when there is no vis data.
    pub fn cluster_sees(&self, a: u32, b: u32) -> bool {
        if a >= self.clusters || b >= self.clusters {
            return false;
        }
        if self.vis.is_empty() {
            return true;
        }
        let at = a as usize * self.bytes_per_cluster as usize + b as usize / 8;
        self.vis
            .get(at)
            .is_some_and(|byte| byte & (1 << (b % 8)) != 0)
    }

    /// Row `a` of the PVS (`bytes_per_cluster` bytes), or `None` when out of range or absent.
    pub fn vis_row(&self, a: u32) -> Option<&[u8]> {
        let n = self.bytes_per_cluster as usize;
        let start = (a as usize).checked_mul(n)?;
        self.vis
            .get(start..start.checked_add(n)?)
            .filter(|_| a < self.clusters)
    }

    /// Fraction of set bits of the `clusters x clusters` PVS (1.0 = everything sees
    /// everything; 0.0 for a map without clusters).
    pub fn pvs_density(&self) -> f64 {
        let n = self.clusters as u64;
        if n == 0 {
            return 0.0;
        }
        let mut set = 0u64;
        for a in 0..self.clusters {
            for b in 0..self.clusters {
                set += u64::from(self.cluster_sees(a, b));
            }
        }
        set as f64 / (n * n) as f64
    }

    /// The surface indices of leaf `leaf` (empty when out of range).
    pub fn surfaces_of_leaf(&self, leaf: usize) -> &[u32] {
        self.leaves
            .get(leaf)
            .and_then(|l| {
                self.leaf_surfaces
                    .get(l.surfaces.start as usize..l.surfaces.end as usize)
            })
            .unwrap_or(&[])
    }

    /// The leaf containing `point`, descending from node 0: front child when
    /// `normal · p - dist >= 0`, else back. 0 when the map has no nodes (a single leaf).
    pub fn leaf_at(&self, point: Vec3) -> usize {
        let mut node = 0i32;
        // The loader checked that the reachable nodes form a tree, so this ends within
        // `nodes.len()` steps; the bound only guards hand-built data.
        for _ in 0..=self.nodes.len() {
            if node < 0 {
                return (-(node + 1)) as usize;
            }
            let Some(n) = self.nodes.get(node as usize) else {
                return 0;
            };
            let d = self
                .planes
                .get(n.plane as usize)
                .map_or(0.0, |p| p.normal.dot(point) - p.dist);
            node = if d >= 0.0 {
                n.children[0]
            } else {
                n.children[1]
            };
        }
        0
    }

    /// The PVS cluster of `point`, or `None` in solid space or outside the map.
    pub fn cluster_at(&self, point: Vec3) -> Option<u32> {
        let c = self.leaves.get(self.leaf_at(point))?.cluster;
        u32::try_from(c).ok().filter(|&c| c < self.clusters)
    }

    /// The leaves whose half-space region the box touches (closed box; the same side rule as
    /// [`BspData::leaf_at`] on its corners), in tree order, each once.
    pub fn leaves_in_box(&self, bounds: &Aabb) -> Vec<usize> {
        let mut out = Vec::new();
        if self.nodes.is_empty() {
            if !self.leaves.is_empty() {
                out.push(0);
            }
            return out;
        }
        let (center, half) = (bounds.center(), bounds.extent() * 0.5);
        let mut stack = vec![0i32];
        // Same bound as `leaf_at`: a tree has at most nodes + leaves entries to visit.
        let mut budget = 2 * (self.nodes.len() + self.leaves.len()) + 1;
        while let Some(node) = stack.pop() {
            budget = budget.saturating_sub(1);
            if budget == 0 {
                break;
            }
            if node < 0 {
                out.push((-(node + 1)) as usize);
                continue;
            }
            let Some(n) = self.nodes.get(node as usize) else {
                continue;
            };
            let Some(p) = self.planes.get(n.plane as usize) else {
                continue;
            };
            let d = p.normal.dot(center) - p.dist;
            let r = p.normal.abs().dot(half);
            // Push back first so the front subtree comes out first.
            if d - r < 0.0 {
                stack.push(n.children[1]);
            }
            if d + r >= 0.0 {
                stack.push(n.children[0]);
            }
        }
        out.sort_unstable();
        out.dedup();
        out
    }

    /// Surface indices that may be seen from cluster `c`: the surfaces of every leaf whose
    /// cluster is set in row `c` of the PVS, plus all surfaces of brush models (1..) whose
    /// bounding box touches such a leaf (movers are in no leaf list; the game culls them by
    /// their box the same way). Sorted; empty when `c` is out of range.
    pub fn surfaces_visible_from_cluster(&self, c: u32) -> Vec<u32> {
        if c >= self.clusters {
            return Vec::new();
        }
        let mut seen = vec![false; self.surfaces.len()];
        let visible_leaf =
            |leaf: &Leaf| u32::try_from(leaf.cluster).is_ok_and(|lc| self.cluster_sees(c, lc));
        for (i, leaf) in self.leaves.iter().enumerate() {
            if visible_leaf(leaf) {
                for &s in self.surfaces_of_leaf(i) {
                    if let Some(flag) = seen.get_mut(s as usize) {
                        *flag = true;
                    }
                }
            }
        }
        for model in self.models.iter().skip(1) {
            let touches = self
                .leaves_in_box(&model.bounds)
                .into_iter()
                .any(|l| self.leaves.get(l).is_some_and(visible_leaf));
            if touches {
                for s in model.surfaces.clone() {
                    if let Some(flag) = seen.get_mut(s as usize) {
                        *flag = true;
                    }
                }
            }
        }
        (0..self.surfaces.len() as u32)
            .filter(|&s| seen[s as usize])
            .collect()
    }

    /// Triangle ids that may be seen from cluster `c` (the triangles of
    /// [`BspData::surfaces_visible_from_cluster`]), sorted ascending.
    pub fn triangles_visible_from_cluster(&self, c: u32) -> Vec<u32> {
        let mut out: Vec<u32> = self
            .surfaces_visible_from_cluster(c)
            .into_iter()
            .filter_map(|s| self.surfaces.get(s as usize))
            .flat_map(|s| s.triangles.clone())
            .collect();
        // Patch triangles come after all polygon/mesh triangles, so surface order is not id
        // order.
        out.sort_unstable();
        out
    }

    /// Flags of triangle `id` (from its surface's shader); `NONE` when out of range.
    pub fn triangle_flags(&self, id: u32) -> SurfaceFlags {
        self.surface_of_triangle
            .get(id as usize)
            .and_then(|&s| self.surfaces.get(s as usize))
            .map_or(SurfaceFlags::NONE, |s| s.flags)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two leaves split by the plane x = 0: leaf 0 in front (x >= 0, cluster 0), leaf 1
    /// behind (cluster 1). Cluster 0 sees only itself; cluster 1 sees both.
    fn two_leaves() -> BspData {
        BspData {
            clusters: 2,
            bytes_per_cluster: 1,
            vis: vec![0b01, 0b11],
            planes: vec![Plane {
                normal: Vec3::X,
                dist: 0.0,
            }],
            nodes: vec![Node {
                plane: 0,
                children: [-1, -2],
                ..Node::default()
            }],
            leaves: vec![
                Leaf {
                    cluster: 0,
                    surfaces: 0..1,
                    ..Leaf::default()
                },
                Leaf {
                    cluster: 1,
                    surfaces: 1..2,
                    ..Leaf::default()
                },
            ],
            leaf_surfaces: vec![0, 1],
            surfaces: vec![
                Surface {
                    kind: SurfaceKind::Polygon,
                    shader: 0,
                    flags: SurfaceFlags::NONE,
                    model: Some(0),
                    triangles: 0..2,
                    patch_size: (0, 0),
                },
                Surface {
                    kind: SurfaceKind::Polygon,
                    shader: 0,
                    flags: SurfaceFlags::TRANSLUCENT,
                    model: Some(0),
                    triangles: 2..3,
                    patch_size: (0, 0),
                },
            ],
            surface_of_triangle: vec![0, 0, 1],
            ..BspData::default()
        }
    }

    #[test]
    fn empty_data_answers_safely() {
        let b = BspData::default();
        assert_eq!(b.leaf_at(Vec3::ZERO), 0);
        assert_eq!(b.cluster_at(Vec3::ZERO), None);
        assert!(!b.cluster_sees(0, 0));
        assert!(b.triangles_visible_from_cluster(0).is_empty());
        assert!(b
            .leaves_in_box(&Aabb::new(Vec3::ZERO, Vec3::ONE))
            .is_empty());
        assert_eq!(b.pvs_density(), 0.0);
        assert_eq!(b.vis_row(0), None);
        assert_eq!(b.triangle_flags(0), SurfaceFlags::NONE);
    }

    #[test]
    fn point_on_plane_goes_to_front() {
        let b = two_leaves();
        assert_eq!(b.leaf_at(Vec3::ZERO), 0);
        assert_eq!(b.leaf_at(Vec3::new(-0.1, 5.0, 5.0)), 1);
        assert_eq!(b.cluster_at(Vec3::new(-1.0, 0.0, 0.0)), Some(1));
    }

    #[test]
    fn vis_is_directional() {
        let b = two_leaves();
        assert!(b.cluster_sees(1, 0) && !b.cluster_sees(0, 1));
        assert_eq!(b.triangles_visible_from_cluster(0), vec![0, 1]);
        assert_eq!(b.triangles_visible_from_cluster(1), vec![0, 1, 2]);
        assert_eq!(b.pvs_density(), 0.75);
    }

    #[test]
    fn box_across_plane_touches_both_leaves() {
        let b = two_leaves();
        let across = Aabb::new(Vec3::splat(-1.0), Vec3::splat(1.0));
        assert_eq!(b.leaves_in_box(&across), vec![0, 1]);
        let front = Aabb::new(Vec3::splat(1.0), Vec3::splat(2.0));
        assert_eq!(b.leaves_in_box(&front), vec![0]);
    }

    #[test]
    fn translucent_does_not_occlude_but_sky_does() {
        let b = two_leaves();
        assert!(!b.triangle_flags(2).occludes());
        assert!(b.triangle_flags(0).occludes());
        assert!(SurfaceFlags::from_shader(0x4, 0).occludes());
        assert!(SurfaceFlags::from_shader(0, 32).contains(SurfaceFlags::LIQUID));
    }

    #[test]
    fn no_vis_data_sees_everything() {
        let mut b = two_leaves();
        b.vis.clear();
        b.bytes_per_cluster = 0;
        assert!(b.cluster_sees(0, 1));
    }
}
