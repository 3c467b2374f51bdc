//! Quake 3 map loader: id Software's IBSP version 46 `.bsp` format (Quake 3 Arena, OpenArena),
//! including its BSP tree, leaves, clusters and compiled cluster-to-cluster PVS.
//!
//! Based on: the layout in `shared/scenes/SOURCES.md` ("IBSP version 46 layout"), which follows
//! Kekoa Proudfoot, "Unofficial Quake 3 Map Specs" (2000), and the q3map2 conventions noted
//! there. Coordinates are Quake units (about an inch), Z up.
//!
//! # Triangle ids
//! 1. Polygon (type 1) and mesh (type 3) triangles of every model, model 0 (the world) first,
//!    then brush models 1..n; within a model, surfaces in order
//!    `firstSurface .. firstSurface + numSurfaces`; within a surface, index triples in order.
//! 2. Then the bezier patch (type 2) triangles, in the same model and surface order (see
//!    `patch.rs` for the order within a patch).
//!
//! So polygon and mesh ids do not depend on [`LoadOptions::patch_subdivisions`]: a PVS baked
//! with one tessellation level still names the same flat triangles at another. Billboards
//! (type 4) have no geometry. Every surface's ids form one contiguous range, recorded in
//! [`BspData::surfaces`].
//!
//! Surfaces with sky or nodraw shaders are kept (sky is the opaque boundary of the map; q3map2
//! drops nodraw surfaces itself, none of the test maps has one with triangles). This is how
//! SOURCES.md counts: fan's 1,082 triangles include its 6 sky triangles, czest3ctf's 19,343
//! its 142. Flags per surface and per triangle are in [`BspData`] so later code can treat
//! glass, water and fog as non-occluding ([`SurfaceFlags::occludes`]).
//!
//! # Vertices
//! Positions `0 .. numDrawVerts` are the drawverts of lump 10 in file order (so position index
//! = drawvert index; patch control points stay unreferenced), followed by the tessellated patch
//! grids (one grid per patch, sub-patches share their border vertices).
//!
//! # Objects
//! The world (model 0) is split by PVS cluster and shader: one object per (cluster, shader)
//! pair with triangles, named `model0/cluster{c}/{shader name}`, where a surface's cluster is
//! the lowest cluster of the leaves that list it (a surface spanning rooms is listed by the
//! leaves of each; world surfaces no leaf lists are `model0/nocluster/{shader}`). That is the
//! mesh a map exporter makes per room and material, and it keeps per-object culling close to
//! the triangle sets: measured with the maps' own cluster PVS (share of triangles drawn when
//! every object with a visible triangle is drawn, mean over clusters), 51.0 % against 48.7 %
//! for the triangle PVS on q3dm6ish and 11.3 % against 10.2 % on czest3ctf, where one object
//! per shader drew 97.5 % and 62.5 % (`docs/objects.md` has the six maps). Brush models
//! (doors, platforms: `model3`) move as a whole, so they are split by shader only:
//! `model{m}/{shader name}`.
//!
//! Shader names are those of lump 1 as stored (e.g. `textures/base_wall/concrete_dark`).
//! [`super::Object::index`] is the model number `m` and [`super::Object::part`] the shader index
//! in lump 1 (two shader records with the same name stay two objects, told apart by `part`; in
//! the world the name's cluster tells apart the objects of one shader). Objects are ordered by
//! model, then cluster (`nocluster` last), then shader index; every surface's triangles belong
//! to the object of its model, cluster and shader ([`BspData`] has all three).
//!
//! # Errors
//! Every offset, count and index in the file is checked before use; errors name the lump and
//! record (`lump 13 (surfaces), record 12`) or the byte offset of the header field.

pub(super) mod data;
mod entities;
mod lumps;
mod patch;

use std::path::Path;

use glam::Vec3;

use super::builder::SceneBuilder;
use super::error::{LoadError, Location};
use super::options::LoadOptions;
use super::types::{Scene, UpAxis};
use crate::geometry::Aabb;
pub use data::{BspData, Leaf, Model, Node, Plane, Shader, Surface, SurfaceFlags, SurfaceKind};
pub use entities::Entity;
use lumps::{f32_at, f32x3_at, i32_at, i32x3_at, record_location, Lumps};

