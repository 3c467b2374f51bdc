//! `sightline`: which triangles of a 3D scene can be seen — from a view cell, from a point, per
//! frame. This binary only parses arguments, shows progress and prints results; the algorithms
//! live in the library crates.

// First: its `outln!` macro is used by the modules after it.
#[macro_use]
mod stdout;

mod args;
mod commands;
mod cull_scenes;
mod errors;
mod features;
#[cfg(feature = "gpu")]
mod headless;
mod limits;
mod output;
mod output_lock;
mod progress;

use std::io::Write;
use std::process::ExitCode;

use clap::{CommandFactory, FromArgMatches, Subcommand};

/// sightline — 3D visibility toolkit: potentially visible sets, exact and conservative
/// from-point visibility, and run-time occlusion culling.
///
/// SCENE arguments are a file (.obj, .ply, .gltf, .glb, .stl, .bsp, optionally .gz) or a
/// procedural spec `procedural:NAME[?seed=S&size=N]` with NAME one of city, rooms, canyon,
/// boxes, spheres (size = approximate triangle count). Without SCENE, commands use the embedded
/// default scene `procedural:city`.
///
/// Exit status: 0 on success, 1 on an error, 2 for invalid arguments (`pvs diff`: 1 when the
/// sets differ, 2 on an error). A closed stdout pipe (`| head`) ends a command quietly with 0.
/// Outputs that are inputs are refused; sizes (cells, frames, pixels) are checked against
/// stated limits before anything is allocated.
#[derive(clap::Parser, Debug)]
#[command(name = "sightline", version, about, long_about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Print triangle/vertex/object counts, bounds and the validation report of a scene.
    Info(commands::info::Args),
    /// Render a scene with the reference rasterizer to a PNG (shaded or triangle-id colours).
    Render(commands::render::Args),
    /// Write a scene as loaded (triangle order = ids) to .ply, .obj or .glb.
    Convert(commands::convert::Args),
    /// Measure throughput (ray casting, rasterization) side by side with the baselines.
    Bench(commands::bench::Args),
    /// Run-time occlusion culling over a camera path with moving objects: the uniform-grid
    /// method and its baselines, objects drawn, queries, culling time and measured popping.
    Cull(commands::cull::Args),
    /// Potentially visible sets from view cells: bake, show, diff, compare with Quake 3's.
    Pvs(commands::pvs::Args),
    /// Measure the pixel error of a .pvs file (the GVS++ paper's metric).
    Eval(commands::eval::Args),
    /// Which triangles are visible from a point: reference rasterizer, --conservative (RV,
    /// bounded memory) or --exact.
    Visible(commands::visible::Args),
    /// Write a self-contained HTML report of a .pvs file: per-cell PVS size and pixel error,
    /// worst views, convergence plots, a map of the cells.
    Report(commands::report::Args),
    /// Run the main job on the embedded default scene and write `sightline-report/`.
    Demo(commands::demo::Args),
    /// Interactive viewer (fly camera, culling methods on keys 1..4, HUD with the live popping
    /// counter; keys in its --help), or headless with --frames N --out DIR (PNG frames and
    /// frames.json).
    View(commands::view::Args),
}

fn main() -> ExitCode {
    // The long version names the optional features built in (a headless build has none);
    // clap wants a 'static text, and this one string lives as long as the process anyway.
    let long_version: &'static str = Box::leak(features::long_version().into_boxed_str());
    let matches = Cli::command()
        .long_version(long_version)
        .mut_subcommand("view", commands::view::with_controls_help)
        .get_matches();
    let cli = match Cli::from_arg_matches(&matches) {
        Ok(cli) => cli,
        Err(e) => e.exit(),
    };
    let result = match stdout::catch_print_panics(|| run(cli.command)) {
        Ok(result) => result.and_then(|()| Ok(stdout::flush_stdout()?)),
        Err(stdout::PrintFailure::Stdout(e)) => Err(e.into()),
        Err(stdout::PrintFailure::Stderr(e)) => {
            // Nothing can be reported where stderr is gone.
            return if e.kind() == std::io::ErrorKind::BrokenPipe {
                ExitCode::SUCCESS
            } else {
                ExitCode::FAILURE
            };
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        // The reader of the pipe has gone (`| head`): a quiet, successful end (see `stdout`).
        Err(e)
            if e.downcast_ref::<stdout::StdoutError>()
                .is_some_and(|s| s.is_broken_pipe()) =>
        {
            ExitCode::SUCCESS
        }
        Err(e) => {
            let message = errors::error_chain(&e);
            if !message.is_empty() {
                // `eprintln!` would panic when stderr is gone too; then only the status is left.
                let _ = writeln!(std::io::stderr(), "error: {message}");
            }
            match e.downcast_ref::<errors::ExitStatus>() {
                Some(status) => ExitCode::from(status.0),
                None => ExitCode::FAILURE,
            }
        }
    }
}

fn run(command: Command) -> anyhow::Result<()> {
    match command {
        Command::Info(a) => commands::info::run(a),
        Command::Render(a) => commands::render::run(a),
        Command::Convert(a) => commands::convert::run(a),
        Command::Bench(a) => commands::bench::run(a),
        Command::Cull(a) => commands::cull::run(a),
        Command::Pvs(a) => commands::pvs::run(a),
        Command::Eval(a) => commands::eval::run(a),
        Command::Visible(a) => commands::visible::run(a),
        Command::Report(a) => commands::report::run(a),
        Command::Demo(a) => commands::demo::run(a),
        Command::View(a) => commands::view::run(a),
    }
}
