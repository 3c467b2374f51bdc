//! `sightline pvs compare-q3`: a bake of a Quake 3 map's clusters against the map's own PVS
//! (q3map2's), pair by pair.

use anyhow::{bail, Context, Result};
use serde::Serialize;
use sightline_region::{PvsFile, ViewCell};

use crate::args::SceneArgs;
use crate::output::print_json;

use super::args::CompareQ3Args;

#[derive(Serialize)]
struct ClusterComparison {
    cluster: u32,
    leaves: usize,
    ours: usize,
    q3map2: usize,
    ours_not_q3map2: usize,
    q3map2_not_ours: usize,
    /// Average erroneous pixels per view of our PVS and of q3map2's (with --views).
    ours_avg_error_pixels: Option<f64>,
    q3map2_avg_error_pixels: Option<f64>,
    /// Viewpoints not evaluated (outside the cluster, or unreachable in a bake with reachable
    /// origins), with --views.
    rejected_viewpoints: sightline_eval::report::evaluate::Rejected,
}

pub(super) fn run_compare_q3(args: CompareQ3Args) -> Result<()> {
    let scene_args = SceneArgs::new(args.map.display().to_string(), args.patch_subdivisions);
    let scene = scene_args.load()?;
    let file =
        PvsFile::load(&args.pvs).with_context(|| format!("reading {}", args.pvs.display()))?;
    file.check_scene(&scene)?;
    let Some(bsp) = scene.bsp.as_deref() else {
        bail!("{} is not a Quake 3 map", args.map.display())
    };
    let Some(clusters) = file.metadata["clusters"].as_array() else {
        bail!(
            "{} was not baked with --q3-leaves (no cluster per cell)",
            args.pvs.display()
        );
    };
    if clusters.len() != file.cells.len() {
        bail!(
            "{}: cluster list does not match the cells",
            args.pvs.display()
        );
    }
    type ClusterCells = (Vec<ViewCell>, fixedbitset::FixedBitSet);
    let mut by_cluster: std::collections::BTreeMap<u32, ClusterCells> = Default::default();
    for (c, cell) in clusters.iter().zip(&file.cells) {
        let c = c.as_u64().context("cluster ids must be numbers")? as u32;
        let entry = by_cluster.entry(c).or_insert_with(|| {
            (
                Vec::new(),
                fixedbitset::FixedBitSet::with_capacity(scene.triangle_count()),
            )
        });
        entry.0.push(cell.cell);
        entry.1.union_with(&cell.visible);
    }
    let eval = sightline_eval::EvalParams {
        viewpoints: args.viewpoints,
        resolution: args.resolution.clamp(1, 8192),
        ..sightline_eval::EvalParams::default()
    };
    // Viewpoints where the bake took its origins: the cluster, and reachable space when the
    // bake recorded one.
    let viewpoints = sightline_eval::report::evaluate::Viewpoints::of(&scene, &file, None)?;
    let mut rows = Vec::new();
    for (cluster, (leaves, ours)) in by_cluster {
        let mut q3 = fixedbitset::FixedBitSet::with_capacity(scene.triangle_count());
        for t in bsp.triangles_visible_from_cluster(cluster) {
            q3.insert(t as usize);
        }
        let (mut ours_error, mut q3_error) = (None, None);
        let filter = viewpoints.cluster(cluster);
        if args.viewpoints > 0 {
            let (mut sum, mut images) = ([0.0f64; 2], 0usize);
            for leaf in &leaves {
                let e = sightline_eval::evaluate_cell_in(
                    &scene,
                    leaf,
                    &|p| filter.allows(p),
                    &[&ours, &q3],
                    &eval,
                    &|_, _| {},
                );
                for (k, ek) in e.iter().enumerate() {
                    sum[k] += ek.avg_error_pixels * ek.images as f64;
                }
                images += e[0].images;
            }
            if images > 0 {
                ours_error = Some(sum[0] / images as f64);
                q3_error = Some(sum[1] / images as f64);
            }
        }
        rows.push(ClusterComparison {
            rejected_viewpoints: filter.rejected(),
            cluster,
            ours_avg_error_pixels: ours_error,
            q3map2_avg_error_pixels: q3_error,
            leaves: leaves.len(),
            ours: ours.count_ones(..),
            q3map2: q3.count_ones(..),
            ours_not_q3map2: ours.difference(&q3).count(),
            q3map2_not_ours: q3.difference(&ours).count(),
        });
    }
    if args.json {
        return print_json(&rows);
    }
    outln!("| cluster | leaves | ours | q3map2 | ours, culled by q3map2 | q3map2, not ours | ours avg err px | q3map2 avg err px |");
    outln!("|---:|---:|---:|---:|---:|---:|---:|---:|");
    for r in &rows {
        let error = |e: Option<f64>| e.map_or("-".to_string(), |v| format!("{v:.3}"));
        outln!(
            "| {} | {} | {} | {} | {} | {} | {} | {} |",
            r.cluster,
            r.leaves,
            r.ours,
            r.q3map2,
            r.ours_not_q3map2,
            r.q3map2_not_ours,
            error(r.ours_avg_error_pixels),
            error(r.q3map2_avg_error_pixels)
        );
    }
    let suspicious: usize = rows.iter().map(|r| r.ours_not_q3map2).sum();
    outln!(
        "{} clusters; {suspicious} (cluster, triangle) pairs we see that q3map2's conservative PVS culls \
         (each is a bug in one of the two, or geometry q3map2 does not treat as occluding)",
        rows.len()
    );
    Ok(())
}