/// Most triangles a map may produce (see `emit_geometry`).
const MAX_TRIANGLES: u64 = 1 << 30;

/// A surface record of lump 13, the fields the loader uses.
#[derive(Clone, Copy, Debug)]
struct RawSurface {
    shader: i32,
    kind: i32,
    first_vert: i32,
    num_verts: i32,
    first_index: i32,
    num_indexes: i32,
    patch_width: i32,
    patch_height: i32,
}

/// Error helper carrying the path.
struct Ctx<'a> {
    path: &'a Path,
}

impl Ctx<'_> {
    fn at(&self, lump: usize, record: usize, message: impl Into<String>) -> LoadError {
        LoadError::parse(self.path, record_location(lump, record), message)
    }
}

/// `first .. first + count` as a checked range inside `0 .. len`.
fn checked_range(first: i32, count: i32, len: usize) -> Option<std::ops::Range<usize>> {
    let first = usize::try_from(first).ok()?;
    let count = usize::try_from(count).ok()?;
    let end = first.checked_add(count)?;
    (end <= len).then_some(first..end)
}

/// Loads a Quake 3 `.bsp` file from its bytes; `path` is for error messages. See the module
/// documentation for the triangle id order, the object grouping and what is checked.
pub fn load(path: &Path, bytes: &[u8], options: &LoadOptions) -> Result<Scene, LoadError> {
    let ctx = Ctx { path };
    let lumps = Lumps::parse(path, bytes)?;

    let shaders: Vec<Shader> = lumps
        .records(lumps::SHADERS)
        .map(|r| {
            let name = &r[..64];
            let end = name.iter().position(|&b| b == 0).unwrap_or(64);
            Shader {
                name: String::from_utf8_lossy(&name[..end]).into_owned(),
                surface_flags: i32_at(r, 64),
                content_flags: i32_at(r, 68),
            }
        })
        .collect();
    let planes: Vec<Plane> = lumps
        .records(lumps::PLANES)
        .map(|r| Plane {
            normal: Vec3::from_array(f32x3_at(r, 0)),
            dist: f32_at(r, 12),
        })
        .collect();
    let drawverts: Vec<Vec3> = lumps
        .records(lumps::DRAWVERTS)
        .map(|r| Vec3::from_array(f32x3_at(r, 0)))
        .collect();
    let drawindexes: Vec<i32> = lumps
        .records(lumps::DRAWINDEXES)
        .map(|r| i32_at(r, 0))
        .collect();
    let raw_surfaces: Vec<RawSurface> = lumps
        .records(lumps::SURFACES)
        .map(|r| RawSurface {
            shader: i32_at(r, 0),
            kind: i32_at(r, 8),
            first_vert: i32_at(r, 12),
            num_verts: i32_at(r, 16),
            first_index: i32_at(r, 20),
            num_indexes: i32_at(r, 24),
            patch_width: i32_at(r, 96),
            patch_height: i32_at(r, 100),
        })
        .collect();

    // Surfaces: shader, type, vertex and index ranges, every index.
    let mut surfaces = Vec::with_capacity(raw_surfaces.len());
    for (i, s) in raw_surfaces.iter().enumerate() {
        let err = |m: String| ctx.at(lumps::SURFACES, i, m);
        let shader = usize::try_from(s.shader)
            .ok()
            .and_then(|k| shaders.get(k))
            .ok_or_else(|| {
                err(format!(
                    "shader {} out of range (lump 1 has {} shaders)",
                    s.shader,
                    shaders.len()
                ))
            })?;
        let kind = match s.kind {
            1 => SurfaceKind::Polygon,
            2 => SurfaceKind::Patch,
            3 => SurfaceKind::Mesh,
            4 => SurfaceKind::Billboard,
            k => return Err(err(format!("unknown surface type {k} (expected 1 to 4)"))),
        };
        let mut patch_size = (0, 0);
        match kind {
            SurfaceKind::Polygon | SurfaceKind::Mesh => {
                let verts =
                    checked_range(s.first_vert, s.num_verts, drawverts.len()).ok_or_else(|| {
                        err(format!(
                            "vertices {} + {} outside lump 10 (drawverts, {} records)",
                            s.first_vert,
                            s.num_verts,
                            drawverts.len()
                        ))
                    })?;
                let indexes = checked_range(s.first_index, s.num_indexes, drawindexes.len())
                    .ok_or_else(|| {
                        err(format!(
                            "indexes {} + {} outside lump 11 (drawindexes, {} records)",
                            s.first_index,
                            s.num_indexes,
                            drawindexes.len()
                        ))
                    })?;
                if s.num_indexes % 3 != 0 {
                    return Err(err(format!(
                        "{} indexes, not a multiple of 3",
                        s.num_indexes
                    )));
                }
                if let Some(k) = drawindexes[indexes.clone()]
                    .iter()
                    .position(|&v| usize::try_from(v).map_or(true, |v| v >= verts.len()))
                {
                    return Err(err(format!(
                        "index {} (drawindexes record {}) is outside the surface's {} vertices",
                        drawindexes[indexes.start + k],
                        indexes.start + k,
                        verts.len()
                    )));
                }
            }
            SurfaceKind::Patch => {
                let (w, h) = (s.patch_width, s.patch_height);
                if w < 3 || h < 3 || w % 2 == 0 || h % 2 == 0 {
                    return Err(err(format!(
                        "patch size {w} x {h}: both must be odd and at least 3"
                    )));
                }
                if i64::from(w) * i64::from(h) != i64::from(s.num_verts) {
                    return Err(err(format!(
                        "patch size {w} x {h} does not match its {} vertices",
                        s.num_verts
                    )));
                }
                checked_range(s.first_vert, s.num_verts, drawverts.len()).ok_or_else(|| {
                    err(format!(
                        "vertices {} + {} outside lump 10 (drawverts, {} records)",
                        s.first_vert,
                        s.num_verts,
                        drawverts.len()
                    ))
                })?;
                patch_size = (w as u32, h as u32);
            }
            SurfaceKind::Billboard => {}
        }
        surfaces.push(Surface {
            kind,
            shader: s.shader as u32,
            flags: SurfaceFlags::from_shader(shader.surface_flags, shader.content_flags),
            model: None,
            triangles: 0..0,
            patch_size,
        });
    }

    // Models: surface ranges, each surface in at most one model.
    let mut models = Vec::with_capacity(lumps.count(lumps::MODELS));
    for (m, r) in lumps.records(lumps::MODELS).enumerate() {
        let (first, count) = (i32_at(r, 24), i32_at(r, 28));
        let range = checked_range(first, count, surfaces.len()).ok_or_else(|| {
            ctx.at(
                lumps::MODELS,
                m,
                format!(
                    "surfaces {first} + {count} outside lump 13 (surfaces, {} records)",
                    surfaces.len()
                ),
            )
        })?;
        for s in range.clone() {
            if let Some(other) = surfaces[s].model {
                return Err(ctx.at(
                    lumps::MODELS,
                    m,
                    format!("surface {s} already belongs to model {other}"),
                ));
            }
            surfaces[s].model = Some(m as u32);
        }
        models.push(Model {
            bounds: Aabb::new(
                Vec3::from_array(f32x3_at(r, 0)),
                Vec3::from_array(f32x3_at(r, 12)),
            ),
            surfaces: range.start as u32..range.end as u32,
        });
    }

    let leaf_count = lumps.count(lumps::LEAFS);
    let nodes = read_nodes(&ctx, &lumps, planes.len(), leaf_count)?;

    let leaf_surfaces: Vec<u32> = lumps
        .records(lumps::LEAFSURFACES)
        .enumerate()
        .map(|(k, r)| {
            let s = i32_at(r, 0);
            usize::try_from(s)
                .ok()
                .filter(|&s| s < surfaces.len())
                .map(|s| s as u32)
                .ok_or_else(|| {
                    ctx.at(
                        lumps::LEAFSURFACES,
                        k,
                        format!(
                            "surface {s} out of range (lump 13 has {} surfaces)",
                            surfaces.len()
                        ),
                    )
                })
        })
        .collect::<Result<_, _>>()?;

    let mut leaves = Vec::with_capacity(leaf_count);
    for (l, r) in lumps.records(lumps::LEAFS).enumerate() {
        let (first, count) = (i32_at(r, 32), i32_at(r, 36));
        let range = checked_range(first, count, leaf_surfaces.len()).ok_or_else(|| {
            ctx.at(
                lumps::LEAFS,
                l,
                format!(
                    "leaf surfaces {first} + {count} outside lump 5 (leafsurfaces, {} records)",
                    leaf_surfaces.len()
                ),
            )
        })?;
        leaves.push(Leaf {
            cluster: i32_at(r, 0),
            area: i32_at(r, 4),
            mins: i32x3_at(r, 8),
            maxs: i32x3_at(r, 20),
            surfaces: range.start as u32..range.end as u32,
        });
    }

    let (clusters, bytes_per_cluster, vis) = read_visdata(&ctx, &lumps, &leaves)?;
    if let Some((l, leaf)) = leaves
        .iter()
        .enumerate()
        .find(|(_, leaf)| leaf.cluster >= 0 && leaf.cluster as u32 >= clusters)
    {
        return Err(ctx.at(
            lumps::LEAFS,
            l,
            format!(
                "cluster {} out of range (lump 16 has {clusters} clusters)",
                leaf.cluster
            ),
        ));
    }

    let entities = entities::parse(lumps.raw(lumps::ENTITIES));
    let spawn_points = entities
        .iter()
        .filter(|e| e.is_spawn_point())
        .filter_map(Entity::origin)
        .collect();

    let mut bsp = BspData {
        clusters,
        bytes_per_cluster,
        vis,
        planes,
        nodes,
        leaves,
        leaf_surfaces,
        models,
        shaders,
        surfaces,
        surface_of_triangle: Vec::new(),
        spawn_points,
        entities,
    };
    let mut scene = emit_geometry(
        &ctx,
        &mut bsp,
        &raw_surfaces,
        &drawverts,
        &drawindexes,
        options,
    )?;
    assign_objects(&mut scene, &bsp);
    scene.bsp = Some(Box::new(bsp));
    Ok(scene)
}

