//! `sightline visible`: which triangles are visible from a point — by the reference
//! rasterizer (pixel-centre sampling), conservatively in bounded memory (RV), or exactly.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Context, Result};
use serde::Serialize;
use sightline_core::raster::render;
use sightline_core::scene::procedural::Params;
use sightline_core::scene::SceneSpec;
use sightline_core::trace::{Bvh, RayCaster};
use sightline_core::TriangleSet;
use sightline_point::rv::{
    conservative_from_region, conservative_visible, Guarantee, HiddenOccluders, RegionOptions,
    RvOptions, SceneSource, StreamingCity,
};
use sightline_region::closed_solids::ClosedSolids;
use sightline_region::ViewCell;

use crate::args::{CameraArgs, SceneArgs};
use crate::output::print_json;

/// Arguments of `sightline visible`.
#[derive(clap::Args, Debug)]
pub(crate) struct Args {
    #[command(flatten)]
    scene: SceneArgs,
    #[command(flatten)]
    camera: CameraArgs,
    /// Conservative visible set (RV: never misses a visible triangle) in bounded memory.
    #[arg(long, conflicts_with = "exact")]
    conservative: bool,
    /// Exact visible set (analytic hidden-surface removal). Exact range: --fov up to 170.00°
    /// (also horizontally), and an image at least tan(fov/2)/4 px high (any size up to fov
    /// 151.9°); other cameras are refused (use several narrower views, e.g. cube faces).
    /// Screen positions are snapped to 2^-20 px, so geometry far below a pixel (a tiny model
    /// seen from far away) loses slivers; depth gaps below ~2e-9 of the distance are ties.
    #[arg(long)]
    exact: bool,
    /// Memory budget of --conservative, e.g. 256MiB, 1GiB, 64000000.
    #[arg(long, default_value = "256MiB", value_parser = parse_bytes)]
    memory: usize,
    /// With --conservative and a `procedural:city` scene: stream the triangles from the
    /// generator without ever holding the scene in memory.
    #[arg(long, requires = "conservative")]
    stream: bool,
    /// With --conservative (from a point): what may never be missed. `area`: every triangle
    /// with a visible region of positive area (the --exact set). `samples`: also every triangle
    /// the reference rasterizer could show at a pixel centre on a silhouette it only touches
    /// (back faces along a closed object's outline; larger sets).
    #[arg(long, default_value = "area", value_parser = ["area", "samples"], requires = "conservative")]
    guarantee: String,
    /// With --conservative (from a point): the thesis' initialization phase — each screen bin's
    /// first batch of triangles becomes occluders untested (faster, larger sets).
    #[arg(long, requires = "conservative")]
    init_phase: bool,
    /// With --conservative (from a point): whether triangles found hidden still become occluder
    /// parts. `never` (the thesis), `joining` (they only grow existing occluders) or `all`.
    /// Smaller sets on in-memory scenes, more time; see docs/BENCHMARKS.md.
    #[arg(long, default_value = "never", value_parser = ["never", "joining", "all"], requires = "conservative")]
    hidden_occluders: String,
    /// With --conservative (from a point, in memory): skip the cross-check against the
    /// guarantee's reference (the exact set, or the rasterizer at 8x), which on a large scene
    /// can take longer than RV itself; the overestimation and the missed count are then not
    /// reported.
    #[arg(long, requires = "conservative")]
    no_check: bool,
    /// With --conservative: visibility from a whole view cell instead of a point: every
    /// triangle seen from any point of the cell is kept (umbrae of the largest convex
    /// occluders, two passes over the scene; the portal cut of Quake 3 cluster bakes does not
    /// apply, since the box's points need not lie in the map's empty leaves). Syntax as
    /// `pvs bake --cell`:
    /// `box:MINX,MINY,MINZ,MAXX,MAXY,MAXZ` or `point:X,Y,Z,R`.
    #[arg(
        long,
        requires = "conservative",
        value_name = "SPEC",
        allow_hyphen_values = true
    )]
    cell: Option<String>,
    /// With --cell: convex occluders kept (the largest by solid angle from the cell).
    #[arg(long, default_value_t = sightline_point::rv::DEFAULT_MAX_OCCLUDERS, requires = "cell")]
    max_occluders: usize,
    /// With --cell: occluder fusion, levels of halving of the cell (each smaller box gets its
    /// own depth map of shrunk occluders, which finds what several occluders hide together;
    /// each level costs up to twice the time). 0 turns fusion off.
    #[arg(long, default_value_t = sightline_point::rv::DEFAULT_FUSION_SPLITS, requires = "cell")]
    fusion_splits: u32,
    /// With --cell: pixels per cube-face side of the fusion's depth maps (the last level
    /// retests what is left on maps four times finer).
    #[arg(long, default_value_t = sightline_point::rv::DEFAULT_FUSION_RESOLUTION, requires = "cell")]
    fusion_resolution: usize,
    /// With --exact: write the visible polygons (coloured by triangle) as SVG.
    #[arg(long, requires = "exact")]
    svg: Option<PathBuf>,
    /// With --exact: write the analytically anti-aliased image (grey headlight shading) as PNG.
    #[arg(long, requires = "exact")]
    png: Option<PathBuf>,
    /// Pixel filter of --png: `box` (the exact pixel-square integral) or `gauss` (radius 2.3 px).
    #[arg(long, default_value = "box", value_parser = ["box", "gauss"])]
    filter: String,
    /// With --exact: screen bin size in pixels.
    #[arg(long, default_value_t = 16)]
    bin_size: u32,
    /// With --exact: skip the conservative depth pre-culling of provably hidden triangles (same
    /// result, slower; for cross-checks and measurements).
    #[arg(long)]
    no_preculling: bool,
    /// With --exact: the set (`-o`, the counts) keeps the triangles whose visible area is at
    /// least this many square pixels and whose visible region is on average (its area over its
    /// extent) at least 2^-19 px (two units of the snapping grid) thick. The default, 1e-6, leaves out the slivers that
    /// the 2^-20 px snapping and f64 rounding leave along shared edges and between nearly
    /// collinear edges (the same rule the conservative check uses); 0 keeps every positive area,
    /// however thin (needed at tiny image sizes, where whole triangles are smaller).
    #[arg(long, value_name = "PX2", default_value_t = sightline_point::analytic::MIN_VISIBLE_AREA_PX2)]
    min_area: f64,
    /// Write the visible triangle ids, one per line, to this file.
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// Print JSON.
    #[arg(long)]
    json: bool,
}

