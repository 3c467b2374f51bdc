//! `sightline bench peers`: our occlusion buffer and BVH side by side with peer libraries, on
//! the same inputs: Intel's Masked Occlusion Culling (MOC) and tinybvh through the harnesses
//! of `bench/peers/` (built by `scripts/peer-bench` from checkouts outside the repository),
//! Embree in process when built with `--features embree`. This file picks the sets (the
//! occlusion bench's random triangles, one frame of the culling simulation's occluders, the
//! ray sets of `bench trace`), writes them as `sightline_eval::bench::peer_sets` files, starts
//! the harnesses and prints the tables; the measuring is `sightline_eval::bench`'s.

use std::path::{Path, PathBuf};

use super::scenes::{load, overview_camera};
use anyhow::{Context, Result};
use sightline_core::scene::LoadOptions;
use sightline_core::trace::{Bvh, RayCaster};
use sightline_core::Scene;
use sightline_cull::{bench_sets, SimConfig};
use sightline_eval::bench::peer_sets::{self, MeshSet, OccluderSet};
use sightline_eval::bench::{
    self as eval_bench, InProcessCaster, OccluderCase, OccluderRow, PeerBenchOptions, PeerProcess,
    RayRow, RaySetCase, TraceRays,
};

/// Arguments of `sightline bench peers`.
#[derive(clap::Args, Debug)]
pub(super) struct PeersArgs {
    /// The built MOC harness (`bench/peers/moc_harness.cpp`; `scripts/peer-bench` builds it).
    /// Without it, no MOC columns.
    #[arg(long, value_name = "PROGRAM")]
    moc: Option<PathBuf>,
    /// The built tinybvh harness (`bench/peers/tinybvh_harness.cpp`). Without it, no tinybvh
    /// rows.
    #[arg(long, value_name = "PROGRAM")]
    tinybvh: Option<PathBuf>,
    /// Rounds; every side runs once per round, in turn (median of all samples).
    #[arg(long, default_value_t = 3)]
    rounds: usize,
    /// Timed samples of occluder renderings per side and round (a sample is the mean of as
    /// many renderings as last 2 ms, one for the random sets).
    #[arg(long, default_value_t = 5)]
    reps: usize,
    /// Casts of each ray set per backend and round.
    #[arg(long, default_value_t = 1)]
    ray_reps: usize,
    /// Leg lengths (pixels) of the random right triangles (100,000 per set, 1920x1080).
    #[arg(long, value_delimiter = ',', default_value = "10,25,50,100")]
    legs: Vec<f32>,
    /// Scenes whose culling simulation gives a real occluder set (the grid method's occluders
    /// in one frame of `sightline cull`'s default camera path, at 1920x1080); "" for none.
    #[arg(long, value_delimiter = ',', default_value = "procedural:city")]
    cull_scenes: Vec<String>,
    /// Frames of that camera path (as `sightline cull --frames`); the set is its middle frame.
    #[arg(long, default_value_t = 300)]
    frames: u32,
    /// Scenes for the ray casting comparison.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "procedural:city?size=1000000"
    )]
    scenes: Vec<String>,
    /// Incoherent rays per scene (`bench trace`'s set).
    #[arg(long, default_value_t = 1_000_000)]
    rays: usize,
    /// Camera resolution (square) of the coherent rays (`bench trace`'s set).
    #[arg(long, default_value_t = 1024)]
    size: u32,
    /// Skip the occluder comparison.
    #[arg(long)]
    no_occluders: bool,
    /// Skip the ray casting comparison.
    #[arg(long)]
    no_rays: bool,
    /// Keep the exchange files in DIR (default: a temporary folder, removed at the end).
    #[arg(long, value_name = "DIR")]
    keep: Option<PathBuf>,
    /// Also write every row as JSON to FILE.
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
}

/// Prints a benchmark's progress on stderr.
fn progress(p: &eval_bench::Progress<'_>) {
    eprintln!("{p}");
}

pub(super) fn run(args: PeersArgs) -> Result<()> {
    let options = PeerBenchOptions {
        rounds: args.rounds,
        reps: args.reps,
        ray_reps: args.ray_reps,
    };
    options.validate()?;
    crate::limits::check_count(args.rays as u64, crate::limits::MAX_BENCH_RAYS, "--rays")?;
    crate::limits::check_pixels(args.size, args.size).map_err(anyhow::Error::msg)?;
    anyhow::ensure!(args.frames > 0, "--frames must be at least 1");
    crate::limits::check_frames(u64::from(args.frames), "--frames")?;
    let dir = match &args.keep {
        Some(d) => d.clone(),
        None => std::env::temp_dir().join(format!("sightline-peers-{}", std::process::id())),
    };
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    let result = run_in(&args, &options, &dir);
    if args.keep.is_none() {
        let _ = std::fs::remove_dir_all(&dir);
    }
    result
}