/// Reads lump 3 and checks plane and child indices, and that the nodes reachable from node 0
/// form a tree (so every descent ends in a leaf).
fn read_nodes(
    ctx: &Ctx<'_>,
    lumps: &Lumps<'_>,
    plane_count: usize,
    leaf_count: usize,
) -> Result<Vec<Node>, LoadError> {
    let mut nodes = Vec::with_capacity(lumps.count(lumps::NODES));
    for (n, r) in lumps.records(lumps::NODES).enumerate() {
        let plane = i32_at(r, 0);
        if usize::try_from(plane).map_or(true, |p| p >= plane_count) {
            return Err(ctx.at(
                lumps::NODES,
                n,
                format!("plane {plane} out of range (lump 2 has {plane_count} planes)"),
            ));
        }
        let children = [i32_at(r, 4), i32_at(r, 8)];
        for c in children {
            let ok = if c >= 0 {
                (c as usize) < lumps.count(lumps::NODES)
            } else {
                // -(c + 1) without overflow for c = i32::MIN.
                ((-(i64::from(c) + 1)) as u64) < leaf_count as u64
            };
            if !ok {
                return Err(ctx.at(
                    lumps::NODES,
                    n,
                    format!(
                        "child {c} out of range ({} nodes, {leaf_count} leafs)",
                        lumps.count(lumps::NODES)
                    ),
                ));
            }
        }
        nodes.push(Node {
            plane: plane as u32,
            children,
            mins: i32x3_at(r, 12),
            maxs: i32x3_at(r, 24),
        });
    }
    if nodes.is_empty() {
        return Ok(nodes);
    }
    let mut reached = vec![false; nodes.len()];
    let mut stack = vec![0usize];
    reached[0] = true;
    while let Some(n) = stack.pop() {
        for c in nodes[n].children {
            if c >= 0 {
                let c = c as usize;
                if reached[c] {
                    return Err(ctx.at(
                        lumps::NODES,
                        n,
                        format!("child node {c} is reached twice: the nodes do not form a tree"),
                    ));
                }
                reached[c] = true;
                stack.push(c);
            }
        }
    }
    Ok(nodes)
}

