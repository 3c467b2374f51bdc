//! Per-frame culling: the cameras' cells, the union of their object sets, and the
//! [`Visibility`] of the entities tied to objects.

use bevy::asset::{AssetEvent, AssetId, Assets, Handle};
use bevy::camera::visibility::Visibility;
use bevy::camera::Camera;
use bevy::ecs::prelude::*;
use bevy::transform::components::GlobalTransform;

use crate::asset::PvsAsset;
use crate::matching::{SightlineLevel, SightlineUnmatched};
pub use crate::object::{SightlineCulled, SightlineObject};

/// Put on a camera (any entity with a [`GlobalTransform`]) to cull with a `.pvs`: the
/// camera's cell is the file's cell that holds its position, in the space of the
/// [`crate::SightlineLevel`] entity using the same file if there is one (so a level may be
/// moved), else in world space.
///
/// Entities without [`Camera`] count as cameras too (a headless app or a tool); a [`Camera`]
/// with `is_active == false` does not take part.
#[derive(Component, Clone, Debug)]
pub struct SightlineCamera {
    /// The baked file.
    pub pvs: Handle<PvsAsset>,
    /// When false the camera does not take part (as if it did not have the component).
    pub enabled: bool,
    /// Cull with the cells' conservative bounds (files baked with `pvs bake --bound`)
    /// instead of their sampled sets: a few more objects are drawn, and none that can be
    /// seen is ever missing. A file without bounds then draws everything (and says so in
    /// [`SightlineStats::last_error`]).
    pub use_bound: bool,
}

impl SightlineCamera {
    /// A camera culling with `pvs`'s sampled sets.
    pub fn new(pvs: Handle<PvsAsset>) -> Self {
        Self {
            pvs,
            enabled: true,
            use_bound: false,
        }
    }

    /// This camera culling with the conservative bounds instead ([`Self::use_bound`]).
    pub fn with_bound(self) -> Self {
        Self {
            use_bound: true,
            ..self
        }
    }
}

/// What the culling does this frame, for UIs and tests. Updated in `PostUpdate`
/// ([`crate::SightlineSystems::Cull`]).
#[derive(Resource, Clone, Debug, Default, PartialEq)]
pub struct SightlineStats {
    /// Entities with a [`SightlineObject`] the plugin does not hide (their own visibility
    /// may still hide them).
    pub drawn: u32,
    /// Entities with a [`SightlineObject`].
    pub total: u32,
    /// Mesh entities below a level that matched no object (never culled).
    pub unmatched: u32,
    /// Objects in the union of the cameras' sets (the file's object count when drawing
    /// everything).
    pub visible_objects: u32,
    /// Objects of the file the cameras use (the largest, when they use several).
    pub object_count: u32,
    /// Each taking-part camera and its cell (`None`: outside every cell, or its `.pvs` is not
    /// loaded or has no objects).
    pub cameras: Vec<(Entity, Option<u32>)>,
    /// True when nothing is culled: no camera takes part, or one is outside every cell (or
    /// its file is not loaded, or has no object sets).
    pub draw_all: bool,
    /// The last problem met (a version-1 file without object sets, a corrupt set), if any.
    pub last_error: Option<String>,
}

/// The union of the sets of the current cells, kept between frames.
#[derive(Resource, Default)]
pub(crate) struct CullState {
    /// Per camera: (camera, file, cell) of the last frame.
    key: Vec<CameraKey>,
    /// One bit per object: visible from some camera's cell.
    bits: Vec<u64>,
    /// Objects the bitset covers.
    len: u32,
    draw_all: bool,
    visible_objects: u32,
    object_count: u32,
    scratch: Vec<u32>,
    /// Files already warned about.
    warned: Vec<AssetId<PvsAsset>>,
}

impl CullState {
    fn visible(&self, object: u32) -> bool {
        if self.draw_all || object >= self.len {
            return true;
        }
        self.bits[(object / 64) as usize] >> (object % 64) & 1 == 1
    }
}

