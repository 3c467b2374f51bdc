//! The scene walk (glTF 2.0 section 3.5 scenes and nodes): from the root nodes down,
//! depth-first in node order, each node's transform composed with its parents', each triangle
//! primitive of its mesh appended in world space as an object (module docs, "Scene walk" and
//! "Objects").

use std::borrow::Cow;
use std::collections::HashMap;
use std::path::Path;
use std::rc::Rc;

use glam::Mat4;
use gltf::mesh::{Mode, Semantic};

use super::super::builder::SceneBuilder;
use super::super::error::{LoadError, Location};
use super::super::limits::check_geometry;
use super::super::options::LoadOptions;
use super::super::types::{Object, Scene};
use super::buffers::is_triangle_mode;
use super::extras::{written_up_axis, SightlineTag};
use super::primitive::read_primitive;

/// Builds the scene of a parsed document whose geometry buffers are loaded (`buffers`, by
/// buffer index).
pub(super) fn build_scene(
    path: &Path,
    doc: &gltf::Document,
    buffers: &[Cow<'_, [u8]>],
    options: &LoadOptions,
) -> Result<Scene, LoadError> {
    let roots = root_nodes(doc);
    let mut walk = Walk {
        path,
        buffers,
        options,
        builder: SceneBuilder::new(path.display().to_string()),
        visited: vec![false; doc.nodes().len()],
        triangles: Vec::new(),
        tagged: HashMap::new(),
        not_triangles: 0,
        no_positions: 0,
    };
    // Depth-first with an explicit stack (no recursion depth limit to hit); children are
    // pushed in reverse so they pop in node order. Each entry carries its parent's world
    // transform and node path.
    let mut stack: Vec<(gltf::Node, Mat4, Rc<str>)> = roots
        .into_iter()
        .rev()
        .map(|n| (n, Mat4::IDENTITY, Rc::from("")))
        .collect();
    while let Some((node, world_from_parent, parent_path)) = stack.pop() {
        let (world_from_node, node_path) = walk.visit(&node, world_from_parent, &parent_path)?;
        let children: Vec<_> = node.children().collect();
        for child in children.into_iter().rev() {
            stack.push((child, world_from_node, node_path.clone()));
        }
    }
    Ok(walk.finish(doc))
}

/// The nodes the walk starts from: those of the default scene, else of scene 0, else every
/// root node (a node that is no node's child) in node order.
fn root_nodes(doc: &gltf::Document) -> Vec<gltf::Node<'_>> {
    match doc.default_scene().or_else(|| doc.scenes().next()) {
        Some(scene) => scene.nodes().collect(),
        None => {
            let mut is_child = vec![false; doc.nodes().len()];
            for node in doc.nodes() {
                for child in node.children() {
                    if let Some(flag) = is_child.get_mut(child.index()) {
                        *flag = true;
                    }
                }
            }
            doc.nodes().filter(|n| !is_child[n.index()]).collect()
        }
    }
}

/// The node's path: its parent's path and its own name (`#<index>` when it has none), joined
/// with `/` (module docs, "Objects").
fn node_path(parent_path: &str, node: &gltf::Node) -> Rc<str> {
    let segment = match node.name() {
        Some(name) if !name.is_empty() => name.to_string(),
        _ => format!("#{}", node.index()),
    };
    if parent_path.is_empty() {
        segment.into()
    } else {
        format!("{parent_path}/{segment}").into()
    }
}

/// The node's local transform (`parent_from_node`), with its rotation normalised (module docs).
fn node_matrix(node: &gltf::Node) -> Result<Mat4, String> {
    let finite = |v: &[f32]| v.iter().all(|x| x.is_finite());
    match node.transform() {
        gltf::scene::Transform::Matrix { matrix } => {
            if !matrix.iter().all(|c| finite(c)) {
                return Err("matrix has a NaN or infinite value".into());
            }
            Ok(Mat4::from_cols_array_2d(&matrix))
        }
        gltf::scene::Transform::Decomposed {
            translation,
            rotation,
            scale,
        } => {
            if !(finite(&translation) && finite(&rotation) && finite(&scale)) {
                return Err("translation, rotation or scale has a NaN or infinite value".into());
            }
            let q = glam::Quat::from_array(rotation);
            let length_squared = q.length_squared();
            if length_squared == 0.0 || !length_squared.is_finite() {
                return Err(format!(
                    "rotation {rotation:?} is not a rotation (zero length)"
                ));
            }
            // Unit within exporters' rounding: as written, so valid files keep their bits.
            let rotation = if (length_squared - 1.0).abs() <= 1e-5 {
                rotation
            } else {
                q.normalize().to_array()
            };
            let transform = gltf::scene::Transform::Decomposed {
                translation,
                rotation,
                scale,
            };
            Ok(Mat4::from_cols_array_2d(&transform.matrix()))
        }
    }
}