fn run_in(args: &PeersArgs, options: &PeerBenchOptions, dir: &Path) -> Result<()> {
    let mut occluder_rows = Vec::new();
    if !args.no_occluders {
        let notes;
        (occluder_rows, notes) = occluders(args, options, dir)?;
        print_occluders(&occluder_rows, options, &notes)?;
    }
    let mut ray_rows = Vec::new();
    if !args.no_rays {
        ray_rows = rays(args, options, dir)?;
        print_rays(&ray_rows, options, args.tinybvh.is_some())?;
    }
    if let Some(path) = &args.json {
        let all = serde_json::json!({
            "options": options,
            "occluders": occluder_rows,
            "rays": ray_rows,
        });
        std::fs::write(path, serde_json::to_string_pretty(&all)? + "\n")
            .with_context(|| format!("writing {}", path.display()))?;
        eprintln!("wrote {}", path.display());
    }
    Ok(())
}

/// The occluder sets (random legs, then one simulated frame per cull scene) and their rows,
/// with notes on MOC's sides for the report (none given, or paths left out:
/// `eval_bench::spawn_moc`).
fn occluders(
    args: &PeersArgs,
    options: &PeerBenchOptions,
    dir: &Path,
) -> Result<(Vec<OccluderRow>, Vec<String>)> {
    let mut cases = Vec::new();
    for &leg in &args.legs {
        anyhow::ensure!(
            leg > 0.0 && leg <= 1000.0,
            "--legs: {leg} is not in (0, 1000] px"
        );
        let (triangles, camera) = bench_sets::occluder_set(leg);
        cases.push(export_case(
            dir,
            &format!("random {leg} px"),
            triangles,
            camera,
        )?);
    }
    for spec in args.cull_scenes.iter().filter(|s| !s.is_empty()) {
        let scene = super::super::cull::load_scene(spec, &LoadOptions::default())?;
        let config = SimConfig {
            frames: args.frames,
            width: bench_sets::WIDTH,
            height: bench_sets::HEIGHT,
            ..SimConfig::default()
        };
        let cameras = super::super::cull::cameras(
            spec,
            super::super::cull::CameraSource::Default,
            &scene,
            &config,
        )?;
        let mid = args.frames / 2;
        let camera = cameras[mid as usize];
        let camera_of = |f: u32| cameras.get(f as usize).copied();
        eprintln!("{spec}: simulating frames 0..={mid} for the occluders of frame {mid}");
        let triangles = bench_sets::frame_occluders(&scene, &camera_of, &config, mid)?;
        let name = format!("{spec} frame {mid}");
        cases.push(export_case(dir, &name, triangles, camera)?);
    }
    let (mut peers, notes) = match &args.moc {
        Some(moc) => eval_bench::spawn_moc(moc)?,
        None => (
            Vec::new(),
            vec!["No MOC harness given (--moc): ours only".to_string()],
        ),
    };
    let rows = eval_bench::bench_occluders(&cases, &mut peers, options, dir, Some(&progress))?;
    Ok((rows, notes))
}

/// Writes an occluder set and reads it back (every side then renders the file's contents).
fn export_case(
    dir: &Path,
    name: &str,
    triangles: Vec<glam::Vec3>,
    camera: sightline_core::Camera,
) -> Result<OccluderCase> {
    let file: String = name
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    let path = dir.join(format!("occ_{file}.bin"));
    peer_sets::write_occluders(&path, &OccluderSet { camera, triangles })?;
    let set = peer_sets::read_occluders(&path)?;
    Ok(OccluderCase {
        name: name.to_string(),
        path,
        set,
    })
}

/// The in-process ray casters: ours, and Embree when built with it (one build thread).
fn in_process() -> Vec<InProcessCaster<'static>> {
    let ours = |scene: &Scene| Ok(Box::new(Bvh::build(scene)) as Box<dyn RayCaster>);
    #[allow(unused_mut)]
    let mut casters = vec![InProcessCaster {
        name: "sightline BVH".into(),
        build: Box::new(ours),
    }];
    #[cfg(feature = "embree")]
    casters.push(InProcessCaster {
        name: "Embree 3".into(),
        build: Box::new(|scene: &Scene| {
            sightline_core::trace::embree::EmbreeCaster::build_with_threads(scene, 1)
                .map(|c| Box::new(c) as Box<dyn RayCaster>)
                .map_err(|e| e.to_string())
        }),
    });
    casters
}

