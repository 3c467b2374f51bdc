//! Reading a `.pvs` file's bake metadata (written by `sightline_region::bake`) for the report.
//! Every key is optional: files from other tools or older versions lack some, and the report
//! shows "—" (or says the data is missing) instead of failing.

use serde_json::Value;

/// What the bake recorded for one cell.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct CellBake {
    /// Rays cast.
    pub rays: Option<u64>,
    /// Seconds spent.
    pub seconds: Option<f64>,
    /// `(rays, PVS size)` after each batch.
    pub convergence: Option<Vec<(u64, u64)>>,
    /// Whether the sampler's termination rule held before the budget ran out (GVS, GVS++).
    pub converged: Option<bool>,
}

/// The bake record of cell `i` (`metadata["cells"][i]`).
pub(crate) fn cell_bake(metadata: &Value, i: usize) -> CellBake {
    let c = &metadata["cells"][i];
    CellBake {
        rays: c["rays"].as_u64(),
        seconds: c["seconds"].as_f64(),
        convergence: convergence(&c["convergence"]),
        converged: c["converged"].as_bool(),
    }
}

/// `"k of n cells"` converged, naming what stopped the others; `None` when no cell records
/// the flag (methods without a termination rule, older files).
pub(crate) fn converged_cells(metadata: &Value, cells: usize) -> Option<String> {
    let flags: Vec<bool> = (0..cells)
        .filter_map(|i| metadata["cells"][i]["converged"].as_bool())
        .collect();
    if flags.is_empty() {
        return None;
    }
    let k = flags.iter().filter(|&&c| c).count();
    Some(if k == flags.len() {
        format!("all {k}")
    } else {
        format!(
            "{k} of {}: the budget stopped the other {} before the termination rule held (their \
             PVS may miss triangles)",
            flags.len(),
            flags.len() - k
        )
    })
}

/// `[[rays, pvs_size], ...]` as pairs; `None` when absent or malformed.
fn convergence(v: &Value) -> Option<Vec<(u64, u64)>> {
    v.as_array()?
        .iter()
        .map(|p| Some((p.get(0)?.as_u64()?, p.get(1)?.as_u64()?)))
        .collect()
}

/// A top-level string (`scene`, `method`, `tool`), or `None`.
pub(crate) fn text(metadata: &Value, key: &str) -> Option<String> {
    match &metadata[key] {
        Value::String(s) => Some(s.clone()),
        Value::Null => None,
        v => Some(v.to_string()),
    }
}

/// The budget as written by the bake (`{"max_rays": N, "max_time": {...}}`) in words.
pub(crate) fn budget(metadata: &Value) -> Option<String> {
    let b = metadata.get("budget")?;
    let mut parts = Vec::new();
    if let Some(r) = b["max_rays"].as_u64() {
        parts.push(format!("{r} rays"));
    }
    if let Some(t) = b.get("max_time").filter(|t| !t.is_null()) {
        let secs = t["secs"].as_f64().unwrap_or(0.0) + t["nanos"].as_f64().unwrap_or(0.0) * 1e-9;
        parts.push(format!("{secs} s"));
    }
    Some(if parts.is_empty() {
        "until converged".into()
    } else {
        parts.join(", ")
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn converged_cells_are_counted() {
        let m = json!({"cells": [{"converged": true}, {"converged": false}, {}]});
        assert_eq!(cell_bake(&m, 1).converged, Some(false));
        assert_eq!(cell_bake(&m, 2).converged, None);
        let line = converged_cells(&m, 3).unwrap();
        assert!(
            line.starts_with("1 of 2: the budget stopped the other 1"),
            "{line}"
        );
        assert_eq!(
            converged_cells(&json!({"cells": [{"converged": true}]}), 1).unwrap(),
            "all 1"
        );
        assert_eq!(converged_cells(&json!({"cells": [{}]}), 1), None);
    }

    #[test]
    fn empty_metadata_gives_nothing() {
        assert_eq!(cell_bake(&Value::Null, 0), CellBake::default());
        assert_eq!(text(&Value::Null, "method"), None);
        assert_eq!(budget(&Value::Null), None);
    }

    #[test]
    fn cell_record_is_read() {
        let m = json!({"cells": [{}, {"rays": 5000, "seconds": 0.5,
            "convergence": [[1000, 10], [5000, 12]]}]});
        let c = cell_bake(&m, 1);
        assert_eq!(c.rays, Some(5000));
        assert_eq!(c.seconds, Some(0.5));
        assert_eq!(c.convergence, Some(vec![(1000, 10), (5000, 12)]));
        assert_eq!(cell_bake(&m, 0).convergence, None);
        assert_eq!(cell_bake(&m, 7), CellBake::default());
    }

    #[test]
    fn malformed_convergence_is_none() {
        let m = json!({"cells": [{"convergence": [[1000, "x"]]}]});
        assert_eq!(cell_bake(&m, 0).convergence, None);
    }

    #[test]
    fn budget_in_words() {
        assert_eq!(
            budget(&json!({"budget": {"max_rays": 100, "max_time": null}})).unwrap(),
            "100 rays"
        );
        assert_eq!(
            budget(
                &json!({"budget": {"max_rays": null, "max_time": {"secs": 2, "nanos": 500000000}}})
            )
            .unwrap(),
            "2.5 s"
        );
        assert_eq!(
            budget(&json!({"budget": {"max_rays": null, "max_time": null}})).unwrap(),
            "until converged"
        );
    }

    #[test]
    fn seed_is_text() {
        assert_eq!(text(&json!({"seed": 7}), "seed").unwrap(), "7");
    }
}