#[derive(Serialize)]
struct Summary {
    method: &'static str,
    triangles: usize,
    visible: usize,
    seconds: f64,
    peak_memory_bytes: Option<usize>,
    /// For --conservative on a materialised scene: the reference set of the guarantee (the
    /// exact analytic set for `area`, the reference rasterizer's set at 8x resolution for
    /// `samples`), the overestimation against it, and triangles of it that RV missed (must be 0).
    reference: Option<&'static str>,
    reference_visible: Option<usize>,
    overestimation: Option<f64>,
    missed: Option<usize>,
}

/// Parses `256MiB`, `1GiB`, `500MB`, `64k`, or plain bytes.
pub(crate) fn parse_bytes(s: &str) -> Result<usize, String> {
    let t = s.trim();
    let split = t
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(t.len());
    let (number, unit) = t.split_at(split);
    let value: f64 = number
        .parse()
        .map_err(|_| format!("'{s}' is not a size like 256MiB"))?;
    let scale: f64 = match unit.trim().to_ascii_lowercase().as_str() {
        "" | "b" => 1.0,
        "k" | "kb" => 1e3,
        "kib" => 1024.0,
        "m" | "mb" => 1e6,
        "mib" => 1024.0 * 1024.0,
        "g" | "gb" => 1e9,
        "gib" => 1024.0 * 1024.0 * 1024.0,
        other => {
            return Err(format!(
                "unknown size unit '{other}' in '{s}' (use B, KiB, MiB, GiB)"
            ))
        }
    };
    let bytes = value * scale;
    if !(1.0..1e15).contains(&bytes) {
        return Err(format!("'{s}' is not a plausible memory size"));
    }
    Ok(bytes as usize)
}

