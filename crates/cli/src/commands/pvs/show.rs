//! `sightline pvs show`: a .pvs file's cells, sets and objects, as text or JSON.

use anyhow::{Context, Result};
use serde::Serialize;
use sightline_region::PvsFile;

use crate::output::print_json;

use super::args::ShowArgs;

#[derive(Serialize)]
struct CellJson {
    center: [f32; 3],
    half_extents: [f32; 3],
    axes: [[f32; 3]; 3],
    pvs_size: usize,
    triangles: Vec<usize>,
    /// Visible objects (version 2 files).
    objects: Option<Vec<usize>>,
    /// Two-sided files: the conservative bound's size and the triangles it adds to the set
    /// (those the set might be missing).
    bound_size: Option<usize>,
    gap: Option<Vec<usize>>,
}

#[derive(Serialize)]
struct ObjectJson {
    name: String,
    index: Option<u32>,
    part: Option<u32>,
    triangles: usize,
    bounds_min: [f32; 3],
    bounds_max: [f32; 3],
}

fn object_rows(file: &PvsFile) -> Option<Vec<ObjectJson>> {
    let table = file.objects.as_ref()?;
    let mut triangles = vec![0usize; table.objects.len()];
    for &o in &table.object_of_triangle {
        triangles[o as usize] += 1;
    }
    Some(
        table
            .objects
            .iter()
            .zip(triangles)
            .map(|(o, triangles)| ObjectJson {
                name: o.name.clone(),
                index: o.index,
                part: o.part,
                triangles,
                bounds_min: o.bounds_min.to_array(),
                bounds_max: o.bounds_max.to_array(),
            })
            .collect(),
    )
}

pub(super) fn run_show(args: ShowArgs) -> Result<()> {
    let file =
        PvsFile::load(&args.file).with_context(|| format!("reading {}", args.file.display()))?;
    let version = if file.objects.is_some() { 2 } else { 1 };
    if args.json {
        #[derive(Serialize)]
        struct Out {
            version: u32,
            scene_hash: String,
            triangle_count: u32,
            metadata: serde_json::Value,
            objects: Option<Vec<ObjectJson>>,
            cells: Vec<CellJson>,
        }
        let cells = file
            .cells
            .iter()
            .enumerate()
            .map(|(i, c)| CellJson {
                center: c.cell.center.to_array(),
                half_extents: c.cell.half_extents.to_array(),
                axes: c.cell.axes.map(|a| a.to_array()),
                pvs_size: c.visible.count_ones(..),
                triangles: c.visible.ones().collect(),
                objects: file.visible_objects(i).map(|o| o.ones().collect()),
                bound_size: c.bound.as_ref().map(|b| b.count_ones(..)),
                gap: c.bound.as_ref().map(|b| b.difference(&c.visible).collect()),
            })
            .collect();
        return print_json(&Out {
            version,
            scene_hash: format!("{:016x}", file.scene_hash),
            triangle_count: file.triangle_count,
            objects: object_rows(&file),
            metadata: file.metadata,
            cells,
        });
    }
    let n = f64::from(file.triangle_count.max(1));
    outln!("file       {}", args.file.display());
    outln!(
        "scene      {} ({} triangles, hash {:016x})",
        file.metadata["scene"].as_str().unwrap_or("?"),
        file.triangle_count,
        file.scene_hash
    );
    outln!(
        "method     {}",
        file.metadata["method"].as_str().unwrap_or("?")
    );
    outln!("version    {version}");
    match &file.objects {
        Some(t) => outln!("objects    {}", t.objects.len()),
        None => outln!("objects    none (version 1: triangle sets only; bake again for objects)"),
    }
    if args.objects {
        for (i, o) in object_rows(&file).unwrap_or_default().iter().enumerate() {
            let number = |v: Option<u32>| v.map_or("-".to_string(), |v| v.to_string());
            outln!(
                "  object {i:>5}  {:<40}  index {:>5}  part {:>4}  {:>7} triangles  bounds {:.2?} .. {:.2?}",
                o.name,
                number(o.index),
                number(o.part),
                o.triangles,
                o.bounds_min,
                o.bounds_max
            );
        }
    }
    outln!("cells      {}", file.cells.len());
    if file.has_bounds() {
        outln!(
            "sides      two: each cell's set (sampled: surely visible) and its conservative \
             bound; gap = triangles the set might miss"
        );
    }
    let objects_total = file.objects.as_ref().map_or(0, |t| t.objects.len().max(1)) as f64;
    for (i, c) in file.cells.iter().enumerate() {
        let size = c.visible.count_ones(..);
        let objects = file.visible_objects(i).map_or(String::new(), |o| {
            let k = o.count_ones(..);
            format!(
                "  objects {k:>6} ({:.2}%)",
                100.0 * k as f64 / objects_total
            )
        });
        let bound = c.bound.as_ref().map_or(String::new(), |b| {
            let bound = b.count_ones(..);
            format!("  bound {bound:>8}  gap {:>8}", bound - size)
        });
        outln!(
            "  cell {i:>4}  centre {:>28}  half extents {:>24}  PVS {size:>8} ({:.2}%){objects}{bound}",
            format!("{:.2?}", c.cell.center.to_array()),
            format!("{:.2?}", c.cell.half_extents.to_array()),
            100.0 * size as f64 / n
        );
    }
    Ok(())
}
