//! Tying the entities of a glTF scene to the objects of a `.pvs` by name.
//!
//! # What Bevy's glTF loader spawns (bevy_gltf 0.19.1)
//!
//! For `WorldAssetRoot(gltf_scene)` on an entity `L`, the loader's world is spawned under `L`:
//!
//! ```text
//! L  (WorldAssetRoot, SightlineLevel)
//! └─ scene root       Name = scene name or "Scene{i}"        loader/mod.rs:1029-1039
//!    └─ node          Name = node name or "GltfNode{index}"  loader/mod.rs:1539-1542,
//!       │             GltfExtras = node extras, if any       gltf_ext/scene.rs:15-21,
//!       │                                                    loader/mod.rs:1563-1567
//!       ├─ primitive  Mesh3d (label "Mesh{m}/Primitive{p}"), loader/mod.rs:1657-1673,
//!       │             Name = "{mesh}.{material}"             label.rs:74-75, loader/mod.rs:1733,
//!       │                                                    gltf_ext/mesh.rs:10-18
//!       └─ child node ...  (spawned after the primitives)    loader/mod.rs:1620, 1834
//! ```
//!
//! (Paths are in `~/.cargo/registry/src/*/bevy_gltf-0.19.1/src/`.)
//!
//! # The matching rule
//!
//! A sightline object of a glTF file is one (node, primitive) pair named by its **node path**:
//! the names of the node's ancestors from the scene's root nodes down to the node, joined by
//! `/`, an unnamed node written `#<node index>` (e.g. `Root/House/Door.001`), with
//! `index` = node index and `part` = primitive index.
//!
//! An entity with a [`Mesh3d`] below an entity with [`SightlineLevel`] is matched like this:
//!
//! 0. With the `gltf` feature: when its parent (the node entity) has `GltfExtras` with the tag
//!    that `sightline convert` / `write_glb` writes on every node,
//!    `{"sightline": {"object": k, "name": …, "index": …, "part": …}}`, and object `k` of the
//!    file has that name, index and part, it is object `k`. (Files written by sightline put
//!    one primitive per node, so this is what tells apart the objects of a multi-primitive
//!    mesh once converted.) Otherwise:
//! 1. Its node path is the [`Name`]s of its ancestors, from the one [`SightlineLevel::skip`]
//!    levels below the level entity (1 for a glTF scene: the scene-root entity is skipped)
//!    down to its parent (the node entity), joined by `/`. The entity's own name (mesh and
//!    material) is not part of it. An ancestor without a `Name` makes the path unknown.
//! 2. Its primitive index `p` is read from its mesh handle's label `Mesh{m}/Primitive{p}`
//!    (unknown for a mesh not loaded from a glTF file).
//! 3. The candidates are the objects whose name equals the path; in an object name a segment
//!    `#N` also matches Bevy's name for an unnamed node, `GltfNode{N}`.
//! 4. Among the candidates, the one whose `part` equals `p` wins; failing that, a single
//!    candidate with no `part` (or a single candidate when `p` is unknown) wins. Anything
//!    else (no candidate, several equally good ones, e.g. sibling nodes sharing a name) is
//!    **no match**.
//!
//! A matched entity gets [`SightlineObject`] and [`AutoMatched`]; an unmatched one gets
//! [`SightlineUnmatched`] and is never culled: **entities that match nothing stay drawn**.
//! Mesh entities below no level get [`SightlineUnmatched`] too (so they are looked at once).
//! Entities that already have a [`SightlineObject`] (set by hand) are left alone. When a
//! `.pvs` is (re)loaded or a [`SightlineLevel`] is added or changed, every automatic
//! assignment is dropped and redone the next frame (which draws everything meanwhile).

use std::collections::HashMap;

use bevy::asset::{AssetEvent, AssetId, Assets, Handle};
use bevy::ecs::name::Name;
use bevy::ecs::prelude::*;
use bevy::mesh::Mesh3d;

use crate::asset::PvsAsset;
use crate::object::SightlineObject;

/// Put on the entity that holds a glTF scene (`WorldAssetRoot`) to tie the mesh entities
/// below it to the objects of a `.pvs` automatically (see the [module](self) documentation).
#[derive(Component, Clone, Debug)]
pub struct SightlineLevel {
    /// The level's baked `.pvs`.
    pub pvs: Handle<PvsAsset>,
    /// How many levels of ancestors right below this entity are not part of node paths: 1
    /// for a glTF scene spawned with `WorldAssetRoot` on this entity (the scene-root entity
    /// that Bevy's loader puts above the glTF root nodes), 0 when the root nodes are children
    /// of this entity.
    pub skip: u8,
}

