//! The map's triangles and objects, once every lump has been read and checked: positions and
//! triangles in the documented id order (module docs, "Triangle ids" and "Vertices"), each
//! surface's triangle range, and the grouping of triangles into objects (module docs,
//! "Objects").

use std::path::Path;

use glam::Vec3;

use super::super::builder::SceneBuilder;
use super::super::error::LoadError;
use super::super::options::LoadOptions;
use super::super::types::{Object, Scene, UpAxis};
use super::data::{BspData, SurfaceKind};
use super::lumps::RawSurface;
use super::patch;

/// Most triangles a map may produce (see [`check_triangle_count`]).
const MAX_TRIANGLES: u64 = 1 << 30;

/// What the triangles are made from: the surface records (lump 13), the drawverts (lump 10)
/// and the drawindexes (lump 11).
pub(super) struct DrawData<'a> {
    pub(super) raw_surfaces: &'a [RawSurface],
    pub(super) drawverts: &'a [Vec3],
    pub(super) drawindexes: &'a [i32],
}

/// Emits positions and triangles in the documented id order and records each surface's
/// triangle range and each triangle's surface. The surfaces' ranges and indices must have
/// been checked against `draw`.
pub(super) fn emit_geometry(
    path: &Path,
    bsp: &mut BspData,
    draw: &DrawData,
    options: &LoadOptions,
) -> Result<Scene, LoadError> {
    // Surfaces in model order (model 0 first); each surface is in at most one model.
    let order: Vec<usize> = bsp
        .models
        .iter()
        .flat_map(|m| m.surfaces.start as usize..m.surfaces.end as usize)
        .collect();
    let n = options.patch_subdivisions as u64;
    let total = check_triangle_count(path, bsp, draw, &order, n)?;
    let mut b = SceneBuilder::new(path.display().to_string());
    b.set_up(UpAxis::Z);
    b.reserve(draw.drawverts.len(), total as usize);
    for &p in draw.drawverts {
        b.add_vertex(p);
    }
    let mut out = Emitter {
        builder: b,
        surface_of_triangle: Vec::with_capacity(total as usize),
    };
    out.flat_surfaces(bsp, draw, &order);
    if n > 0 {
        out.patches(bsp, draw, &order, n as usize);
    }
    bsp.surface_of_triangle = out.surface_of_triangle;
    Ok(out.builder.finish())
}

/// The number of triangles the surfaces `order` make with patches at `n` subdivisions; more
/// than [`MAX_TRIANGLES`] is an error. Triangle ids and vertex indices are u32; a patch grid
/// has at most twice as many vertices as triangles, so 2^30 triangles keep both in range.
fn check_triangle_count(
    path: &Path,
    bsp: &BspData,
    draw: &DrawData,
    order: &[usize],
    n: u64,
) -> Result<u64, LoadError> {
    let (mut flat, mut curved) = (0u64, 0u64);
    for &s in order {
        let raw = &draw.raw_surfaces[s];
        match bsp.surfaces[s].kind {
            SurfaceKind::Polygon | SurfaceKind::Mesh => flat += raw.num_indexes as u64 / 3,
            SurfaceKind::Patch => {
                let (w, h) = bsp.surfaces[s].patch_size;
                curved += patch::sub_patch_count(w as usize, h as usize) as u64 * 2 * n * n;
            }
            SurfaceKind::Billboard => {}
        }
    }
    if flat + curved > MAX_TRIANGLES {
        return Err(LoadError::Invalid {
            path: path.to_path_buf(),
            message: format!(
                "{} triangles ({flat} flat + {curved} patch at {n} subdivisions) exceed the \
                 limit of {MAX_TRIANGLES}",
                flat + curved
            ),
        });
    }
    Ok(flat + curved)
}

/// The scene being emitted and the surface of each triangle so far.
struct Emitter {
    builder: SceneBuilder,
    surface_of_triangle: Vec<u32>,
}

