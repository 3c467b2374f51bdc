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
mod geometry;
mod lumps;
mod patch;

use std::path::Path;

use glam::Vec3;

use super::error::{LoadError, Location};
use super::options::LoadOptions;
use super::types::Scene;
use crate::geometry::Aabb;
pub use data::{BspData, Leaf, Model, Node, Plane, Shader, Surface, SurfaceFlags, SurfaceKind};
pub use entities::Entity;
use geometry::{assign_objects, emit_geometry, DrawData};
use lumps::{f32_at, f32x3_at, i32_at, i32x3_at, record_location, Lumps, RawSurface};

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

    let shaders = read_shaders(&lumps);
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
        .map(RawSurface::read)
        .collect();
    let draw = DrawData {
        raw_surfaces: &raw_surfaces,
        drawverts: &drawverts,
        drawindexes: &drawindexes,
    };

    let mut surfaces = read_surfaces(&ctx, &draw, &shaders)?;
    let models = read_models(&ctx, &lumps, &mut surfaces)?;
    let leaf_count = lumps.count(lumps::LEAFS);
    let nodes = read_nodes(&ctx, &lumps, planes.len(), leaf_count)?;
    let leaf_surfaces = read_leaf_surfaces(&ctx, &lumps, surfaces.len())?;
    let leaves = read_leaves(&ctx, &lumps, leaf_surfaces.len())?;
    let (clusters, bytes_per_cluster, vis) = read_visdata(&ctx, &lumps, &leaves)?;
    check_leaf_clusters(&ctx, &leaves, clusters)?;

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
    let mut scene = emit_geometry(path, &mut bsp, &draw, options)?;
    assign_objects(&mut scene, &bsp);
    scene.bsp = Some(Box::new(bsp));
    Ok(scene)
}

/// Reads lump 1: each shader's name (up to its first NUL) and flags.
fn read_shaders(lumps: &Lumps<'_>) -> Vec<Shader> {
    lumps
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
        .collect()
}

/// Checks every surface record of lump 13 (shader, type, vertex and index ranges, every
/// index) and makes its [`Surface`], not yet in a model and without triangles.
fn read_surfaces(
    ctx: &Ctx<'_>,
    draw: &DrawData,
    shaders: &[Shader],
) -> Result<Vec<Surface>, LoadError> {
    let mut surfaces = Vec::with_capacity(draw.raw_surfaces.len());
    for (i, s) in draw.raw_surfaces.iter().enumerate() {
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
        let patch_size = check_surface_data(s, kind, draw).map_err(err)?;
        surfaces.push(Surface {
            kind,
            shader: s.shader as u32,
            flags: SurfaceFlags::from_shader(shader.surface_flags, shader.content_flags),
            model: None,
            triangles: 0..0,
            patch_size,
        });
    }
    Ok(surfaces)
}

