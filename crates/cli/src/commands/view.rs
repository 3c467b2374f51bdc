//! `sightline view`: the interactive viewer (a window with a fly camera, the visibility methods
//! on keys 1..4 and the frame's numbers in a HUD and the title), or with `--frames N --out DIR`
//! its headless mode, which renders N frames offscreen along a camera path and writes
//! `DIR/frame_0000.png`, ... (with the HUD when `--hud`) and `DIR/frames.json`. `--cell`,
//! `--freeze-at` and `--overview` start with a picked cell, frozen culling and the top-down
//! overview (keys `[` `]`, F and O in the window). The window's
//! keys in `--help` come from the viewer's table of controls. The work is in `sightline-view`.

use std::path::PathBuf;

use crate::args::{CameraArgs, SceneArgs};

/// Arguments of `sightline view`.
#[derive(clap::Args, Debug)]
#[cfg_attr(not(feature = "viewer"), allow(dead_code))]
pub(crate) struct Args {
    #[command(flatten)]
    scene: SceneArgs,
    #[command(flatten)]
    camera: CameraArgs,
    /// A .pvs file of the scene: its cells are drawn, the `pvs` method uses the set of the cell
    /// containing the eye (or of the cell picked with --cell).
    #[arg(long, value_name = "FILE")]
    pvs: Option<PathBuf>,
    /// The visibility method: none, pvs, occlusion or exact (default: pvs with --pvs, else
    /// none). Keys 1..4 switch in the window.
    #[arg(long)]
    method: Option<String>,
    /// Show the full image with culled triangles tinted red instead of hidden (key X).
    #[arg(long)]
    xray: bool,
    /// The exact method renders its visible set at 1/N of the image size per axis.
    #[arg(long, value_name = "N", default_value_t = 4)]
    exact_divisor: u32,
    /// Fly speed in scene units per second (default: 5% of the scene's diagonal).
    #[arg(long)]
    speed: Option<f32>,
    /// Headless: render this many frames offscreen (no window) and write them to --out (at
    /// most 1,000,000).
    #[arg(long, value_name = "N", requires = "out")]
    frames: Option<u32>,
    /// Headless: the output folder for frame_0000.png... and frames.json.
    #[arg(long, value_name = "DIR", requires = "frames")]
    out: Option<PathBuf>,
    /// Headless: camera path JSON `{"frames": [{"eye": [x,y,z], "look": [x,y,z]}, ...]}`
    /// (keyframes spread over the frames); default: one orbit around the look point.
    #[arg(long, value_name = "FILE", requires = "frames")]
    path: Option<PathBuf>,
    /// Headless: draw the HUD in each frame's top-left corner (method, cell, triangles and
    /// objects drawn, popping pixels, frame number), as the window does; without it the
    /// frames are the plain render.
    #[arg(long, requires = "frames")]
    hud: bool,
    /// Use cell I's set for the pvs method from any viewpoint instead of the set of the cell
    /// containing the eye (in the window, [ and ] step through the cells and Backspace goes
    /// back to the eye's cell). The cell is highlighted and the HUD names it "(picked)".
    #[arg(long, value_name = "I", requires = "pvs")]
    cell: Option<usize>,
    /// Headless: freeze culling at frame K (0-based; key F in the window): frame K and the
    /// frames after it draw the set chosen for frame K's camera while the camera flies on
    /// along the path, with that camera's frustum drawn in orange. Frozen frames' popping is
    /// not counted in the summary (it measures what the set misses from elsewhere).
    #[arg(long, value_name = "K", requires = "frames")]
    freeze_at: Option<u32>,
    /// Draw the scene from above (key O in the window): an orthographic camera over the whole
    /// scene down its up axis, with the cells filled in the report map's colours for their
    /// PVS size and the eye marked (white; a frozen camera orange). The set is still chosen
    /// from the eye. Its popping is not counted in the summary.
    #[arg(long)]
    overview: bool,
    /// Headless: print the summary as JSON.
    #[arg(long)]
    json: bool,
}

