//! The `extras.sightline` members that [`super::write_glb`] writes and the loader reads back
//! (module docs, "Objects"): on a node, the object it belongs to; on the default scene, the
//! up axis the scene had before it was turned Y-up.

use super::super::types::UpAxis;

/// The `extras.sightline` member of a node written by [`super::write_glb`]:
/// `{"object": k, "name": "...", "index": i, "part": p}`. `object` is required (a `u32`);
/// the rest are optional (`null` or missing = `None`; a missing name = the node path).
#[derive(Debug, serde::Deserialize)]
pub(super) struct SightlineTag {
    pub(super) object: u32,
    #[serde(default)]
    pub(super) name: Option<String>,
    #[serde(default)]
    pub(super) index: Option<u32>,
    #[serde(default)]
    pub(super) part: Option<u32>,
}

/// A node's `extras` when they hold a [`SightlineTag`].
#[derive(serde::Deserialize)]
struct NodeExtras {
    sightline: SightlineTag,
}

impl SightlineTag {
    /// The node's tag; `None` when it has none or when its extras do not have the documented
    /// shape (such a node is then an ordinary node, not an error).
    pub(super) fn of(node: &gltf::Node) -> Option<Self> {
        let raw = node.extras().as_ref()?;
        serde_json::from_str::<NodeExtras>(raw.get())
            .ok()
            .map(|e| e.sightline)
    }
}

/// The up axis `write_glb` recorded in the default scene's `extras.sightline.up`, if any.
pub(super) fn written_up_axis(doc: &gltf::Document) -> Option<UpAxis> {
    #[derive(serde::Deserialize)]
    struct Extras {
        sightline: Tag,
    }
    #[derive(serde::Deserialize)]
    struct Tag {
        up: String,
    }
    let scene = doc.default_scene().or_else(|| doc.scenes().next())?;
    let raw = scene.extras().as_ref()?;
    let extras: Extras = serde_json::from_str(raw.get()).ok()?;
    UpAxis::parse(&extras.sightline.up)
}