/// Where the primitives of one node's mesh go: the node, its world transform, its path and
/// its `write_glb` tag.
struct Placement<'p> {
    node_index: usize,
    world_from_node: Mat4,
    node_path: &'p str,
    tag: Option<SightlineTag>,
}

/// The walk's state: the scene being built and what the walk has met so far.
struct Walk<'a> {
    path: &'a Path,
    buffers: &'a [Cow<'a, [u8]>],
    options: &'a LoadOptions,
    builder: SceneBuilder,
    /// Nodes reached so far, by node index.
    visited: Vec<bool>,
    /// The triangles of the primitive being added (a buffer reused across primitives).
    triangles: Vec<[u32; 3]>,
    /// Objects written by `write_glb`: object id of each `sightline.object` number.
    tagged: HashMap<u32, u32>,
    /// Primitives skipped: not triangles, or without positions.
    not_triangles: usize,
    no_positions: usize,
}

impl Walk<'_> {
    /// Visits one node: marks it reached, composes its world transform and path, and appends
    /// its mesh's primitives. Returns the transform and path its children inherit.
    fn visit(
        &mut self,
        node: &gltf::Node,
        world_from_parent: Mat4,
        parent_path: &str,
    ) -> Result<(Mat4, Rc<str>), LoadError> {
        self.mark_reached(node)?;
        let parent_from_node = node_matrix(node).map_err(|message| {
            LoadError::parse(
                self.path,
                Location::Element(format!("node {}", node.index())),
                message,
            )
        })?;
        let world_from_node = world_from_parent * parent_from_node;
        let node_path = node_path(parent_path, node);
        if let Some(mesh) = node.mesh() {
            let place = Placement {
                node_index: node.index(),
                world_from_node,
                node_path: &node_path,
                tag: SightlineTag::of(node),
            };
            for primitive in mesh.primitives() {
                self.add_primitive(&mesh, &primitive, &place)?;
            }
        }
        Ok((world_from_node, node_path))
    }

    /// Marks `node` reached. A node reached twice is an error (the node graph must be a
    /// forest), so cycles cannot recurse.
    fn mark_reached(&mut self, node: &gltf::Node) -> Result<(), LoadError> {
        let path = self.path;
        let seen = self
            .visited
            .get_mut(node.index())
            .ok_or_else(|| LoadError::Invalid {
                path: path.to_path_buf(),
                message: format!("node {} does not exist", node.index()),
            })?;
        if *seen {
            return Err(LoadError::parse(
                path,
                Location::Element(format!("node {}", node.index())),
                "node is reached twice: the node hierarchy is not a tree",
            ));
        }
        *seen = true;
        Ok(())
    }

    /// Appends one primitive of the node's mesh in world space, to its own object or to the
    /// object of the node's tag. Points, lines and primitives without positions are counted
    /// and skipped; errors name the mesh and primitive.
    fn add_primitive(
        &mut self,
        mesh: &gltf::Mesh,
        primitive: &gltf::Primitive,
        place: &Placement,
    ) -> Result<(), LoadError> {
        let path = self.path;
        let location = || {
            Location::Element(format!(
                "mesh {}, primitive {}",
                mesh.index(),
                primitive.index()
            ))
        };
        let err = |message: String| LoadError::parse(path, location(), message);
        if !is_triangle_mode(primitive.mode()) {
            self.not_triangles += 1;
            return Ok(());
        }
        // A primitive without positions has nothing to draw (spec 3.7.2.1).
        let Some(position_accessor) = primitive.get(&Semantic::Positions) else {
            self.no_positions += 1;
            return Ok(());
        };
        self.check_room(primitive, &position_accessor, location())?;
        let positions = read_primitive(
            primitive,
            &position_accessor,
            self.buffers,
            &mut self.triangles,
        )
        .map_err(err)?;
        self.begin_object(place, primitive.index());
        let base = self.builder.vertex_count();
        for p in positions {
            self.builder
                .add_vertex(place.world_from_node.transform_point3(p));
        }
        for t in &self.triangles {
            self.builder.add_triangle(t.map(|i| base + i));
        }
        Ok(())
    }

    /// Before reading a primitive: the scene it would make (the accessors' counts are checked
    /// against their views when read) must fit [`LoadOptions::max_scene_bytes`], and its
    /// vertices must be addressable by `u32` indices.
    fn check_room(
        &self,
        primitive: &gltf::Primitive,
        position_accessor: &gltf::Accessor,
        location: Location,
    ) -> Result<(), LoadError> {
        let vertices = position_accessor.count() as u64;
        let corners = primitive.indices().map_or(vertices, |a| a.count() as u64);
        let new_triangles = match primitive.mode() {
            Mode::Triangles => corners / 3,
            _ => corners.saturating_sub(2),
        };
        let total_vertices = u64::from(self.builder.vertex_count()) + vertices;
        check_geometry(
            self.path,
            location.clone(),
            total_vertices,
            self.builder.triangle_count() as u64 + new_triangles,
            self.options,
        )?;
        if total_vertices > u64::from(u32::MAX) {
            return Err(LoadError::parse(
                self.path,
                location,
                format!("the scene would have {total_vertices} vertices, more than 2^32 - 1"),
            ));
        }
        Ok(())
    }

    /// Makes the object of primitive `part` of the placed node the current one: one object
    /// per (node, primitive); nodes tagged by `write_glb` join the object of their tag
    /// instead (module docs, "Objects").
    fn begin_object(&mut self, place: &Placement, part: usize) {
        match &place.tag {
            Some(tag) => match self.tagged.get(&tag.object) {
                Some(&id) => self.builder.resume_object(id),
                None => {
                    let id = self.builder.push_object(Object {
                        name: tag
                            .name
                            .clone()
                            .unwrap_or_else(|| place.node_path.to_string()),
                        index: tag.index,
                        part: tag.part,
                    });
                    self.tagged.insert(tag.object, id);
                }
            },
            None => {
                self.builder.push_object(Object {
                    name: place.node_path.to_string(),
                    index: Some(place.node_index as u32),
                    part: Some(part as u32),
                });
            }
        }
    }

    /// The finished scene: warnings for what was skipped, tagged objects in the order they
    /// were written, and a scene `write_glb` turned Y-up turned back to its own up axis.
    fn finish(mut self, doc: &gltf::Document) -> Scene {
        let builder = &mut self.builder;
        if self.not_triangles > 0 {
            builder.warn(format!(
                "{} primitive(s) of points or lines skipped (no triangles)",
                self.not_triangles
            ));
        }
        if self.no_positions > 0 {
            builder.warn(format!(
                "{} triangle primitive(s) without POSITION skipped",
                self.no_positions
            ));
        }
        if builder.triangle_count() == 0 {
            builder.warn("the scene's nodes have no triangle primitives");
        }
        if !self.tagged.is_empty() {
            // Tagged objects take their `sightline.object` order (the ids they had when
            // written), untagged ones follow in walk order.
            let mut keys = vec![(1u8, u32::MAX); builder.objects().len()];
            for (&object, &id) in &self.tagged {
                keys[id as usize] = (0, object);
            }
            builder.sort_objects_by_key(&keys);
        }
        let mut scene = self.builder.finish();
        // A file `write_glb` wrote from a scene that was not Y-up holds that scene turned Y-up
        // (as glTF requires) and names the original axis: turn it back, exactly, so the loaded
        // scene has the original coordinates and ids (and so the `.pvs` files baked from it).
        if let Some(up) = written_up_axis(doc) {
            for p in &mut scene.positions {
                *p = up.from_y_up(*p);
            }
            scene.up = up;
        }
        scene
    }
}
