//! # bevy_sightline
//!
//! Baked potentially-visible-set culling for [Bevy](https://bevy.org) with
//! [sightline](https://example.invalid/sightline) `.pvs` files: the camera's view cell says
//! which objects of the level can be seen from there, and the others are not drawn.
//!
//! ```no_run
//! use bevy::prelude::*;
//! use bevy_sightline::{PvsAsset, SightlineCamera, SightlineLevel, SightlinePlugin};
//!
//! fn setup(mut commands: Commands, assets: Res<AssetServer>) {
//!     let pvs: Handle<PvsAsset> = assets.load("level.pvs");
//!     // The level, with its mesh entities matched to the file's objects by glTF node path.
//!     commands.spawn((
//!         WorldAssetRoot(assets.load(GltfAssetLabel::Scene(0).from_asset("level.glb"))),
//!         SightlineLevel::gltf(pvs.clone()),
//!     ));
//!     commands.spawn((Camera3d::default(), SightlineCamera::new(pvs)));
//! }
//!
//! App::new()
//!     .add_plugins((DefaultPlugins, SightlinePlugin))
//!     .add_systems(Startup, setup)
//!     .run();
//! ```
//!
//! # Pieces
//!
//! - [`PvsAsset`], loaded by [`PvsLoader`] from files with the extension `pvs`: a checked
//!   [`sightline_runtime::Pvs`]. A damaged file fails to load (never a panic).
//! - [`SightlineObject`]`(id)` ties an entity to object `id` of the file. Set it by hand, or
//!   put [`SightlineLevel`] on the entity holding a glTF scene to have it filled for every mesh
//!   entity below by glTF node path and primitive index ([`matching`] has the exact rule).
//!   Mesh entities that match nothing get [`SightlineUnmatched`] and stay drawn.
//! - [`SightlineCamera`] on a camera names the file it culls with.
//! - [`SightlineStats`]: drawn/total entity counts, visible/total objects and the cameras'
//!   cells, for UIs and tests.
//!
//! # The culling policy
//!
//! Each frame in `PostUpdate` (after transform propagation, before Bevy's visibility
//! propagation, so the frame being rendered already uses it):
//!
//! 1. Every taking-part camera (a [`SightlineCamera`] with `enabled`, and an active
//!    [`Camera`](bevy::camera::Camera) if it has one) finds its cell:
//!    [`cell_at`](sightline_runtime::Pvs::cell_at) of its world position.
//! 2. **Several cameras:** Bevy's `Visibility` is one per entity, not per view, so an object is
//!    drawn when it is visible from *any* camera's cell (the union of their sets). If one
//!    camera is **outside every cell** (or its file is not loaded yet, or has no object sets,
//!    e.g. a version-1 file), everything is drawn. With no taking-part camera nothing is
//!    hidden. All cameras are expected to use the same `.pvs`: object ids are the file's.
//! 3. Only entities with a [`SightlineObject`] are touched. One whose object is not in the set
//!    gets `Visibility::Hidden`, and the value it had is kept in [`SightlineCulled::saved`];
//!    when the object is visible again (or the entity loses its `SightlineObject`), that value
//!    is written back. A value written by anyone else while the plugin hides the entity
//!    becomes the saved value (the entity stays hidden until it is in view again): drawn =
//!    your visibility **and** in the set. To hide a culled entity for good, hide it or an
//!    ancestor as usual; glTF mesh entities are leaves, so hiding a node entity (an ancestor)
//!    never conflicts with the culling at all.
//! 4. The union is recomputed only when a camera changes cell or a file changes; otherwise
//!    the pass over the objects writes nothing (no change detection is triggered).

pub mod asset;
pub mod cull;
pub mod matching;
mod object;

use bevy::app::{App, Plugin, PostUpdate};
use bevy::asset::AssetApp;
use bevy::camera::visibility::VisibilitySystems;
use bevy::ecs::schedule::{IntoScheduleConfigs, SystemSet};
use bevy::transform::TransformSystems;

pub use asset::{PvsAsset, PvsLoadError, PvsLoader};
pub use cull::{SightlineCamera, SightlineCulled, SightlineObject, SightlineStats};
#[cfg(feature = "gltf")]
pub use matching::tagged_object;
pub use matching::{
    primitive_index, AutoMatched, ObjectMatcher, SightlineLevel, SightlineUnmatched,
};
pub use sightline_runtime;

/// The plugin's systems, in `PostUpdate`, after `TransformSystems::Propagate` and before
/// `VisibilitySystems::VisibilityPropagate`.
#[derive(SystemSet, Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SightlineSystems {
    /// Gives [`SightlineObject`]s to the mesh entities of [`SightlineLevel`]s.
    Match,
    /// Hides and shows the entities of objects.
    Cull,
}

/// Registers the `.pvs` asset and loader, the name matching and the culling. Needs Bevy's
/// `AssetPlugin`; the transforms must be propagated (`TransformPlugin`, part of
/// `DefaultPlugins`) for the cameras' positions.
#[derive(Default)]
pub struct SightlinePlugin;

impl Plugin for SightlinePlugin {
    fn build(&self, app: &mut App) {
        app.init_asset::<PvsAsset>()
            .register_asset_loader(PvsLoader)
            .init_resource::<SightlineStats>()
            .init_resource::<cull::CullState>()
            .init_resource::<matching::Matchers>()
            .configure_sets(
                PostUpdate,
                (SightlineSystems::Match, SightlineSystems::Cull)
                    .chain()
                    .after(TransformSystems::Propagate)
                    .before(VisibilitySystems::VisibilityPropagate),
            )
            .add_systems(
                PostUpdate,
                (
                    matching::assign_objects.in_set(SightlineSystems::Match),
                    cull::cull.in_set(SightlineSystems::Cull),
                ),
            );
    }
}