/// Reads lump 16: `(clusters, bytes_per_cluster, bits)`. Without vis data the cluster count
/// comes from the leaves and the bits are empty (everything visible, as in the game).
fn read_visdata(
    ctx: &Ctx<'_>,
    lumps: &Lumps<'_>,
    leaves: &[Leaf],
) -> Result<(u32, u32, Vec<u8>), LoadError> {
    let raw = lumps.raw(lumps::VISDATA);
    if raw.is_empty() {
        let clusters = leaves
            .iter()
            .map(|l| l.cluster.saturating_add(1).max(0) as u32)
            .max()
            .unwrap_or(0);
        return Ok((clusters, 0, Vec::new()));
    }
    let at = |field: usize, message: String| {
        LoadError::parse(
            ctx.path,
            Location::Byte((lumps.offset(lumps::VISDATA) + field) as u64),
            format!("lump 16 (visdata): {message}"),
        )
    };
    if raw.len() < 8 {
        return Err(at(
            0,
            format!("{} bytes, shorter than its 8-byte header", raw.len()),
        ));
    }
    let (n, bpc) = (i32_at(raw, 0), i32_at(raw, 4));
    if n < 0 || bpc < 0 {
        return Err(at(
            0,
            format!("negative cluster count {n} or row size {bpc}"),
        ));
    }
    if (bpc as u64) * 8 < n as u64 {
        return Err(at(
            4,
            format!("{bpc} bytes per cluster cannot hold {n} cluster bits"),
        ));
    }
    let size = n as u64 * bpc as u64;
    if 8 + size > raw.len() as u64 {
        return Err(at(
            8,
            format!(
                "{n} clusters x {bpc} bytes need {size} bytes, only {} present",
                raw.len() - 8
            ),
        ));
    }
    Ok((n as u32, bpc as u32, raw[8..8 + size as usize].to_vec()))
}