/// Checks what surface `s` of type `kind` takes from the drawverts and drawindexes: polygons
/// and meshes, their ranges and that every index names one of their vertices; patches, their
/// size and vertex range. Returns the patch size (`(0, 0)` for the other types).
fn check_surface_data(
    s: &RawSurface,
    kind: SurfaceKind,
    draw: &DrawData,
) -> Result<(u32, u32), String> {
    let (drawverts, drawindexes) = (draw.drawverts, draw.drawindexes);
    let vertices_outside = || {
        format!(
            "vertices {} + {} outside lump 10 (drawverts, {} records)",
            s.first_vert,
            s.num_verts,
            drawverts.len()
        )
    };
    match kind {
        SurfaceKind::Polygon | SurfaceKind::Mesh => {
            let verts = checked_range(s.first_vert, s.num_verts, drawverts.len())
                .ok_or_else(vertices_outside)?;
            let indexes = checked_range(s.first_index, s.num_indexes, drawindexes.len())
                .ok_or_else(|| {
                    format!(
                        "indexes {} + {} outside lump 11 (drawindexes, {} records)",
                        s.first_index,
                        s.num_indexes,
                        drawindexes.len()
                    )
                })?;
            if s.num_indexes % 3 != 0 {
                return Err(format!("{} indexes, not a multiple of 3", s.num_indexes));
            }
            if let Some(k) = drawindexes[indexes.clone()]
                .iter()
                .position(|&v| usize::try_from(v).map_or(true, |v| v >= verts.len()))
            {
                return Err(format!(
                    "index {} (drawindexes record {}) is outside the surface's {} vertices",
                    drawindexes[indexes.start + k],
                    indexes.start + k,
                    verts.len()
                ));
            }
            Ok((0, 0))
        }
        SurfaceKind::Patch => {
            let (w, h) = (s.patch_width, s.patch_height);
            if w < 3 || h < 3 || w % 2 == 0 || h % 2 == 0 {
                return Err(format!(
                    "patch size {w} x {h}: both must be odd and at least 3"
                ));
            }
            if i64::from(w) * i64::from(h) != i64::from(s.num_verts) {
                return Err(format!(
                    "patch size {w} x {h} does not match its {} vertices",
                    s.num_verts
                ));
            }
            checked_range(s.first_vert, s.num_verts, drawverts.len())
                .ok_or_else(vertices_outside)?;
            Ok((w as u32, h as u32))
        }
        SurfaceKind::Billboard => Ok((0, 0)),
    }
}

/// Reads lump 7: each model's bounds and surface range, recording the model of each of its
/// surfaces (a surface in two models is an error).
fn read_models(
    ctx: &Ctx<'_>,
    lumps: &Lumps<'_>,
    surfaces: &mut [Surface],
) -> Result<Vec<Model>, LoadError> {
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
    Ok(models)
}

/// Reads lump 5: the surface index of each leaf-surface record, checked against the
/// `surface_count` surfaces of lump 13.
fn read_leaf_surfaces(
    ctx: &Ctx<'_>,
    lumps: &Lumps<'_>,
    surface_count: usize,
) -> Result<Vec<u32>, LoadError> {
    lumps
        .records(lumps::LEAFSURFACES)
        .enumerate()
        .map(|(k, r)| {
            let s = i32_at(r, 0);
            usize::try_from(s)
                .ok()
                .filter(|&s| s < surface_count)
                .map(|s| s as u32)
                .ok_or_else(|| {
                    ctx.at(
                        lumps::LEAFSURFACES,
                        k,
                        format!("surface {s} out of range (lump 13 has {surface_count} surfaces)"),
                    )
                })
        })
        .collect()
}

/// Reads lump 4: each leaf's cluster, area, bounds and range of leaf surfaces (checked
/// against the `leaf_surface_count` records of lump 5).
fn read_leaves(
    ctx: &Ctx<'_>,
    lumps: &Lumps<'_>,
    leaf_surface_count: usize,
) -> Result<Vec<Leaf>, LoadError> {
    let mut leaves = Vec::with_capacity(lumps.count(lumps::LEAFS));
    for (l, r) in lumps.records(lumps::LEAFS).enumerate() {
        let (first, count) = (i32_at(r, 32), i32_at(r, 36));
        let range = checked_range(first, count, leaf_surface_count).ok_or_else(|| {
            ctx.at(
                lumps::LEAFS,
                l,
                format!(
                    "leaf surfaces {first} + {count} outside lump 5 (leafsurfaces, \
                     {leaf_surface_count} records)"
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
    Ok(leaves)
}

/// Every leaf's cluster must be below the vis data's cluster count (negative: outside the
/// map, allowed).
fn check_leaf_clusters(ctx: &Ctx<'_>, leaves: &[Leaf], clusters: u32) -> Result<(), LoadError> {
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
    Ok(())
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

#[cfg(test)]
mod tests {
    use super::super::types::UpAxis;
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