/// `sightline view`'s help with the window's controls added to the long help (`--help`),
/// printed from the viewer's one table of them, so help and key handler cannot differ. A build
/// without the viewer has no window and lists none.
pub(crate) fn with_controls_help(cmd: clap::Command) -> clap::Command {
    #[cfg(feature = "viewer")]
    {
        let mut text = String::from(
            "Window controls (the HUD lists them too, for a few seconds at the start and on H \
             or F1):\n",
        );
        for line in sightline_view::help_lines() {
            text.push_str("  ");
            text.push_str(&line);
            text.push('\n');
        }
        cmd.after_help("The window's keys: see --help.")
            .after_long_help(text)
    }
    #[cfg(not(feature = "viewer"))]
    cmd
}

/// Runs the viewer, or says that this build has none.
pub(crate) fn run(args: Args) -> anyhow::Result<()> {
    #[cfg(feature = "viewer")]
    return window_or_headless::run(args);
    #[cfg(not(feature = "viewer"))]
    {
        let _ = args;
        Err(crate::features::not_built("viewer", "`sightline view`"))
    }
}

/// The viewer itself (cargo feature `viewer`).
#[cfg(feature = "viewer")]
mod window_or_headless {
    use anyhow::{bail, Context, Result};
    use glam::Vec3;
    use sightline_core::{Camera, NearPlaneRule};
    use sightline_region::PvsFile;
    use sightline_view::{
        interpolate, orbit, read_camera_path, run_headless, run_window, FlyCamera, HeadlessOptions,
        HeadlessReport, Lens, Method, Viewer, ViewerOptions,
    };

    use super::Args;
    use crate::output::print_json;

    /// Checks the outputs, loads the scene, the start camera and the viewer (with its
    /// `.pvs` file and method), then opens the window, or renders the frames headless when
    /// `--frames` and `--out` are given.
    pub(super) fn run(args: Args) -> Result<()> {
        if let Some(frames) = args.frames {
            crate::limits::check_frames(u64::from(frames), "--frames")?;
        }
        if let Some(out) = &args.out {
            let mut inputs = vec![std::path::Path::new(&args.scene.scene)];
            inputs.extend(args.pvs.as_deref());
            inputs.extend(args.path.as_deref());
            crate::output::refuse_overwriting_inputs(&[out, &out.join("frames.json")], &inputs)?;
        }
        let scene = args.scene.load()?;
        // The near plane is checked on the cameras used: the start (window) or the path (headless).
        let start = Start {
            camera: args.camera.camera_unchecked(&scene)?,
            look: args.camera.look.unwrap_or(scene.bounds().center()),
            up: args.camera.up.unwrap_or(scene.up.vector()),
            diagonal: scene.bounds().diagonal().max(1e-6),
        };
        let (mut viewer, method) = open_viewer(&args, scene)?;
        let (Some(frames), Some(out)) = (args.frames, &args.out) else {
            return window(&args, viewer, &start);
        };
        if frames == 0 {
            bail!("--frames must be at least 1");
        }
        if let Some(k) = args.freeze_at.filter(|&k| k >= frames) {
            bail!(
                "--freeze-at {k} is past the last frame (--frames {frames}: frames 0 to {})",
                frames - 1
            );
        }
        let cameras = path_cameras(&args, &viewer, &start, frames as usize)?;
        args.camera.warn_if_near_hides(viewer.scene(), &cameras);
        crate::headless::quiet_vulkan_layers();
        let (device, queue, info) = sightline_gpu::vulkan_device()?;
        let report = run_headless(
            &device,
            &queue,
            &info.name,
            &mut viewer,
            &cameras,
            out,
            &HeadlessOptions {
                hud: args.hud,
                freeze_at: args.freeze_at,
                overview: args.overview,
            },
        )?;
        if args.json {
            return print_json(&report);
        }
        print_summary(&report, method, out, &viewer)
    }

    /// Where the view starts: the command line's camera (its near plane not yet checked),
    /// the point it looks at, the up vector, and the scene's diagonal (for the default
    /// fly speed).
    struct Start {
        camera: Camera,
        look: Vec3,
        up: Vec3,
        diagonal: f32,
    }