impl Emitter {
    /// Emits the polygon and mesh surfaces among `order`, in that order: their index triples
    /// over the drawverts (positions `0 .. numDrawVerts`).
    fn flat_surfaces(&mut self, bsp: &mut BspData, draw: &DrawData, order: &[usize]) {
        let b = &mut self.builder;
        for &s in order {
            let raw = &draw.raw_surfaces[s];
            if !matches!(
                bsp.surfaces[s].kind,
                SurfaceKind::Polygon | SurfaceKind::Mesh
            ) {
                continue;
            }
            // Ranges and indices were checked when the surfaces were read.
            let base = raw.first_vert as u32;
            let first = b.triangle_count() as u32;
            let indexes = &draw.drawindexes[raw.first_index as usize..][..raw.num_indexes as usize];
            for t in indexes.chunks_exact(3) {
                b.add_triangle([base + t[0] as u32, base + t[1] as u32, base + t[2] as u32]);
                self.surface_of_triangle.push(s as u32);
            }
            bsp.surfaces[s].triangles = first..b.triangle_count() as u32;
        }
    }

    /// Emits the patch surfaces among `order`, in that order, each tessellated at `n`
    /// subdivisions into a grid of its own vertices.
    fn patches(&mut self, bsp: &mut BspData, draw: &DrawData, order: &[usize], n: usize) {
        let b = &mut self.builder;
        for &s in order {
            if bsp.surfaces[s].kind != SurfaceKind::Patch {
                continue;
            }
            let raw = &draw.raw_surfaces[s];
            let (w, h) = bsp.surfaces[s].patch_size;
            let control = &draw.drawverts[raw.first_vert as usize..][..raw.num_verts as usize];
            let grid = patch::tessellate(control, w as usize, h as usize, n);
            let base = b.vertex_count();
            for p in grid.positions {
                b.add_vertex(p);
            }
            let first = b.triangle_count() as u32;
            for [x, y, z] in grid.triangles {
                b.add_triangle([base + x, base + y, base + z]);
                self.surface_of_triangle.push(s as u32);
            }
            bsp.surfaces[s].triangles = first..b.triangle_count() as u32;
        }
    }
}

/// Replaces the builder's single object by the documented grouping (module docs, "Objects"):
/// world surfaces by (cluster, shader), brush-model surfaces by (model, shader).
pub(super) fn assign_objects(scene: &mut Scene, bsp: &BspData) {
    // Lowest cluster of the leaves that list each surface (u32::MAX: none lists it).
    let mut cluster_of_surface = vec![u32::MAX; bsp.surfaces.len()];
    for (l, leaf) in bsp.leaves.iter().enumerate() {
        let Ok(cluster) = u32::try_from(leaf.cluster) else {
            continue;
        };
        for &s in bsp.surfaces_of_leaf(l) {
            if let Some(slot) = cluster_of_surface.get_mut(s as usize) {
                *slot = (*slot).min(cluster);
            }
        }
    }
    // Key per surface: (model, cluster in the world / u32::MAX for brush models, shader);
    // surfaces of no model emit no triangles.
    let key = |s: usize| {
        let surface = &bsp.surfaces[s];
        let model = surface.model.unwrap_or(u32::MAX);
        let cluster = if model == 0 {
            cluster_of_surface[s]
        } else {
            u32::MAX
        };
        (model, cluster, surface.shader)
    };
    let mut keys: Vec<(u32, u32, u32)> = bsp
        .surface_of_triangle
        .iter()
        .map(|&s| key(s as usize))
        .collect();
    keys.sort_unstable();
    keys.dedup();
    scene.objects = keys
        .iter()
        .map(|&(model, cluster, shader)| {
            let shader_name = bsp
                .shaders
                .get(shader as usize)
                .map_or("", |sh| sh.name.as_str());
            let name = match (model, cluster) {
                (0, u32::MAX) => format!("model0/nocluster/{shader_name}"),
                (0, c) => format!("model0/cluster{c}/{shader_name}"),
                (m, _) => format!("model{m}/{shader_name}"),
            };
            Object {
                name,
                index: Some(model),
                part: Some(shader),
            }
        })
        .collect();
    // Object id of each surface, looked up once per surface.
    let object_of_surface: Vec<u32> = (0..bsp.surfaces.len())
        .map(|s| keys.binary_search(&key(s)).map_or(u32::MAX, |k| k as u32))
        .collect();
    scene.object_of_triangle = bsp
        .surface_of_triangle
        .iter()
        .map(|&s| object_of_surface[s as usize])
        .collect();
}
