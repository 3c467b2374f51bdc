//! `sightline render`: an image of the scene from the reference rasterizer.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Result};
use sightline_core::raster;
use sightline_core::Camera;

use crate::args::{CameraArgs, SceneArgs};
use sightline_eval::report::shading::shaded_image;

use crate::output::{
    id_image, print_json, refuse_overwriting_inputs, require_png_extension, save_png,
};

/// Arguments of `sightline render`.
#[derive(clap::Args, Debug)]
pub(crate) struct Args {
    #[command(flatten)]
    scene: SceneArgs,
    #[command(flatten)]
    camera: CameraArgs,
    /// Output PNG (the name must end in .png; it may not be the scene file). With --cube, six
    /// files NAME_px.png, NAME_nx.png, ... are written.
    #[arg(short, long, default_value = "render.png")]
    output: PathBuf,
    /// Colour each triangle by its id instead of shading.
    #[arg(long)]
    ids: bool,
    /// Render the six 90-degree faces of a cube map at the eye (square, --size width).
    #[arg(long)]
    cube: bool,
    /// Print a JSON summary.
    #[arg(long)]
    json: bool,
}

#[derive(serde::Serialize)]
struct Summary {
    outputs: Vec<PathBuf>,
    visible_triangles: usize,
    milliseconds: f64,
}

pub(crate) fn run(args: Args) -> Result<()> {
    let scene_path = Path::new(&args.scene.scene);
    // With --cube the files written are NAME_px.png...; the plain name is checked first so
    // the refusal comes before the scene is loaded.
    refuse_overwriting_inputs(&[&args.output], &[scene_path])?;
    require_png_extension(&args.output, "--output")?;
    let scene = args.scene.load()?;
    // The near plane is checked on the cameras rendered: with --cube, the six faces.
    let main_camera = args.camera.camera_unchecked(&scene)?;
    let cameras: Vec<(Camera, PathBuf)> = if args.cube {
        const SUFFIX: [&str; 6] = ["px", "nx", "py", "ny", "pz", "nz"];
        let stem = args
            .output
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned());
        let Some(stem) = stem else {
            bail!("--output {} has no file name", args.output.display())
        };
        let faces = Camera::cube_faces(main_camera.eye, main_camera.width, main_camera.near)?;
        faces
            .into_iter()
            .zip(SUFFIX)
            .map(|(c, s)| (c, args.output.with_file_name(format!("{stem}_{s}.png"))))
            .collect()
    } else {
        vec![(main_camera, args.output.clone())]
    };
    let written: Vec<&Path> = cameras.iter().map(|(_, p)| p.as_path()).collect();
    refuse_overwriting_inputs(&written, &[scene_path])?;
    let rendered: Vec<Camera> = cameras.iter().map(|(c, _)| *c).collect();
    args.camera.warn_if_near_hides(&scene, &rendered);
    let start = Instant::now();
    let mut visible = sightline_core::TriangleSet::with_capacity(scene.triangle_count());
    let mut outputs = Vec::new();
    // Six faces take six times one image: show them (hidden when stderr is not a terminal).
    let bar = if args.cube {
        crate::progress::bar(cameras.len() as u64, &crate::progress::template("faces"))
    } else {
        indicatif::ProgressBar::hidden()
    };
    for (camera, path) in &cameras {
        bar.set_message(path.display().to_string());
        let frame = raster::render(&scene, camera);
        for &id in &frame.ids {
            if (id as usize) < scene.triangle_count() {
                visible.insert(id as usize);
            }
        }
        let image = if args.ids {
            id_image(&frame)
        } else {
            shaded_image(&frame, &scene, camera)
        };
        save_png(&image, path)?;
        outputs.push(path.clone());
        bar.inc(1);
    }
    bar.finish_and_clear();
    let summary = Summary {
        outputs,
        visible_triangles: visible.count_ones(..),
        milliseconds: start.elapsed().as_secs_f64() * 1e3,
    };
    if args.json {
        return print_json(&summary);
    }
    for p in &summary.outputs {
        outln!("wrote {}", p.display());
    }
    outln!(
        "{} of {} triangles visible, {:.1} ms",
        summary.visible_triangles,
        scene.triangle_count(),
        summary.milliseconds
    );
    Ok(())
}