/// Per scene: export the mesh and `bench trace`'s two ray sets, then measure.
fn rays(args: &PeersArgs, options: &PeerBenchOptions, dir: &Path) -> Result<Vec<RayRow>> {
    let mut tinybvh = match &args.tinybvh {
        Some(program) => {
            let (peer, hello) = PeerProcess::spawn("tinybvh", program, &[])?;
            eprintln!("tinybvh: {hello}");
            Some(peer)
        }
        None => None,
    };
    let casters = in_process();
    let mut rows = Vec::new();
    for spec in args.scenes.iter().filter(|s| !s.is_empty()) {
        let scene = load(spec)?;
        let camera = overview_camera(&scene, args.size)?;
        let rays = TraceRays::new(&scene, &camera, args.rays);
        let mesh = MeshSet {
            vertices: scene.positions.clone(),
            triangles: scene.triangles.clone(),
        };
        let mesh_path = dir.join("mesh.bin");
        peer_sets::write_mesh(&mesh_path, &mesh)?;
        drop(mesh);
        let mut sets = Vec::new();
        for (name, r) in [
            ("coherent", &rays.coherent),
            ("incoherent", &rays.incoherent),
        ] {
            let path = dir.join(format!("rays_{name}.bin"));
            peer_sets::write_rays(&path, r)?;
            let rays = peer_sets::read_rays(&path)?;
            sets.push(RaySetCase {
                name: name.into(),
                path,
                rays,
            });
        }
        drop(rays);
        if let Some(peer) = tinybvh.as_mut() {
            peer.call(&format!("scene {}", mesh_path.display()))?;
        }
        rows.extend(eval_bench::bench_rays(
            spec,
            &scene,
            &sets,
            &casters,
            tinybvh.as_mut(),
            options,
            dir,
            Some(&progress),
        )?);
    }
    Ok(rows)
}

fn print_occluders(rows: &[OccluderRow], o: &PeerBenchOptions, notes: &[String]) -> Result<()> {
    outln!(
        "Occluder rasterization at 1920x1080, one thread, CPU time per frame (clear + render), \
         median of {} rounds x {} samples (fastest-slowest; a sample is the mean of as many \
         renderings as last 2 ms). `peer/ours`: the side's median time \
         over ours with the CPU's best kernel (above 1: ours is faster); on a CPU with \
         AVX-512 ours also runs its AVX2 kernel, the one of CPUs without it.\n",
        o.rounds,
        o.reps
    );
    for note in notes {
        outln!("({note}.)\n");
    }
    outln!("| set | triangles | side | ms (fastest-slowest) | M tris/s | peer/ours | coverage check: covered ours / peer, pixels agreeing, median depth diff |");
    outln!("|---|---:|---|---:|---:|---:|---|");
    for r in rows {
        let t = &r.timing;
        let check = r.check.map_or(String::new(), |c| {
            format!(
                "{:.2} % / {:.2} %, {:.2} %, {:.2e}",
                100.0 * c.ours_covered,
                100.0 * c.peer_covered,
                100.0 * c.agree,
                c.median_depth_rel_diff
            )
        });
        outln!(
            "| {} | {} | {} | {:.3} ({:.3}-{:.3}) | {:.1} | {:.2} | {check} |",
            r.set,
            r.triangles,
            r.side,
            t.median_s * 1e3,
            t.min_s * 1e3,
            t.max_s * 1e3,
            r.triangles as f64 / t.median_s.max(1e-12) / 1e6,
            r.time_over_ours
        );
    }
    outln!();
    Ok(())
}

fn print_rays(rows: &[RayRow], o: &PeerBenchOptions, tinybvh: bool) -> Result<()> {
    outln!(
        "Closest-hit ray casting, one thread, CPU time, median of {} rounds (build: once per \
         round; each ray set cast {} time(s) per round). `peer/ours`: the backend's median time \
         over ours (above 1: ours is faster). `agree`: rays whose closest hit matches ours \
         (same triangle, distance within 1e-4 relative, or both miss).\n",
        o.rounds,
        o.ray_reps
    );
    if !tinybvh {
        outln!("(No tinybvh harness given (--tinybvh): no tinybvh rows.)\n");
    }
    outln!("| scene | triangles | backend | build s | peer/ours | coherent Mrays/s | peer/ours | agree | incoherent Mrays/s | peer/ours | agree |");
    outln!("|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|");
    let agree = |r: &RayRow| {
        r.agree_with_ours
            .map_or("-".to_string(), |a| format!("{:.2} %", 100.0 * a))
    };
    for build in rows.iter().filter(|r| r.set == "build") {
        let find = |set: &str| {
            rows.iter()
                .find(|r| r.scene == build.scene && r.backend == build.backend && r.set == set)
        };
        let (Some(c), Some(i)) = (find("coherent"), find("incoherent")) else {
            continue;
        };
        outln!(
            "| {} | {} | {} | {:.3} | {:.2} | {:.2} | {:.2} | {} | {:.2} | {:.2} | {} |",
            build.scene,
            build.triangles,
            build.backend,
            build.timing.median_s,
            build.time_over_ours,
            c.mrays,
            c.time_over_ours,
            agree(c),
            i.mrays,
            i.time_over_ours,
            agree(i)
        );
    }
    outln!();
    Ok(())
}
