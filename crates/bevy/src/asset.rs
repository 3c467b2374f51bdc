//! The `.pvs` asset and its loader.

use std::sync::Arc;

use bevy::asset::io::Reader;
use bevy::asset::{Asset, AssetLoader, LoadContext};
use bevy::reflect::TypePath;

/// A baked `.pvs` file, loaded by [`PvsLoader`] (extension `pvs`).
///
/// The file is checked completely when it loads (structure and every checksum; see
/// [`sightline_runtime::Pvs::from_bytes`]), so a damaged file fails to load instead of
/// culling wrongly. The [`sightline_runtime::Pvs`] is shared: cloning the asset is cheap.
#[derive(Asset, TypePath, Clone, Debug)]
pub struct PvsAsset {
    pvs: Arc<sightline_runtime::Pvs>,
}

impl PvsAsset {
    /// Wraps an opened file (e.g. one opened with [`sightline_runtime::Pvs::open`]), for
    /// adding to `Assets<PvsAsset>` by hand.
    pub fn new(pvs: sightline_runtime::Pvs) -> Self {
        Self { pvs: Arc::new(pvs) }
    }

    /// The opened file.
    pub fn pvs(&self) -> &sightline_runtime::Pvs {
        &self.pvs
    }

    /// The opened file, shared.
    pub fn shared(&self) -> Arc<sightline_runtime::Pvs> {
        Arc::clone(&self.pvs)
    }
}

impl std::ops::Deref for PvsAsset {
    type Target = sightline_runtime::Pvs;

    fn deref(&self) -> &Self::Target {
        &self.pvs
    }
}

/// Why a `.pvs` asset failed to load.
#[derive(Debug, thiserror::Error)]
pub enum PvsLoadError {
    /// The asset reader failed.
    #[error("reading the .pvs file: {0}")]
    Io(#[from] std::io::Error),
    /// The bytes are not a valid `.pvs` file.
    #[error("invalid .pvs file: {0}")]
    Invalid(#[from] sightline_runtime::Error),
}

/// Loads `.pvs` files as [`PvsAsset`]s. Never panics: every problem of the file is a
/// [`PvsLoadError`], reported by Bevy as a failed load.
#[derive(Default, TypePath)]
pub struct PvsLoader;

impl AssetLoader for PvsLoader {
    type Asset = PvsAsset;
    type Settings = ();
    type Error = PvsLoadError;

    async fn load(
        &self,
        reader: &mut dyn Reader,
        _settings: &(),
        _load_context: &mut LoadContext<'_>,
    ) -> Result<PvsAsset, PvsLoadError> {
        let mut bytes = Vec::new();
        reader.read_to_end(&mut bytes).await?;
        Ok(PvsAsset::new(sightline_runtime::Pvs::from_bytes(bytes)?))
    }

    fn extensions(&self) -> &[&str] {
        &["pvs"]
    }
}
