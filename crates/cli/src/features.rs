//! The CLI's optional parts (cargo features, both on by default): `gpu` (the GPU ray caster of
//! `pvs bake --device gpu` and `bench trace --device gpu`, the GPU occlusion backend of
//! `cull --backend gpu`) and `viewer` (`sightline view`). A headless build
//! (`cargo install --path crates/cli --no-default-features`) compiles neither wgpu nor winit;
//! its commands and flags stay the same, and asking for a part it lacks is an error that says
//! how to get it, instead of a flag or command that silently does not exist.

/// The error of a command or flag that needs a cargo feature this build was made without;
/// exit status 2, as for any argument the command cannot take.
#[cfg_attr(all(feature = "gpu", feature = "viewer"), allow(dead_code))]
pub(crate) fn not_built(feature: &str, what: &str) -> anyhow::Error {
    anyhow::anyhow!(
        "{what} needs the cargo feature `{feature}`, and this sightline was built without it \
         (a headless build, `--no-default-features`); rebuild with the default features: \
         cargo install --path crates/cli"
    )
    .context(crate::errors::ExitStatus(2))
}

/// `Ok` when this build has the GPU parts; else the [`not_built`] error for `what` (the flag
/// that asked), so commands refuse it before loading anything.
pub(crate) fn require_gpu(what: &str) -> anyhow::Result<()> {
    if cfg!(feature = "gpu") {
        Ok(())
    } else {
        Err(not_built("gpu", what))
    }
}

/// The optional features this build has, shown by `sightline --version`.
pub(crate) fn built_features() -> Vec<&'static str> {
    let mut features = Vec::new();
    if cfg!(feature = "gpu") {
        features.push("gpu");
    }
    if cfg!(feature = "viewer") {
        features.push("viewer");
    }
    if cfg!(feature = "embree") {
        features.push("embree");
    }
    features
}

/// `sightline --version`'s text: the version and the optional features built in.
pub(crate) fn long_version() -> String {
    let features = built_features();
    let features = if features.is_empty() {
        "none (headless build)".to_string()
    } else {
        features.join(", ")
    };
    format!("{}\nfeatures: {features}", env!("CARGO_PKG_VERSION"))
}