impl SightlineLevel {
    /// For a glTF scene spawned with `WorldAssetRoot` on the same entity (`skip` = 1).
    pub fn gltf(pvs: Handle<PvsAsset>) -> Self {
        Self { pvs, skip: 1 }
    }
}

/// Marks a [`SightlineObject`] that was assigned by name matching (and is redone when the
/// level's `.pvs` changes); hand-set ones do not have it.
#[derive(Component, Clone, Copy, Debug, Default)]
pub struct AutoMatched;

/// Marks a mesh entity below a [`SightlineLevel`] that matched no object: it is never culled.
#[derive(Component, Clone, Copy, Debug, Default)]
pub struct SightlineUnmatched;

/// The primitive index of a glTF mesh handle (`…#Mesh{m}/Primitive{p}`), if it has one.
pub fn primitive_index(mesh: &Mesh3d) -> Option<u32> {
    let label = mesh.0.path()?.label()?;
    let (_, primitive) = label.split_once("/Primitive")?;
    primitive.parse().ok()
}

/// The objects of a `.pvs` by node path, for [the matching rule](self).
#[derive(Debug, Default)]
pub struct ObjectMatcher {
    by_path: HashMap<String, Vec<(Option<u32>, u32)>>,
}

impl ObjectMatcher {
    /// Indexes the objects of `pvs`.
    pub fn new(pvs: &sightline_runtime::Pvs) -> Self {
        let mut by_path: HashMap<String, Vec<(Option<u32>, u32)>> = HashMap::new();
        for (id, object) in pvs.objects().enumerate() {
            let id = id as u32;
            by_path
                .entry(object.name.to_owned())
                .or_default()
                .push((object.part, id));
            let bevy_name = bevy_node_names(object.name);
            if bevy_name != object.name {
                by_path
                    .entry(bevy_name)
                    .or_default()
                    .push((object.part, id));
            }
        }
        Self { by_path }
    }

    /// The object of the entity with node path `path` and primitive index `primitive`.
    pub fn find(&self, path: &str, primitive: Option<u32>) -> Option<u32> {
        let candidates = self.by_path.get(path)?;
        let single = |mut it: Box<dyn Iterator<Item = u32> + '_>| {
            let first = it.next()?;
            it.all(|o| o == first).then_some(first)
        };
        if let Some(p) = primitive {
            let exact = candidates
                .iter()
                .filter(|(part, _)| *part == Some(p))
                .map(|&(_, o)| o);
            if let Some(o) = single(Box::new(exact.clone())) {
                return Some(o);
            }
            if exact.count() > 0 {
                return None;
            }
            let no_part = candidates
                .iter()
                .filter(|(part, _)| part.is_none())
                .map(|&(_, o)| o);
            return single(Box::new(no_part));
        }
        single(Box::new(candidates.iter().map(|&(_, o)| o)))
    }
}

/// `a/#3/b` → `a/GltfNode3/b`: an object name with Bevy's names for unnamed nodes.
fn bevy_node_names(name: &str) -> String {
    name.split('/')
        .map(|segment| match segment.strip_prefix('#') {
            Some(n) if !n.is_empty() && n.bytes().all(|b| b.is_ascii_digit()) => {
                format!("GltfNode{n}")
            }
            _ => segment.to_owned(),
        })
        .collect::<Vec<_>>()
        .join("/")
}

/// Object `k` of a node's `extras` tag `{"sightline": {"object": k, "name", "index", "part"}}`
/// (written by `sightline_core::scene::gltf::write_glb`), if `pvs` has that object with that
/// name, index and part (missing `name`, `index`, `part` are not compared).
#[cfg(feature = "gltf")]
pub fn tagged_object(extras: &str, pvs: &sightline_runtime::Pvs) -> Option<u32> {
    let value: serde_json::Value = serde_json::from_str(extras).ok()?;
    let tag = value.get("sightline")?;
    let k = u32::try_from(tag.get("object")?.as_u64()?).ok()?;
    let object = pvs.object(k).ok()?;
    let number = |key: &str, has: Option<u32>| match tag.get(key) {
        None => true,
        Some(serde_json::Value::Null) => has.is_none(),
        Some(v) => v.as_u64().is_some_and(|v| Some(v) == has.map(u64::from)),
    };
    let name = match tag.get("name") {
        None => true,
        Some(n) => n.as_str() == Some(object.name),
    };
    (name && number("index", object.index) && number("part", object.part)).then_some(k)
}

