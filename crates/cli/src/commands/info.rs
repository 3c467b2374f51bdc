//! `sightline info`: counts, bounds, objects and the validation report of a scene. Like a
//! validator, it exits with status 1 after the report when the report has errors (the scene
//! is empty, has NaN coordinates, ...), so scripts can rely on the status.

use std::time::Instant;

use anyhow::{bail, Result};
use serde::Serialize;
use sightline_core::validate::{validate, Report};

use crate::args::SceneArgs;
use crate::output::print_json;

/// Arguments of `sightline info`.
#[derive(clap::Args, Debug)]
pub(crate) struct Args {
    #[command(flatten)]
    scene: SceneArgs,
    /// Print JSON instead of text.
    #[arg(long)]
    json: bool,
    /// List every object with its triangle count (text output lists the first 20).
    #[arg(long)]
    objects: bool,
}

#[derive(Serialize)]
struct Info {
    source: String,
    up: sightline_core::UpAxis,
    load_seconds: f64,
    geometry_bytes: usize,
    geometry_hash: String,
    validation: Report,
    errors: Vec<String>,
    warnings: Vec<String>,
    /// What the loader found questionable (`Scene::load_warnings`; also printed on stderr).
    load_warnings: Vec<String>,
    objects: Vec<ObjectInfo>,
}

#[derive(Serialize)]
struct ObjectInfo {
    name: String,
    /// `Object::index` (glTF node, Quake 3 model); `null` when the format has none.
    index: Option<u32>,
    /// `Object::part` (glTF primitive, Quake 3 shader); `null` when the format has none.
    part: Option<u32>,
    triangles: usize,
}

pub(crate) fn run(args: Args) -> Result<()> {
    let start = Instant::now();
    let scene = args.scene.load_unchecked()?;
    let load_seconds = start.elapsed().as_secs_f64();
    let validation = validate(&scene);
    let mut counts = vec![0usize; scene.objects.len()];
    for &o in &scene.object_of_triangle {
        if let Some(c) = counts.get_mut(o as usize) {
            *c += 1;
        }
    }
    let info = Info {
        source: scene.source.clone(),
        up: scene.up,
        load_seconds,
        geometry_bytes: scene.geometry_bytes(),
        geometry_hash: format!("{:016x}", scene.geometry_hash()),
        errors: validation
            .errors()
            .iter()
            .map(ToString::to_string)
            .collect(),
        warnings: validation.warnings(),
        load_warnings: scene.load_warnings.clone(),
        objects: scene
            .objects
            .iter()
            .zip(&counts)
            .map(|(o, &triangles)| ObjectInfo {
                name: o.name.clone(),
                index: o.index,
                part: o.part,
                triangles,
            })
            .collect(),
        validation,
    };
    if args.json {
        print_json(&info)?;
        return exit_status(&info);
    }
    let v = &info.validation;
    outln!("scene      {}", info.source);
    outln!("triangles  {}", v.triangles);
    outln!("vertices   {}", v.vertices);
    outln!("objects    {}", v.objects);
    match v.bounds {
        Some([min, max]) => outln!("bounds     {min:?} .. {max:?}"),
        None => outln!("bounds     (none)"),
    }
    outln!("up axis    {:?}", info.up);
    outln!(
        "memory     {:.1} MiB geometry",
        info.geometry_bytes as f64 / (1 << 20) as f64
    );
    outln!("hash       {}", info.geometry_hash);
    outln!("loaded in  {:.3} s", info.load_seconds);
    if info.errors.is_empty() && info.warnings.is_empty() {
        outln!("validation ok");
    }
    for e in &info.errors {
        outln!("error      {e}");
    }
    for w in &info.warnings {
        outln!("warning    {w}");
    }
    let shown = if args.objects { info.objects.len() } else { 20 };
    for o in info.objects.iter().take(shown) {
        outln!("  object {:<40} {:>9} triangles", o.name, o.triangles);
    }
    if info.objects.len() > shown {
        outln!(
            "  ... {} more objects (--objects lists all)",
            info.objects.len() - shown
        );
    }
    exit_status(&info)
}

/// An error (exit status 1) when the report has errors; they were printed with the report.
fn exit_status(info: &Info) -> Result<()> {
    if !info.errors.is_empty() {
        bail!(
            "{}: {} validation error(s), see the report above",
            info.source,
            info.errors.len()
        );
    }
    Ok(())
}