/// `--conservative --cell`: the conservative from-region set, with a sampled cross-check on a
/// materialised scene (rays from random points of the cell: whatever they hit must be kept).
fn run_from_region(args: &Args, spec: &str, start: Instant) -> Result<()> {
    let cell = ViewCell::parse(spec).with_context(|| format!("--cell '{spec}'"))?;
    let options = RegionOptions {
        max_occluders: args.max_occluders,
        fusion_splits: args.fusion_splits,
        fusion_resolution: args.fusion_resolution,
        ..RegionOptions::default()
    };
    let (r, check) = if args.stream {
        let SceneSpec::Procedural(Params { name, seed, size }) =
            SceneSpec::parse(&args.scene.scene)?
        else {
            bail!("--stream works with procedural:city scenes only");
        };
        if name != "city" {
            bail!("--stream works with procedural:city scenes only, not procedural:{name}");
        }
        let r = conservative_from_region(
            &mut StreamingCity::new(seed, size),
            &cell.corners(),
            &options,
        )?;
        (r, None)
    } else {
        let scene = args.scene.load()?;
        let mut r =
            conservative_from_region(&mut SceneSource::new(&scene), &cell.corners(), &options)?;
        // The scene is in memory: the back faces of its closed solids go too.
        let solids = ClosedSolids::new(&scene);
        let removed = solids.remove_back_faces(&scene, &cell.corners(), &mut r.visible);
        r.stats.hidden += removed as u64;
        let seconds = start.elapsed().as_secs_f64();
        let bvh = Bvh::build(&scene);
        let seen = sampled_from_cell(&bvh, &cell, 200_000);
        let missed = seen.difference(&r.visible).count();
        (r, Some((seen.count_ones(..), missed, seconds)))
    };
    let n = r.visible.count_ones(..);
    let seconds = check.map_or(start.elapsed().as_secs_f64(), |c| c.2);
    let summary = Summary {
        method: if check.is_some() {
            "conservative from a view cell (umbrae of convex occluders, back faces of closed solids)"
        } else {
            "conservative from a view cell (umbrae of convex occluders)"
        },
        triangles: r.stats.triangles_streamed as usize,
        visible: n,
        seconds,
        peak_memory_bytes: None,
        reference: check.map(|_| "200000 rays from inside the cell"),
        reference_visible: check.map(|c| c.0),
        overestimation: check.map(|c| n as f64 / c.0.max(1) as f64 - 1.0),
        missed: check.map(|c| c.1),
    };
    if let Some(path) = &args.output {
        write_ids(path, &r.visible)?;
    }
    if args.json {
        return print_json(&summary);
    }
    outln!(
        "{}: {} of {} triangles ({:.2}%) in {:.3} s, {} occluders, {} hidden only by several together ({} boxes)",
        summary.method,
        n,
        summary.triangles,
        100.0 * n as f64 / summary.triangles.max(1) as f64,
        summary.seconds,
        r.stats.occluders,
        r.stats.fused_hidden,
        r.stats.fusion_boxes
    );
    if let Some((seen, missed, _)) = check {
        outln!(
            "sampled check: 200000 rays from the cell hit {seen} triangles, {missed} of them missing from the set (must be 0)"
        );
    }
    Ok(())
}

/// Writes the ids of `set`, one per line (atomically: an existing file survives a failure).
fn write_ids(path: &std::path::Path, set: &TriangleSet) -> Result<()> {
    let text: String = set.ones().map(|id| format!("{id}\n")).collect();
    sightline_core::atomic_file::write_atomic(path, |w| {
        std::io::Write::write_all(w, text.as_bytes())
    })
    .with_context(|| format!("writing {}", path.display()))
}

/// Triangles hit by `rays` rays from random points of `cell` in random directions.
fn sampled_from_cell(bvh: &Bvh, cell: &ViewCell, rays: usize) -> TriangleSet {
    let batch = cell.random_rays(rays, 0x5eed);
    let mut hits = vec![sightline_core::Hit::default(); batch.len()];
    bvh.cast(&batch, &mut hits);
    let mut seen = TriangleSet::with_capacity(bvh.triangle_count());
    for h in hits
        .iter()
        .filter(|h| h.triangle != sightline_core::Hit::NONE)
    {
        seen.insert(h.triangle as usize);
    }
    seen
}