/// Emits positions and triangles in the documented id order and records each surface's
/// triangle range and each triangle's surface.
fn emit_geometry(
    ctx: &Ctx<'_>,
    bsp: &mut BspData,
    raw_surfaces: &[RawSurface],
    drawverts: &[Vec3],
    drawindexes: &[i32],
    options: &LoadOptions,
) -> Result<Scene, LoadError> {
    // Surfaces in model order (model 0 first); each surface is in at most one model.
    let order: Vec<usize> = bsp
        .models
        .iter()
        .flat_map(|m| m.surfaces.start as usize..m.surfaces.end as usize)
        .collect();
    let n = options.patch_subdivisions as u64;
    let (mut flat, mut curved) = (0u64, 0u64);
    for &s in &order {
        let raw = &raw_surfaces[s];
        match bsp.surfaces[s].kind {
            SurfaceKind::Polygon | SurfaceKind::Mesh => flat += raw.num_indexes as u64 / 3,
            SurfaceKind::Patch => {
                let (w, h) = bsp.surfaces[s].patch_size;
                curved += patch::sub_patch_count(w as usize, h as usize) as u64 * 2 * n * n;
            }
            SurfaceKind::Billboard => {}
        }
    }
    // Triangle ids and vertex indices are u32; a patch grid has at most twice as many
    // vertices as triangles, so 2^30 triangles keep both in range.
    if flat + curved > MAX_TRIANGLES {
        return Err(LoadError::Invalid {
            path: ctx.path.to_path_buf(),
            message: format!(
                "{} triangles ({flat} flat + {curved} patch at {n} subdivisions) exceed the \
                 limit of {MAX_TRIANGLES}",
                flat + curved
            ),
        });
    }

    let mut b = SceneBuilder::new(ctx.path.display().to_string());
    b.set_up(UpAxis::Z);
    b.reserve(drawverts.len(), (flat + curved) as usize);
    for &p in drawverts {
        b.add_vertex(p);
    }
    let mut surface_of_triangle = Vec::with_capacity((flat + curved) as usize);
    for &s in &order {
        let raw = &raw_surfaces[s];
        if !matches!(
            bsp.surfaces[s].kind,
            SurfaceKind::Polygon | SurfaceKind::Mesh
        ) {
            continue;
        }
        // Ranges and indices were checked when the surfaces were read.
        let base = raw.first_vert as u32;
        let first = b.triangle_count() as u32;
        let indexes = &drawindexes[raw.first_index as usize..][..raw.num_indexes as usize];
        for t in indexes.chunks_exact(3) {
            b.add_triangle([base + t[0] as u32, base + t[1] as u32, base + t[2] as u32]);
            surface_of_triangle.push(s as u32);
        }
        bsp.surfaces[s].triangles = first..b.triangle_count() as u32;
    }
    if n > 0 {
        for &s in &order {
            if bsp.surfaces[s].kind != SurfaceKind::Patch {
                continue;
            }
            let raw = &raw_surfaces[s];
            let (w, h) = bsp.surfaces[s].patch_size;
            let control = &drawverts[raw.first_vert as usize..][..raw.num_verts as usize];
            let grid = patch::tessellate(control, w as usize, h as usize, n as usize);
            let base = b.vertex_count();
            for p in grid.positions {
                b.add_vertex(p);
            }
            let first = b.triangle_count() as u32;
            for [x, y, z] in grid.triangles {
                b.add_triangle([base + x, base + y, base + z]);
                surface_of_triangle.push(s as u32);
            }
            bsp.surfaces[s].triangles = first..b.triangle_count() as u32;
        }
    }
    bsp.surface_of_triangle = surface_of_triangle;
    Ok(b.finish())
}