    /// The viewer of `scene`: its `.pvs` file (with `--pvs`), its method (`--method`, else
    /// pvs with a file, else none) and shading. Refuses an unknown method, the pvs method
    /// without a file, a zero exact divisor and a file of another scene.
    fn open_viewer(args: &Args, scene: sightline_core::Scene) -> Result<(Viewer, Method)> {
        let pvs = match &args.pvs {
            Some(p) => Some(PvsFile::load(p).with_context(|| format!("reading {}", p.display()))?),
            None => None,
        };
        let method = match &args.method {
            Some(name) => Method::parse(name).with_context(|| {
                format!("unknown method {name:?}: use none, pvs, occlusion or exact")
            })?,
            None if pvs.is_some() => Method::Pvs,
            None => Method::None,
        };
        if method == Method::Pvs && pvs.is_none() {
            bail!("--method pvs needs --pvs FILE");
        }
        if args.exact_divisor == 0 {
            bail!("--exact-divisor must be at least 1");
        }
        let options = ViewerOptions {
            exact_divisor: args.exact_divisor,
            ..Default::default()
        };
        let source = args.scene.scene.clone();
        let mut viewer = Viewer::new(scene, pvs, options).with_context(|| {
            format!(
                "{} does not go with {}",
                args.pvs
                    .as_ref()
                    .map_or(String::new(), |p| p.display().to_string()),
                source
            )
        })?;
        viewer.set_method(method);
        viewer.shading.xray = args.xray;
        viewer.overview = args.overview;
        viewer
            .pick_cell(args.cell)
            .with_context(|| format!("--cell {}", args.cell.unwrap_or_default()))?;
        Ok((viewer, method))
    }

    /// The interactive window, with a fly camera at the start (speed `--speed`, default 5%
    /// of the scene's diagonal per second).
    fn window(args: &Args, viewer: Viewer, start: &Start) -> Result<()> {
        let camera = start.camera;
        args.camera.warn_if_near_hides(viewer.scene(), &[camera]);
        let speed = args.speed.unwrap_or(start.diagonal * 0.05);
        let fly =
            FlyCamera::new(camera.eye, start.look, start.up, speed).context("invalid camera")?;
        let lens = Lens {
            fov_y_deg: camera.fov_y_deg,
            near: camera.near,
        };
        run_window(viewer, fly, lens, camera.width, camera.height)
            .context("the viewer window (headless: --frames N --out DIR)")
    }

    /// The `n` headless cameras: along `--path` (keyframes spread over the frames) or one
    /// orbit around the look point, with the start camera's lens and one near plane for the
    /// whole path.
    fn path_cameras(args: &Args, viewer: &Viewer, start: &Start, n: usize) -> Result<Vec<Camera>> {
        let (camera, up) = (start.camera, start.up);
        let poses = match &args.path {
            Some(path) => {
                let keys = read_camera_path(path)?;
                (0..n).map(|f| interpolate(&keys, f, n)).collect()
            }
            None => orbit(camera.eye, start.look, up, n),
        };
        // One near plane for the whole path, by the default rule at every eye on it (the start
        // eye's could clip what a later frame passes close to).
        let near = match args.camera.near {
            Some(near) => near,
            None => {
                let eyes: Vec<Vec3> = poses.iter().map(|&(eye, _)| eye).collect();
                NearPlaneRule::new(viewer.scene()).along(&eyes)
            }
        };
        poses
            .into_iter()
            .enumerate()
            .map(|(f, (eye, look))| {
                Camera::look_at(
                    eye,
                    look,
                    up,
                    camera.fov_y_deg,
                    camera.width,
                    camera.height,
                    near,
                )
                .with_context(|| {
                    format!(
                        "frame {f}: no camera from eye {eye} looking at {look} (eye equal to look, \
                         or looking along the up axis?)"
                    )
                })
            })
            .collect::<Result<Vec<_>>>()
    }

    /// Prints the headless run's one-line summary: frames written, triangles drawn on
    /// average, popping.
    fn print_summary(
        report: &HeadlessReport,
        method: Method,
        out: &std::path::Path,
        viewer: &Viewer,
    ) -> Result<()> {
        let drawn_mean = report
            .frames
            .iter()
            .map(|f| f.triangles_drawn as f64)
            .sum::<f64>()
            / report.frames.len().max(1) as f64;
        outln!(
            "wrote {} frames ({}x{}, method {}) and frames.json to {} on {}: {:.0} of {} triangles \
             drawn on average, popping max {} px, mean {:.1} px per frame (GPU id-image compare)",
            report.frames.len(),
            report.width,
            report.height,
            method.name(),
            out.display(),
            report.adapter,
            drawn_mean,
            viewer.scene().triangle_count(),
            report.popping.max,
            report.popping_mean,
        );
        Ok(())
    }
}
