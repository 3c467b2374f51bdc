//! The component that ties an entity to an object of a `.pvs`, and the record of what the
//! culling did to its visibility. Kept apart from both systems: [`crate::matching`] writes
//! [`SightlineObject`]s, [`crate::cull`] reads them.

use bevy::camera::visibility::Visibility;
use bevy::ecs::prelude::*;

/// Ties an entity to object `.0` of the `.pvs` its cameras cull with (the index into
/// [`sightline_runtime::Pvs::objects`]). Set it by hand, or let [`crate::SightlineLevel`]
/// fill it from glTF node names.
///
/// Only entities with this component are ever hidden by the plugin. An id past the file's
/// objects never hides its entity.
#[derive(Component, Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[require(Visibility, SightlineCulled)]
pub struct SightlineObject(pub u32);

/// What the plugin did to an entity's [`Visibility`]: added with [`SightlineObject`].
///
/// While `hidden`, the entity's `Visibility` is `Hidden` and `saved` is the value it had
/// before (or the last value anyone else wrote since); it is written back when the object
/// becomes visible again or the entity loses its [`SightlineObject`].
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SightlineCulled {
    /// True while the plugin hides the entity.
    pub hidden: bool,
    /// The entity's own visibility, restored when it is shown again.
    pub saved: Visibility,
}