/// Replaces the builder's single object by the documented grouping (module docs, "Objects"):
/// world surfaces by (cluster, shader), brush-model surfaces by (model, shader).
fn assign_objects(scene: &mut Scene, bsp: &BspData) {
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
            super::types::Object {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn empty_input_is_error() {
        let e = load(Path::new("e.bsp"), &[], &LoadOptions::default()).expect_err("error");
        assert!(e.to_string().contains("e.bsp"), "{e}");
    }

    #[test]
    fn wrong_magic_is_named() {
        let mut b = vec![0u8; lumps::HEADER_BYTES];
        b[0..4].copy_from_slice(b"VBSP");
        let e = load(Path::new("x.bsp"), &b, &LoadOptions::default()).expect_err("error");
        assert!(e.to_string().contains("IBSP"), "{e}");
    }

    #[test]
    fn header_with_empty_lumps_is_empty_scene() {
        let mut b = vec![0u8; lumps::HEADER_BYTES];
        b[0..4].copy_from_slice(b"IBSP");
        b[4..8].copy_from_slice(&46i32.to_le_bytes());
        let s = load(Path::new("x.bsp"), &b, &LoadOptions::default()).expect("loads");
        assert!(s.is_empty());
        assert_eq!(s.up, UpAxis::Z);
        let bsp = s.bsp.expect("bsp data");
        assert_eq!(bsp.clusters, 0);
        assert_eq!(bsp.leaf_at(Vec3::ZERO), 0);
    }

    #[test]
    fn checked_range_rejects_negative_and_overflow() {
        assert_eq!(checked_range(1, 2, 3), Some(1..3));
        assert_eq!(checked_range(-1, 2, 3), None);
        assert_eq!(checked_range(1, -2, 3), None);
        assert_eq!(
            checked_range(i32::MAX, i32::MAX, usize::MAX),
            Some(i32::MAX as usize..2 * i32::MAX as usize)
        );
        assert_eq!(checked_range(2, 2, 3), None);
    }
}