/// The deepest hierarchy walked up from a mesh entity looking for its level.
const MAX_DEPTH: usize = 1024;

/// Where a mesh entity stands: below which level, with which node path.
enum Placement {
    /// Below `level` with this node path (`None`: an ancestor has no name).
    Level(Entity, Option<String>),
    /// Below no level.
    None,
}

fn placement(
    entity: Entity,
    hierarchy: &Query<(Option<&ChildOf>, Option<&Name>)>,
    levels: &Query<&SightlineLevel>,
) -> Placement {
    let mut names: Vec<Option<&str>> = Vec::new();
    let mut current = entity;
    for _ in 0..MAX_DEPTH {
        let Ok((Some(child_of), _)) = hierarchy.get(current) else {
            return Placement::None;
        };
        let parent = child_of.parent();
        if let Ok(level) = levels.get(parent) {
            // `names` runs from the mesh's parent up to the level's child.
            let keep = names.len().saturating_sub(level.skip as usize);
            let path = names[..keep]
                .iter()
                .rev()
                .copied()
                .collect::<Option<Vec<&str>>>()
                .filter(|p| !p.is_empty())
                .map(|p| p.join("/"));
            return Placement::Level(parent, path);
        }
        let Ok((_, name)) = hierarchy.get(parent) else {
            return Placement::None;
        };
        names.push(name.map(|n| n.as_str()));
        current = parent;
    }
    Placement::None
}

/// Object matchers per `.pvs`, rebuilt when a file (re)loads.
#[derive(Resource, Default)]
pub(crate) struct Matchers(HashMap<AssetId<PvsAsset>, ObjectMatcher>);

/// Gives [`SightlineObject`]s to the mesh entities of levels (see the [module](self) docs).
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
pub(crate) fn assign_objects(
    mut commands: Commands,
    mut matchers: ResMut<Matchers>,
    mut events: MessageReader<AssetEvent<PvsAsset>>,
    assets: Res<Assets<PvsAsset>>,
    levels: Query<&SightlineLevel>,
    changed_levels: Query<(), Changed<SightlineLevel>>,
    candidates: Query<(Entity, &Mesh3d), (Without<SightlineObject>, Without<SightlineUnmatched>)>,
    assigned: Query<Entity, Or<(With<AutoMatched>, With<SightlineUnmatched>)>>,
    hierarchy: Query<(Option<&ChildOf>, Option<&Name>)>,
    #[cfg(feature = "gltf")] extras: Query<&bevy::gltf::GltfExtras>,
) {
    let mut redo = !changed_levels.is_empty();
    for event in events.read() {
        match event {
            AssetEvent::Added { id } | AssetEvent::Modified { id } | AssetEvent::Removed { id } => {
                matchers.0.remove(id);
                redo = true;
            }
            _ => {}
        }
    }
    if redo {
        // Rare (a level spawned or changed, a file reloaded): forget every automatic
        // decision; the next frame redoes them against the current files.
        for entity in &assigned {
            commands
                .entity(entity)
                .remove::<(SightlineObject, AutoMatched, SightlineUnmatched)>();
        }
        return;
    }
    for (entity, mesh) in &candidates {
        match placement(entity, &hierarchy, &levels) {
            Placement::None => {
                commands.entity(entity).insert(SightlineUnmatched);
            }
            Placement::Level(level, path) => {
                let Ok(level) = levels.get(level) else {
                    continue;
                };
                let Some(pvs) = assets.get(&level.pvs) else {
                    // Not loaded yet (or failed): decide later.
                    continue;
                };
                let matcher = matchers
                    .0
                    .entry(level.pvs.id())
                    .or_insert_with(|| ObjectMatcher::new(pvs.pvs()));
                #[cfg(feature = "gltf")]
                let tagged = hierarchy
                    .get(entity)
                    .ok()
                    .and_then(|(child_of, _)| extras.get(child_of?.parent()).ok())
                    .and_then(|e| tagged_object(&e.value, pvs.pvs()));
                #[cfg(not(feature = "gltf"))]
                let tagged = None;
                let object =
                    tagged.or_else(|| path.and_then(|p| matcher.find(&p, primitive_index(mesh))));
                match object {
                    Some(o) => commands
                        .entity(entity)
                        .insert((SightlineObject(o), AutoMatched)),
                    None => commands.entity(entity).insert(SightlineUnmatched),
                };
            }
        }
    }
}
