//! `sightline convert`: write the scene as loaded, so other tools can use sightline's ids.
//!
//! Triangle ids are kept by every writer. Objects (`docs/objects.md`) are kept by `.glb` (node
//! `extras.sightline` tags) and `.obj` (`# sightline-object` comments before the `o` lines):
//! loading the output gives the same objects, names, `index`/`part` and object of every
//! triangle. `.ply` has no objects.

use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use sightline_core::atomic_file::write_atomic;
use sightline_core::scene::{gltf, obj, ply};

use crate::args::SceneArgs;

/// Arguments of `sightline convert`.
#[derive(clap::Args, Debug)]
pub(crate) struct Args {
    #[command(flatten)]
    scene: SceneArgs,
    /// Output file: .ply (binary, no objects), .obj (objects as tagged `o` groups) or .glb
    /// (objects as tagged nodes). Triangle order is kept, so triangle ids stay the same, and
    /// .obj/.glb load back with the same objects (docs/objects.md).
    #[arg(short, long)]
    output: PathBuf,
    /// Print a JSON summary.
    #[arg(long)]
    json: bool,
}

pub(crate) fn run(args: Args) -> Result<()> {
    crate::output::refuse_overwriting_inputs(
        &[&args.output],
        &[std::path::Path::new(&args.scene.scene)],
    )?;
    let scene = args.scene.load()?;
    let ext = args
        .output
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let result = match ext.as_str() {
        "ply" => write_atomic(&args.output, |w| ply::write(&scene, w)),
        "obj" => write_atomic(&args.output, |w| obj::write(&scene, w)),
        "glb" => write_atomic(&args.output, |w| gltf::write_glb(&scene, w)),
        _ => bail!(
            "{}: unknown output format (use .ply, .obj or .glb)",
            args.output.display()
        ),
    };
    result.with_context(|| format!("writing {}", args.output.display()))?;
    if args.json {
        return crate::output::print_json(&serde_json::json!({
            "output": args.output,
            "triangles": scene.triangle_count(),
            "objects": scene.objects.len(),
            "geometry_hash": format!("{:016x}", scene.geometry_hash()),
        }));
    }
    outln!(
        "wrote {} ({} triangles, {} objects)",
        args.output.display(),
        scene.triangle_count(),
        scene.objects.len()
    );
    Ok(())
}
