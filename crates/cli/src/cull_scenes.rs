//! The scene specs of `cull`'s own procedural scenes, `procedural:grid` (rooms on a grid of
//! floors, `size` = objects per room, default 40) and `procedural:graveyard` (the Teapot
//! Graveyard, `size` = teapots, default 5000), each with `?seed=S&size=N`: `cull` runs them
//! with their moving objects and camera paths, every other command loads their geometry at
//! time 0 (`args::SceneArgs`), so one spec names one scene everywhere.

use anyhow::{bail, Context, Result};
use sightline_cull::scenes::{graveyard, the_grid, CullScene};

/// The scene `spec` names when it is one of these two (`None` for any other spec).
pub(crate) fn procedural(spec: &str) -> Option<Result<CullScene>> {
    let (name, query) = spec.split_once('?').unwrap_or((spec, ""));
    let is_grid = match name {
        "procedural:grid" => true,
        "procedural:graveyard" => false,
        _ => return None,
    };
    Some(build(spec, query, is_grid))
}

fn build(spec: &str, query: &str, is_grid: bool) -> Result<CullScene> {
    let (mut seed, mut size) = (1u64, if is_grid { 40usize } else { 5000 });
    for kv in query.split('&').filter(|kv| !kv.is_empty()) {
        let (k, v) = kv
            .split_once('=')
            .with_context(|| format!("{spec}: expected key=value, got {kv:?}"))?;
        match k {
            "seed" => {
                seed = v
                    .parse()
                    .with_context(|| format!("{spec}: bad seed {v:?}"))?
            }
            "size" => {
                size = v
                    .parse()
                    .with_context(|| format!("{spec}: bad size {v:?}"))?
            }
            _ => bail!("{spec}: unknown parameter {k:?} (expected seed, size)"),
        }
    }
    let limit = if is_grid { 1000 } else { 200_000 };
    if size > limit {
        bail!("{spec}: size {size} is above the maximum of {limit}");
    }
    Ok(if is_grid {
        the_grid(seed, size)
    } else {
        graveyard(seed, size)
    })
}