/// A taking-part camera, its file and its cell (`None`: outside every cell, or the file is
/// not loaded).
/// A taking-part camera: its entity, file, cell and whether it uses the bounds.
type CameraKey = (Entity, AssetId<PvsAsset>, Option<u32>, bool);

/// The culling system: see the crate documentation for the policy. One frame in four steps:
/// the cameras' cells ([`camera_cells`]), the union of their sets when it may have changed
/// ([`CullState::rebuild`]), visibility given back to entities that stopped being objects
/// ([`restore_released`]), then hiding and showing ([`apply_visibility`]) and the stats.
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
pub(crate) fn cull(
    mut state: ResMut<CullState>,
    mut stats: ResMut<SightlineStats>,
    mut events: MessageReader<AssetEvent<PvsAsset>>,
    assets: Res<Assets<PvsAsset>>,
    cameras: Query<(Entity, &SightlineCamera, &GlobalTransform, Option<&Camera>)>,
    levels: Query<(&SightlineLevel, &GlobalTransform)>,
    mut objects: Query<(Ref<SightlineObject>, &mut Visibility, &mut SightlineCulled)>,
    mut released: Query<(&mut Visibility, &mut SightlineCulled), Without<SightlineObject>>,
    mut removed: RemovedComponents<SightlineObject>,
    unmatched: Query<(), With<SightlineUnmatched>>,
) {
    // (Every event is read, so none is seen again next frame.)
    let files_changed = events.read().fold(false, |changed, e| {
        changed
            | matches!(
                e,
                AssetEvent::Added { .. } | AssetEvent::Modified { .. } | AssetEvent::Removed { .. }
            )
    });

    // 1. Where the cameras are.
    let key = camera_cells(&cameras, &levels, &assets);

    // 2. The union of their sets, only when a camera changed cell or a file changed.
    let sets_changed = files_changed || key != state.key;
    if sets_changed {
        state.rebuild(key, &assets, &mut stats);
    }

    // 3. Entities that stopped being objects get their visibility back.
    restore_released(&mut removed, &mut released);

    // 4. Hide and show. Only flips write, so Bevy's visibility propagation sees changes only.
    let (drawn, total) = apply_visibility(&mut objects, &state, sets_changed);

    stats.record(&state, drawn, total, unmatched.iter().count() as u32);
}

/// Step 1 of [`cull`]: every taking-part camera (enabled, and active if it is a Bevy
/// [`Camera`]) with its file and cell, sorted by entity so that the key compares equal from
/// frame to frame when nothing moved between cells.
fn camera_cells(
    cameras: &Query<(Entity, &SightlineCamera, &GlobalTransform, Option<&Camera>)>,
    levels: &Query<(&SightlineLevel, &GlobalTransform)>,
    assets: &Assets<PvsAsset>,
) -> Vec<CameraKey> {
    let mut key = Vec::with_capacity(cameras.iter().len());
    for (entity, camera, transform, bevy_camera) in cameras {
        if !camera.enabled || bevy_camera.is_some_and(|c| !c.is_active) {
            continue;
        }
        // In the space of the level baked into this file, if one is spawned (the cells are in
        // the coordinates of the baked scene), else in world space.
        let mut position = transform.translation();
        if let Some((_, level)) = levels.iter().find(|(l, _)| l.pvs.id() == camera.pvs.id()) {
            position = level.affine().inverse().transform_point3(position);
        }
        let cell = assets
            .get(&camera.pvs)
            .and_then(|pvs| pvs.cell_at(position.to_array()));
        key.push((entity, camera.pvs.id(), cell, camera.use_bound));
    }
    key.sort_unstable_by_key(|&(e, _, _, _)| e);
    key
}