/// The set a conservative result under `guarantee` must contain: the exact analytic set
/// (without the exact method's sub-grid rounding pieces), or the rasterizer's at 8x.
fn reference_set(
    scene: &sightline_core::Scene,
    camera: &sightline_core::Camera,
    guarantee: Guarantee,
) -> Result<TriangleSet> {
    Ok(match guarantee {
        Guarantee::PositiveArea => {
            use sightline_point::analytic::{visible_fragments, AnalyticOptions};
            let exact = visible_fragments(scene, camera, &AnalyticOptions::default())?;
            warn_unresolved_crossings(exact.stats.warnings.unresolved_crossings);
            // Pieces under MIN_VISIBLE_AREA_PX2 are the exact method's rounding on shared
            // edges: the positive-area guarantee means that threshold.
            exact.visible_at_least(
                scene.triangle_count(),
                sightline_point::analytic::MIN_VISIBLE_AREA_PX2,
            )
        }
        Guarantee::AnySample => {
            let mut fine = *camera;
            fine.width = (camera.width * 8).min(16384);
            fine.height = (camera.height * 8).min(16384);
            render(scene, &fine).visible_set(scene.triangle_count())
        }
    })
}

/// Finds the visible set by the method the arguments choose: exact, conservative from a view
/// cell, conservative from a point (streamed or in memory, cross-checked), or the reference
/// rasterizer; then writes the ids (`-o`) and prints the summary.
pub(crate) fn run(args: Args) -> Result<()> {
    let start = Instant::now();
    check_outputs(&args)?;
    if args.exact {
        return run_exact(&args, start);
    }
    if let Some(spec) = &args.cell {
        return run_from_region(&args, spec, start);
    }
    let (visible, summary) = if args.stream {
        conservative_streamed(&args, start)?
    } else {
        let scene = args.scene.load()?;
        let camera = args.camera.camera(&scene)?;
        if args.conservative {
            conservative_in_memory(&args, &scene, &camera, start)?
        } else {
            let visible = render(&scene, &camera).visible_set(scene.triangle_count());
            let summary = Summary {
                method: "reference rasterizer (pixel centres)",
                triangles: scene.triangle_count(),
                visible: visible.count_ones(..),
                seconds: start.elapsed().as_secs_f64(),
                peak_memory_bytes: None,
                reference: None,
                reference_visible: None,
                overestimation: None,
                missed: None,
            };
            (visible, summary)
        }
    };
    if let Some(path) = &args.output {
        write_ids(path, &visible)?;
    }
    if args.json {
        return print_json(&summary);
    }
    print_summary(&args, &summary)
}

/// Refuses outputs (`--svg`, `--png`, `-o`) that would overwrite the scene, and a `--png`
/// without the `.png` extension: before any work.
fn check_outputs(args: &Args) -> Result<()> {
    let outputs: Vec<&Path> = [&args.svg, &args.png, &args.output]
        .into_iter()
        .flatten()
        .map(PathBuf::as_path)
        .collect();
    crate::output::refuse_overwriting_inputs(&outputs, &[Path::new(&args.scene.scene)])?;
    if let Some(png) = &args.png {
        crate::output::require_png_extension(png, "--png")?;
    }
    Ok(())
}

/// RV's options from the command line: memory budget, guarantee, initialization phase and
/// hidden occluders.
fn rv_options(args: &Args) -> RvOptions {
    RvOptions {
        memory_budget_bytes: args.memory,
        guarantee: if args.guarantee == "samples" {
            Guarantee::AnySample
        } else {
            Guarantee::PositiveArea
        },
        init_phase: args.init_phase,
        hidden_occluders: match args.hidden_occluders.as_str() {
            "joining" => HiddenOccluders::Joining,
            "all" => HiddenOccluders::All,
            _ => HiddenOccluders::Never,
        },
        ..RvOptions::default()
    }
}

/// `--conservative --stream`: RV over a `procedural:city` streamed from its generator (the
/// scene is never held), without a cross-check.
fn conservative_streamed(args: &Args, start: Instant) -> Result<(TriangleSet, Summary)> {
    let SceneSpec::Procedural(Params { name, seed, size }) = SceneSpec::parse(&args.scene.scene)?
    else {
        bail!("--stream works with procedural:city scenes only");
    };
    if name != "city" {
        bail!("--stream works with procedural:city scenes only, not procedural:{name}");
    }
    let camera = streamed_camera(args, size)?;
    let mut source = StreamingCity::new(seed, size);
    let r = conservative_visible(&mut source, &camera, &rv_options(args))?;
    let visible = r.visible;
    let summary = Summary {
        method: "conservative (RV, streamed)",
        triangles: r.stats.triangles_streamed as usize,
        visible: visible.count_ones(..),
        seconds: start.elapsed().as_secs_f64(),
        peak_memory_bytes: Some(r.peak_memory_bytes),
        reference: None,
        reference_visible: None,
        overestimation: None,
        missed: None,
    };
    Ok((visible, summary))
}

