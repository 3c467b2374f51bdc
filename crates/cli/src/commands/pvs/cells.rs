//! `pvs bake`'s view cells: where they come from (a cells file, `--cell`, `--grid`,
//! `--walkable`, Quake 3 leaves or clusters), one source per bake.

use std::path::Path;

use anyhow::{bail, Context, Result};
use glam::Vec3;
use sightline_core::trace::Bvh;
use sightline_region::cell_sources::{
    inside_solid, q3_cells, read_cells_file, Q3CellKind, Q3Cells, Q3Origins,
};
use sightline_region::reachable::{ReachParams, DEFAULT_STEP};
use sightline_region::walkable::{walkable_cells, WalkableParams};
use sightline_region::ViewCell;

use super::args::CellArgs;

fn parse_numbers(s: &str, n: usize, what: &str) -> Result<Vec<f32>> {
    let v: Vec<f32> = s
        .split(',')
        .map(|p| p.trim().parse::<f32>())
        .collect::<Result<_, _>>()
        .with_context(|| format!("{what} '{s}': not a list of numbers"))?;
    if v.len() != n || v.iter().any(|x| !x.is_finite()) {
        bail!("{what} '{s}': expected {n} finite numbers");
    }
    Ok(v)
}

/// `--walkable SIZE`: cells at eye height over the floors, with a line saying how many.
fn walkable(
    args: &CellArgs,
    size: f32,
    scene: &sightline_core::Scene,
    caster: &Bvh,
) -> Result<Vec<ViewCell>> {
    let eye = parse_numbers(&args.eye_height, 2, "--eye-height")?;
    let params = WalkableParams {
        size,
        eye: (eye[0], eye[1]),
        head_room: args.head_room,
        ..WalkableParams::default()
    };
    let cells = walkable_cells(scene, caster, &params)?;
    eprintln!(
        "placed {} walkable cells ({size} x {size}, eye height {}..{} above the floor, up axis {:?})",
        cells.len(),
        params.eye.0,
        params.eye.1,
        scene.up
    );
    Ok(cells)
}

/// The cells and, for Quake 3 leaves and clusters, their clusters and origin rule.
pub(super) fn collect_cells<'a>(
    args: &CellArgs,
    scene: &'a sightline_core::Scene,
    caster: &Bvh,
) -> Result<(Vec<ViewCell>, Option<Q3Cells<'a>>)> {
    let sources = usize::from(args.cells.is_some())
        + usize::from(!args.cell.is_empty())
        + usize::from(args.grid.is_some())
        + usize::from(args.walkable.is_some())
        + usize::from(args.q3_leaves)
        + usize::from(args.q3_clusters);
    if sources != 1 {
        bail!("give exactly one cell source: --cells FILE, --cell SPEC, --grid NX,NY,NZ, --walkable SIZE, --q3-leaves or --q3-clusters");
    }
    let q3 = args.q3_leaves || args.q3_clusters;
    if !q3 && (args.include_unreachable || args.reach_step != DEFAULT_STEP) {
        bail!("--include-unreachable and --reach-step apply to --q3-leaves and --q3-clusters only");
    }
    if let Some(path) = &args.cells {
        return Ok((read_cells_file(path)?, None));
    }
    if let Some(size) = args.walkable {
        return Ok((walkable(args, size, scene, caster)?, None));
    }
    if !args.cell.is_empty() {
        let cells = args
            .cell
            .iter()
            .map(|s| ViewCell::parse(s))
            .collect::<Result<_, _>>()?;
        return Ok((cells, None));
    }
    if let Some(grid) = &args.grid {
        let n = parse_numbers(grid, 3, "--grid")?;
        if n.iter().any(|&x| x < 1.0 || x.fract() != 0.0 || x > 4096.0) {
            bail!("--grid '{grid}': counts must be whole numbers in 1..=4096");
        }
        let (min, max) = match &args.bounds {
            Some(b) => {
                let v = parse_numbers(b, 6, "--bounds")?;
                (Vec3::new(v[0], v[1], v[2]), Vec3::new(v[3], v[4], v[5]))
            }
            None => {
                let b = scene.bounds();
                (b.min, b.max)
            }
        };
        crate::limits::check_cells(&[n[0] as u64, n[1] as u64, n[2] as u64], "--grid")?;
        let mut cells = ViewCell::grid(min, max, [n[0] as u32, n[1] as u32, n[2] as u32])?;
        if args.skip_solid {
            cells.retain(|c| !inside_solid(scene, caster, c.center));
        }
        return Ok((cells, None));
    }
    if scene.bsp.is_none() {
        bail!("--q3-leaves and --q3-clusters need a Quake 3 map (.bsp) as the scene");
    }
    let filter = (!args.clusters.is_empty()).then_some(args.clusters.as_slice());
    let kind = if args.q3_clusters {
        Q3CellKind::Clusters
    } else {
        Q3CellKind::Leaves
    };
    let origins = if args.include_unreachable {
        Q3Origins::Cluster
    } else {
        Q3Origins::Reachable(ReachParams {
            step: args.reach_step,
        })
    };
    let mut q3 = q3_cells(scene, kind, filter, origins).context("--reach-step")?;
    let map = Path::new(&scene.source).file_stem().map_or_else(
        || scene.source.clone(),
        |s| s.to_string_lossy().into_owned(),
    );
    let line = q3.summary.describe(&map);
    match (&q3.summary.fallback, q3.summary.dropped_cells) {
        (Some(_), _) => eprintln!("warning: {line}"),
        (None, 0) if q3.rule.reach.is_none() => {}
        (None, 0) => eprintln!("{line}"),
        (None, _) => eprintln!("{line} (--include-unreachable bakes them with the old rule)"),
    }
    let cells = std::mem::take(&mut q3.cells);
    Ok((cells, Some(q3)))
}