impl CullState {
    /// Step 2 of [`cull`]: takes `key` as the current cameras and recomputes the union of
    /// their cells' object sets from `assets`. A camera outside every cell, or whose file is
    /// not loaded or has a corrupt set, makes everything drawn; a corrupt set is also reported
    /// in `stats.last_error` (and logged once per file).
    fn rebuild(
        &mut self,
        key: Vec<CameraKey>,
        assets: &Assets<PvsAsset>,
        stats: &mut SightlineStats,
    ) {
        self.key = key;
        self.draw_all = self.key.is_empty();
        self.object_count = 0;
        let mut len = 0;
        for &(_, id, _, _) in &self.key {
            if let Some(pvs) = assets.get(id) {
                len = len.max(pvs.object_count());
            }
        }
        self.len = len;
        self.object_count = len;
        self.bits.clear();
        self.bits.resize(len.div_ceil(64) as usize, 0);
        for &(_, id, cell, use_bound) in &self.key {
            let (Some(pvs), Some(cell)) = (assets.get(id), cell) else {
                // Outside every cell, or the file is not loaded: this camera sees everything.
                self.draw_all = true;
                continue;
            };
            let set = if use_bound {
                pvs.bound_objects_into(cell, &mut self.scratch)
            } else {
                pvs.visible_objects_into(cell, &mut self.scratch)
            };
            if let Err(e) = set {
                let message = format!("sightline: cell {cell}: {e}; drawing everything");
                if !self.warned.contains(&id) {
                    self.warned.push(id);
                    tracing::warn!("{message}");
                }
                stats.last_error = Some(message);
                self.draw_all = true;
                continue;
            }
            for &o in &self.scratch {
                if o < len {
                    self.bits[(o / 64) as usize] |= 1 << (o % 64);
                }
            }
        }
        self.visible_objects = if self.draw_all {
            len
        } else {
            self.bits.iter().map(|w| w.count_ones()).sum()
        };
    }
}

/// Step 3 of [`cull`]: entities that lost their [`SightlineObject`] while hidden get the
/// visibility they had back.
fn restore_released(
    removed: &mut RemovedComponents<SightlineObject>,
    released: &mut Query<(&mut Visibility, &mut SightlineCulled), Without<SightlineObject>>,
) {
    for entity in removed.read() {
        if let Ok((mut visibility, mut culled)) = released.get_mut(entity) {
            if culled.hidden {
                *visibility = culled.saved;
                culled.hidden = false;
            }
        }
    }
}

/// Step 4 of [`cull`]: hides the objects `state` does not see and shows the others again,
/// writing only flips (and only when the sets changed or the entity's object did); returns
/// `(drawn, total)` entity counts. A visibility someone else wrote while the plugin hid the
/// entity becomes its saved value.
fn apply_visibility(
    objects: &mut Query<(Ref<SightlineObject>, &mut Visibility, &mut SightlineCulled)>,
    state: &CullState,
    sets_changed: bool,
) -> (u32, u32) {
    let (mut drawn, mut total) = (0, 0);
    for (object, mut visibility, mut culled) in objects {
        total += 1;
        let hide = !state.visible(object.0);
        if culled.hidden && visibility.is_changed() && !visibility.is_added() {
            // Someone else wrote the visibility of a hidden entity: that is its own value now.
            culled.saved = *visibility;
            if hide && *visibility != Visibility::Hidden {
                *visibility = Visibility::Hidden;
            }
        }
        if !sets_changed && !object.is_changed() {
            drawn += u32::from(!culled.hidden);
            continue;
        }
        match (hide, culled.hidden) {
            (true, false) => {
                culled.saved = *visibility;
                culled.hidden = true;
                if *visibility != Visibility::Hidden {
                    *visibility = Visibility::Hidden;
                }
            }
            (false, true) => {
                culled.hidden = false;
                if *visibility != culled.saved {
                    *visibility = culled.saved;
                }
            }
            _ => {}
        }
        drawn += u32::from(!culled.hidden);
    }
    (drawn, total)
}

impl SightlineStats {
    /// The end of [`cull`]: this frame's counts (`drawn` and `total` entities, `unmatched` mesh
    /// entities) and what `state` holds.
    fn record(&mut self, state: &CullState, drawn: u32, total: u32, unmatched: u32) {
        self.drawn = drawn;
        self.total = total;
        self.unmatched = unmatched;
        self.visible_objects = state.visible_objects;
        self.object_count = state.object_count;
        self.draw_all = state.draw_all;
        self.cameras.clear();
        self.cameras
            .extend(state.key.iter().map(|&(e, _, cell, _)| (e, cell)));
    }
}