/// The camera of a streamed city of `size` triangles: explicit --eye and --look need no
/// scene; otherwise the default view needs the bounds, taken from the generated city when it
/// is small enough to hold.
fn streamed_camera(args: &Args, size: usize) -> Result<sightline_core::Camera> {
    if args.camera.eye.is_some() && args.camera.look.is_some() {
        let mut c = args.camera.clone();
        c.near = c.near.or(Some(0.05));
        let placeholder = sightline_core::Scene {
            up: sightline_core::UpAxis::Z,
            ..sightline_core::Scene::default()
        };
        Ok(c.camera(&placeholder)?)
    } else if size <= 2_000_000 {
        Ok(args.camera.camera(&args.scene.load()?)?)
    } else {
        bail!("--stream with more than 2M triangles: give --eye and --look explicitly");
    }
}

/// `--conservative` on a loaded scene: RV, then (unless `--no-check`) the cross-check with
/// the reference of the guarantee, which RV's set must contain. The time excludes the check.
fn conservative_in_memory(
    args: &Args,
    scene: &sightline_core::Scene,
    camera: &sightline_core::Camera,
    start: Instant,
) -> Result<(TriangleSet, Summary)> {
    let options = rv_options(args);
    let r = conservative_visible(&mut SceneSource::new(scene), camera, &options)?;
    let seconds = start.elapsed().as_secs_f64();
    // Cross-check with the reference of the guarantee: RV must contain it.
    let reference = if args.no_check {
        None
    } else {
        Some(reference_set(scene, camera, options.guarantee)?)
    };
    let missed = reference
        .as_ref()
        .map(|set| set.difference(&r.visible).count());
    let n_ref = reference.as_ref().map(|set| set.count_ones(..));
    let visible = r.visible;
    let summary = Summary {
        method: "conservative (RV)",
        triangles: scene.triangle_count(),
        visible: visible.count_ones(..),
        seconds,
        peak_memory_bytes: Some(r.peak_memory_bytes),
        reference: reference.as_ref().map(|_| match options.guarantee {
            Guarantee::PositiveArea => "exact analytic set",
            Guarantee::AnySample => "reference rasterizer at 8x",
        }),
        reference_visible: n_ref,
        overestimation: n_ref.map(|n| visible.count_ones(..) as f64 / n.max(1) as f64 - 1.0),
        missed,
    };
    Ok((visible, summary))
}

/// Prints the summary of a from-point run: the set's size and time, RV's peak memory, the
/// cross-check, the file written.
fn print_summary(args: &Args, summary: &Summary) -> Result<()> {
    outln!(
        "{}: {} of {} triangles visible ({:.2}%) in {:.3} s",
        summary.method,
        summary.visible,
        summary.triangles,
        100.0 * summary.visible as f64 / summary.triangles.max(1) as f64,
        summary.seconds
    );
    if let Some(peak) = summary.peak_memory_bytes {
        outln!(
            "peak memory {:.1} MiB of a {:.1} MiB budget",
            peak as f64 / 1048576.0,
            args.memory as f64 / 1048576.0
        );
    }
    if let (Some(name), Some(n), Some(o), Some(m)) = (
        summary.reference,
        summary.reference_visible,
        summary.overestimation,
        summary.missed,
    ) {
        outln!(
            "reference ({name}): {n} triangles; overestimation {:.1}%; visible triangles missed: {m}",
            100.0 * o
        );
    }
    if let Some(p) = &args.output {
        outln!("wrote {}", p.display());
    }
    Ok(())
}

/// `--exact`: analytic visible fragments, optional SVG and anti-aliased PNG.
fn run_exact(args: &Args, start: Instant) -> Result<()> {
    use sightline_point::analytic::{
        antialiased_image, visible_fragments, write_svg, AnalyticOptions, Filter,
    };
    let scene = args.scene.load()?;
    let camera = args.camera.camera(&scene)?;
    let result = visible_fragments(
        &scene,
        &camera,
        &AnalyticOptions {
            bin_size: args.bin_size,
            depth_preculling: !args.no_preculling,
        },
    )?;
    let visibility_seconds = start.elapsed().as_secs_f64();
    if let Some(path) = &args.svg {
        sightline_core::atomic_file::write_atomic(path, |w| write_svg(&result, w))
            .with_context(|| format!("writing {}", path.display()))?;
    }
    if let Some(path) = &args.png {
        let filter = if args.filter == "gauss" {
            Filter::Gauss { radius_px: 2.3 }
        } else {
            Filter::Box
        };
        // The filtered values are linear light (area averages of the shading); the file is
        // sRGB-encoded and says so, so that partial coverage shows as the right brightness.
        let values = antialiased_image(&result, &scene, &camera, filter);
        crate::output::save_linear_grey_png(&values, camera.width, camera.height, path)?;
    }
    if !(args.min_area >= 0.0 && args.min_area.is_finite()) {
        bail!("--min-area {} must be a finite number >= 0", args.min_area);
    }
    let set = result.visible_at_least(scene.triangle_count(), args.min_area);
    let below = result.visible.count_ones(..) - set.count_ones(..);
    if let Some(path) = &args.output {
        let text: String = set.ones().map(|id| format!("{id}\n")).collect();
        sightline_core::atomic_file::write_atomic(path, |w| {
            std::io::Write::write_all(w, text.as_bytes())
        })
        .with_context(|| format!("writing {}", path.display()))?;
    }
    let s = &result.stats;
    let summary = serde_json::json!({
        "method": "exact (analytic)",
        "triangles": scene.triangle_count(),
        "visible": set.count_ones(..),
        "min_area_px2": args.min_area,
        "min_thickness_px": if args.min_area > 0.0 {
            sightline_point::analytic::MIN_VISIBLE_THICKNESS_PX
        } else {
            0.0
        },
        "below_min_area": below,
        "visible_polygons": result.polygons.len(),
        "visibility_seconds": visibility_seconds,
        "seconds": start.elapsed().as_secs_f64(),
        "intersections": s.intersections,
        "invalid_triangles": s.warnings.invalid_triangles,
        "crossing_pairs": s.crossing_pairs,
        "flipped_overlaps": s.flipped_overlaps,
        "unresolved_crossings": s.warnings.unresolved_crossings,
    });
    if s.warnings.invalid_triangles > 0 {
        eprintln!(
            "warning: {} triangles skipped (an index past the vertex array or a non-finite corner)",
            s.warnings.invalid_triangles
        );
    }
    warn_unresolved_crossings(s.warnings.unresolved_crossings);
    if args.json {
        return print_json(&summary);
    }
    outln!(
        "exact (analytic): {} of {} triangles visible (at least {:e} px² and 2^-19 px thick; {} more below) as {} polygons; visibility {:.3} s, total {:.3} s; {} edge/triangle overlaps; {} intersecting pairs resolved; {} warnings",
        set.count_ones(..),
        scene.triangle_count(),
        args.min_area,
        below,
        result.polygons.len(),
        visibility_seconds,
        start.elapsed().as_secs_f64(),
        s.intersections,
        s.crossing_pairs,
        s.warnings.total()
    );
    for p in [&args.svg, &args.png, &args.output].into_iter().flatten() {
        outln!("wrote {}", p.display());
    }
    Ok(())
}

/// Says on stderr when intersecting pairs were left to the order at each part of their overlap.
fn warn_unresolved_crossings(count: u64) {
    if count > 0 {
        eprintln!(
            "warning: {count} intersecting triangle pairs cross only within the depth tolerance \
             (1e-9 relative); each side keeps the order found there"
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_with_units() {
        assert_eq!(parse_bytes("256MiB").unwrap(), 256 << 20);
        assert_eq!(parse_bytes("1GiB").unwrap(), 1 << 30);
        assert_eq!(parse_bytes("500MB").unwrap(), 500_000_000);
        assert_eq!(parse_bytes("4096").unwrap(), 4096);
    }

    #[test]
    fn bad_sizes_are_errors() {
        assert!(parse_bytes("lots").is_err());
        assert!(parse_bytes("5 parsecs").unwrap_err().contains("unit"));
        assert!(parse_bytes("0").is_err());
    }
}
