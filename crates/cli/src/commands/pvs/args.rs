//! The arguments of `sightline pvs` and its subcommands (clap). A leaf: the subcommands
//! take their arguments from here.

use std::path::PathBuf;

use sightline_point::rv::BAKE_METHODS;
use sightline_region::methods::MethodOverrides;
use sightline_region::reachable::DEFAULT_STEP;

use crate::args::SceneArgs;
use crate::commands::bench::{Device, GpuCasterChoice};

/// Arguments of `sightline pvs`.
#[derive(clap::Args, Debug)]
pub(crate) struct Args {
    #[command(subcommand)]
    pub(crate) what: What,
}

#[derive(clap::Subcommand, Debug)]
pub(crate) enum What {
    /// Compute the PVS of view cells and write a .pvs file.
    Bake(Box<BakeArgs>),
    /// Print a .pvs file's header, metadata, object count and per-cell triangle and object set
    /// sizes (--objects: the object table).
    Show(ShowArgs),
    /// Join the shard files of a bake (`pvs bake --shard I/N`) into one .pvs, cells in order.
    Merge(MergeArgs),
    /// Merge neighbouring cells whose PVSs are nearly the same (fewer cells at run time): two
    /// axis-aligned cells sharing a whole face become their union box with the union of their
    /// sets (exactly the PVS of the joined region), most similar first, while the Jaccard
    /// similarity of the sets is at least --min-similarity and the larger set grows by at most
    /// --max-growth. Per-cell statistics are summed; `metadata.cells[i].merged_from` lists the
    /// original cells.
    MergeCells(MergeCellsArgs),
    /// Give every cell of a baked .pvs a conservative bound (what `pvs bake --bound` does
    /// after sampling): the file then carries, per cell, the sampled set (surely visible) and a
    /// superset that misses no visible triangle; the gap between them is printed per cell.
    Bound(BoundArgs),
    /// Compare two .pvs files of the same scene cell by cell. Exit status as `diff`: 0 when
    /// every cell's set is equal, 1 when some differ (with a summary line: cells differing,
    /// triangles only in the second file = added, only in the first = removed), 2 on errors.
    Diff(DiffArgs),
    /// Compare a PVS baked on a Quake 3 map's leaves (--q3-leaves) with the map's own compiled
    /// cluster PVS, cluster by cluster.
    CompareQ3(CompareQ3Args),
}

/// Where the view cells come from (exactly one source).
#[derive(clap::Args, Debug)]
pub(crate) struct CellArgs {
    /// JSON or TOML file with `cells`: `{"min": [..], "max": [..]}` or
    /// `{"center", "axes", "half_extents"}` entries.
    #[arg(long, value_name = "FILE")]
    pub(crate) cells: Option<PathBuf>,
    /// A cell on the command line: `box:MINX,MINY,MINZ,MAXX,MAXY,MAXZ` or `point:X,Y,Z,R`
    /// (repeatable).
    #[arg(long, value_name = "SPEC", allow_hyphen_values = true)]
    pub(crate) cell: Vec<String>,
    /// A regular grid of NX,NY,NZ cells over --bounds (default: the scene bounds); at most
    /// 2^20 cells in all (every cell's set stays in memory until the file is written).
    #[arg(long, value_name = "NX,NY,NZ")]
    pub(crate) grid: Option<String>,
    /// Region of --grid: MINX,MINY,MINZ,MAXX,MAXY,MAXZ.
    #[arg(
        long,
        value_name = "MINX,MINY,MINZ,MAXX,MAXY,MAXZ",
        allow_hyphen_values = true
    )]
    pub(crate) bounds: Option<String>,
    /// With --grid: drop cells whose centre is inside solid geometry.
    #[arg(long)]
    pub(crate) skip_solid: bool,
    /// Cells where players walk, for mesh levels: SIZE x SIZE columns over the scene, and in
    /// each a cell at eye height (--eye-height) over every floor found there: an upward-facing
    /// surface (at most 45 degrees steep) with --head-room free above it and room for a
    /// player's 0.3-unit footprint. Several storeys give several cells. Lengths in scene units
    /// (the defaults assume metres); --write-cells saves them for editing.
    #[arg(long, value_name = "SIZE")]
    pub(crate) walkable: Option<f32>,
    /// With --walkable: eye heights above the floor that a cell spans.
    #[arg(long, value_name = "LOW,HIGH", default_value = "1.2,1.8")]
    pub(crate) eye_height: String,
    /// With --walkable: free height a floor needs above it.
    #[arg(long, value_name = "H", default_value_t = 2.0)]
    pub(crate) head_room: f32,
    /// Also write the cells (from any source) to FILE as a cells file (JSON) before baking:
    /// edit it and bake again with --cells FILE.
    #[arg(long, value_name = "FILE")]
    pub(crate) write_cells: Option<PathBuf>,
    /// Quake 3 maps: one cell per BSP leaf box (cells of a cluster together form it). Ray
    /// origins stay inside the leaf's cluster and in the space reachable from the map's spawn
    /// points; leaves without reachable space are not baked (see --include-unreachable).
    #[arg(long)]
    pub(crate) q3_leaves: bool,
    /// Quake 3 maps: one cell per cluster (the bounding box of its leaves; ray origins stay
    /// inside the cluster and in reachable space, as for --q3-leaves).
    #[arg(long)]
    pub(crate) q3_clusters: bool,
    /// With --q3-leaves or --q3-clusters: only these clusters (comma-separated).
    #[arg(long, value_name = "C1,C2,..", value_delimiter = ',')]
    pub(crate) clusters: Vec<u32>,
    /// With --q3-leaves or --q3-clusters: bake every cell, with origins anywhere in the cell's
    /// cluster (the rule before reachable space: also inside detail brushes, behind patches and
    /// in sealed voids, where no player can be).
    #[arg(long)]
    pub(crate) include_unreachable: bool,
    /// With --q3-leaves or --q3-clusters: lattice step, in map units, of the reachable space
    /// (the free space flood-filled from the spawn points; a player box is 32 x 32 x 56).
    /// Smaller finds narrower passages and costs 8x the memory and time per halving; the
    /// lattice is capped at 2^28 points.
    #[arg(long, value_name = "UNITS", default_value_t = DEFAULT_STEP, allow_hyphen_values = true)]
    pub(crate) reach_step: f32,
    /// Mesh scenes: let ray origins lie anywhere in the cells. By default each cell is split
    /// into 8x8x8 voxels, and voxels lying wholly inside closed geometry (their centre and
    /// corners all inside: most axis rays from them hit the back of a triangle) give no
    /// origins, so rays from inside walls and sealed rooms do not add triangles no camera sees.
    /// The bake reports cells that reach into solid geometry. Quake 3 cells use their BSP
    /// instead (see --include-unreachable).
    #[arg(long)]
    pub(crate) origins_anywhere: bool,
}

#[derive(clap::Args, Debug)]
pub(crate) struct BakeArgs {
    #[command(flatten)]
    pub(crate) scene: SceneArgs,
    #[command(flatten)]
    pub(crate) cells: CellArgs,
    /// The method: `gvs++` (the default), `gvs`, `rand` and `raster` sample the cell with rays
    /// and give aggressive sets (small; what they miss is measured by `eval`); `conservative`
    /// casts no rays and gives RV's from-region set: every triangle that no single large convex
    /// occluder hides from the whole cell, and for Quake 3 leaf and cluster cells only those
    /// the cell may see through the map's portals (never misses a visible triangle; typically
    /// several times larger in cities, 1.4-2.6x on the shared maps' clusters; --rays and
    /// --time do not apply).
    #[arg(long, default_value = "gvs++",
        value_parser = clap::builder::PossibleValuesParser::new(BAKE_METHODS))]
    pub(crate) method: String,
    /// Ray budget per cell (RASTER counts 6 R² per cube map). GVS++ casts batches of 16,384
    /// rays, each of the kind (random, border, reverse or neighbour sampling) that lately
    /// found the most new triangles per ray, and keeps a budget to within one exploration step
    /// (about 340 rays at the defaults). Without --rays and --time, GVS++ runs until the last
    /// 10^7 rays found fewer than --termination new triangles, GVS its paper's rounds until
    /// its rule holds, RAND casts 10M rays, RASTER renders 64 cube maps. A GVS/GVS++ cell whose budget runs out before its
    /// termination rule held is not converged: the bake warns and the file records
    /// `converged: false` for it. How much is enough depends on the cell: a room-sized cell of
    /// an indoor level converges after tens of millions of rays (55M for one of the house
    /// scene's), a street cell of a city after a few million; bake a few cells without a
    /// budget first to see.
    #[arg(long)]
    pub(crate) rays: Option<u64>,
    /// Time budget per cell in milliseconds (wall clock: cells bake in parallel and share the
    /// cores; results under a time budget are not reproducible, use --rays for that).
    #[arg(long, value_name = "MS")]
    pub(crate) time: Option<u64>,
    /// Seed of every random choice (same seed, same result).
    #[arg(long, default_value_t = 1)]
    pub(crate) seed: u64,
    /// `gpu` casts the bake's rays on the GPU (see `sightline bench trace --device gpu`), with
    /// the caster `--gpu-caster` chooses: hardware ray queries where the adapter has them, else
    /// wgpu compute shaders. The compute caster's hits are bit-identical to the CPU caster's
    /// on adapters with `SHADER_F64`, so its PVS is a CPU bake's for the same seed and ray
    /// budget; ray queries may differ where a ray decides at a tie or an edge within rounding.
    /// `--gpu-cells` cells bake at once and their rays go to the GPU together.
    #[arg(long, value_enum, default_value_t = Device::Cpu)]
    pub(crate) device: Device,
    /// With `--device gpu`: `auto` (ray queries where the adapter has them, else compute),
    /// `compute` (bit-identical to a CPU bake) or `ray-query`.
    #[arg(long, value_enum, default_value_t = GpuCasterChoice::Auto)]
    pub(crate) gpu_caster: GpuCasterChoice,
    /// With `--device gpu`: cells baked at once (on as many threads), whose batches of rays
    /// are gathered into one GPU batch, so that many small cells still give the GPU large
    /// batches (the sets are the same for any value). 1: each cell's batches go alone, cells
    /// on the bake's threads (`--threads`).
    #[arg(long, value_name = "N", default_value_t = 16,
          value_parser = clap::value_parser!(u16).range(1..=1024))]
    pub(crate) gpu_cells: u16,
    // The methods' parameters (`--n-rand` to `--raster-resolution`): one list in the region
    // crate, which the Python `Method` takes as keywords too.
    #[command(flatten)]
    pub(crate) method_overrides: MethodOverrides,
    /// Output .pvs file (written atomically). While baking, finished cells are kept in
    /// OUTPUT.checkpoint; rerunning the same command resumes from it.
    #[arg(short, long)]
    pub(crate) output: PathBuf,
    /// Discard an existing checkpoint of OUTPUT instead of resuming from it.
    #[arg(long)]
    pub(crate) restart: bool,
    /// Least seconds between checkpoint writes (the first finished cell and the end are always
    /// written).
    #[arg(long, default_value_t = 2.0, value_name = "S")]
    pub(crate) checkpoint_every: f64,
    /// Bake only shard I of N: the cells whose index modulo N is I. Join the shard files with
    /// `sightline pvs merge`.
    #[arg(long, value_name = "I/N")]
    pub(crate) shard: Option<String>,
    /// Incremental rebake: reuse the sets of this earlier .pvs (baked with the same cells,
    /// method, parameters, seed and budget on --old-scene) for every cell the scene edit cannot
    /// change, and rebake only the others.
    #[arg(long, value_name = "OLD.pvs", requires = "old_scene")]
    pub(crate) since: Option<PathBuf>,
    /// With --since: the scene the earlier .pvs was baked for (file or procedural spec).
    #[arg(long, value_name = "SCENE", requires = "since")]
    pub(crate) old_scene: Option<String>,
    /// With --since: rays per cell and added object cast in the old scene from the cell
    /// through the added geometry's box; one that gets there unblocked rebakes the cell
    /// (catches geometry seen only against the sky, with no old triangle behind it). 0 skips
    /// the probe.
    #[arg(long, default_value_t = sightline_region::rebake::DEFAULT_PROBE_RAYS, value_name = "N")]
    pub(crate) probe_rays: usize,
    /// Worker threads (default: all cores; at most 4 per core, more are capped with a
    /// warning). Results do not depend on it.
    #[arg(long)]
    pub(crate) threads: Option<usize>,
    /// Print a JSON summary.
    #[arg(long)]
    pub(crate) json: bool,
    /// GVS++ only: bake all cells together, every ray also counting for every other cell it
    /// crosses (ray sharing); --rays and --time stay per cell.
    #[arg(long)]
    pub(crate) share_rays: bool,
    /// Two-sided bake: after the sampled sets, give every cell a conservative bound (RV's
    /// from-region set, through the map's portals for Quake 3 cells, as `--method conservative`,
    /// joined with the sampled set) and store both
    /// (docs/pvs-format.md, "Two-sided files"). The file then says per cell which triangles are
    /// surely visible (the set) and which might be (the bound): the gap is the set's error bar,
    /// shown by `pvs show` and the report, and a renderer can draw either side. Takes about as
    /// long per cell as `--method conservative`. Shards baked with --bound join with
    /// `pvs merge` as they are (all of them with --bound, or none).
    #[arg(long)]
    pub(crate) bound: bool,
    #[command(flatten)]
    pub(crate) bound_options: BoundOptionArgs,
}

/// How the conservative bound is computed (`pvs bake --bound`, `pvs bound`).
#[derive(clap::Args, Debug, Clone, Copy)]
pub(crate) struct BoundOptionArgs {
    /// Occluders of the conservative bound: the largest convex ones by solid angle from the
    /// cell's centre. More give a tighter bound and cost time roughly in proportion.
    #[arg(long, value_name = "N", default_value_t = sightline_point::rv::DEFAULT_MAX_OCCLUDERS)]
    pub(crate) bound_occluders: usize,
    /// Occluder fusion in the conservative bound: levels of halving of each cell, each
    /// smaller box with its own depth map of shrunk occluders, which finds what several
    /// occluders hide together. Each level costs up to twice the time; on munich's street
    /// cells 6 levels take the bound down by 7 % at 4x the time, 8 levels by 14 % at 16x, and
    /// 8 levels with all of munich's occluders (--bound-occluders 50000) by 27.5 % at 50x
    /// (docs/BENCHMARKS.md, "Occluder fusion"). 0 (the default) turns it off.
    #[arg(long, value_name = "LEVELS", default_value_t = sightline_point::rv::DEFAULT_FUSION_SPLITS)]
    pub(crate) bound_fusion_splits: u32,
    /// Pixels per cube-face side of the fusion's depth maps (the last level retests what is
    /// left on maps four times finer).
    #[arg(long, value_name = "PIXELS", default_value_t = sightline_point::rv::DEFAULT_FUSION_RESOLUTION)]
    pub(crate) bound_fusion_resolution: usize,
    /// Quake 3 leaf and cluster cells: leave out the cut by the map's portals (RV's umbrae
    /// alone, 3-18x looser on the shared maps; docs/BENCHMARKS.md, "Two-sided bakes on Quake 3
    /// maps"), to compare the two. Other cells never use the portals.
    #[arg(long)]
    pub(crate) bound_no_portals: bool,
    /// Leave out the back-face rule of closed solids (a face of a closed solid, such as a
    /// building standing on the ground, that faces away from the whole cell is hidden when the
    /// cell is outside the solid; on the shared city cells it takes the bound down by 21 %
    /// (munich) and 41 % (etoile)), to compare the two. docs/BENCHMARKS.md, "Back faces of
    /// closed solids".
    #[arg(long)]
    pub(crate) bound_no_solids: bool,
    /// Occluder fusion of closed solids: also leave out what the union of the closed solids
    /// (whole blocks of houses), shrunk by RADIUS (scene units), hides from a grid of
    /// viewpoints spaced so that every point of the cell lies within the shrink of one
    /// (Wonka et al. 2000). "auto": 1/1000 of the scene's diagonal. A cell that would need
    /// over 1,024 viewpoints at RADIUS uses twice it (or four times, ...). On the shared city
    /// cells it takes the bound from 2.49x to 1.86x the GVS++ sets (etoile) and from 3.58x to
    /// 3.20x (munich, whose cells look over roofs at grazing angles) at 11-35x the bound's
    /// time, about 2.5 s of CPU a 20x20 m cell (docs/BENCHMARKS.md, "Solid fusion shrunk per
    /// axis"). "off" (the default) turns it off. On Quake 3 leaf and cluster cells the map's
    /// solid space is fused this way wherever the portal walk runs out (open areas), at
    /// RADIUS or, with "off" and "auto", 1/1000 of the map's diagonal (czest3ctf: 2.12x →
    /// 1.54x the GVS++ sets; "Two-sided bakes on Quake 3 maps: the map's solid space fused").
    #[arg(long, value_name = "RADIUS|auto|off", default_value = "off", value_parser = solid_fusion)]
    pub(crate) bound_solid_fusion: SolidFusionArg,
}

/// `--bound-solid-fusion`: off, the scene's default radius, or a radius.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum SolidFusionArg {
    Off,
    Auto,
    Radius(f64),
}

fn solid_fusion(text: &str) -> Result<SolidFusionArg, String> {
    match text {
        "off" => Ok(SolidFusionArg::Off),
        "auto" => Ok(SolidFusionArg::Auto),
        _ => match text.parse::<f64>() {
            Ok(r) if r.is_finite() && r > 0.0 => Ok(SolidFusionArg::Radius(r)),
            _ => Err(format!(
                "expected a positive radius, auto or off (got {text})"
            )),
        },
    }
}

/// Arguments of `pvs bound`.
#[derive(clap::Args, Debug)]
pub(crate) struct BoundArgs {
    #[command(flatten)]
    pub(crate) scene: SceneArgs,
    /// The .pvs file baked for SCENE (required; SCENE comes first, as in `eval`).
    #[arg(value_name = "PVS")]
    pub(crate) file: Option<PathBuf>,
    /// Output .pvs file (written atomically; never the input).
    #[arg(short, long)]
    pub(crate) output: PathBuf,
    #[command(flatten)]
    pub(crate) options: BoundOptionArgs,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub(crate) threads: Option<usize>,
    /// Print a JSON summary.
    #[arg(long)]
    pub(crate) json: bool,
}

#[derive(clap::Args, Debug)]
pub(crate) struct MergeArgs {
    /// The shard files (from `pvs bake --shard I/N` with otherwise identical arguments).
    #[arg(required = true)]
    pub(crate) files: Vec<PathBuf>,
    /// Output .pvs file (written atomically).
    #[arg(short, long)]
    pub(crate) output: PathBuf,
    /// Write the merge even when some cells are in none of the files (the result lists its
    /// cells' global indices in `cell_indices`).
    #[arg(long)]
    pub(crate) allow_partial: bool,
    /// Print a JSON summary.
    #[arg(long)]
    pub(crate) json: bool,
}

#[derive(clap::Args, Debug)]
pub(crate) struct MergeCellsArgs {
    /// The .pvs file.
    pub(crate) file: PathBuf,
    /// Output .pvs file (written atomically; never the input).
    #[arg(short, long)]
    pub(crate) output: PathBuf,
    /// The least similarity (shared triangles over triangles of either, 0 to 1) of two cells'
    /// sets that may merge.
    #[arg(long, value_name = "S", default_value_t = 0.9)]
    pub(crate) min_similarity: f64,
    /// The most a merged set may exceed the larger of its two parts, as a fraction (0.1 =
    /// 10 %).
    #[arg(long, value_name = "F", default_value_t = 0.1)]
    pub(crate) max_growth: f64,
    /// Print a JSON summary.
    #[arg(long)]
    pub(crate) json: bool,
}

#[derive(clap::Args, Debug)]
pub(crate) struct ShowArgs {
    /// The .pvs file.
    pub(crate) file: PathBuf,
    /// Also list the object table (name, index, part, triangles, bounds) of a version-2 file.
    #[arg(long)]
    pub(crate) objects: bool,
    /// Print JSON (with the triangle and object ids of every cell, and the object table).
    #[arg(long)]
    pub(crate) json: bool,
}

#[derive(clap::Args, Debug)]
pub(crate) struct DiffArgs {
    /// First .pvs file.
    pub(crate) a: PathBuf,
    /// Second .pvs file.
    pub(crate) b: PathBuf,
    /// Print JSON.
    #[arg(long)]
    pub(crate) json: bool,
}

#[derive(clap::Args, Debug)]
pub(crate) struct CompareQ3Args {
    /// The Quake 3 map (.bsp) the PVS was baked for.
    pub(crate) map: PathBuf,
    /// A .pvs baked with --q3-leaves on that map.
    pub(crate) pvs: PathBuf,
    /// Quake 3 maps: patch tessellation used for the bake.
    #[arg(long, default_value_t = 4)]
    pub(crate) patch_subdivisions: u32,
    /// Also measure the pixel error of both PVSs from this many viewpoints per leaf (inside
    /// the leaf's own cluster), six cube faces each; 0 skips it.
    #[arg(
        long = "views",
        alias = "viewpoints",
        value_name = "N",
        default_value_t = 0
    )]
    pub(crate) viewpoints: usize,
    /// Image size of those views (square: one number, or NxN).
    #[arg(long = "size", alias = "resolution", value_name = "PX", default_value = "256",
        value_parser = crate::args::parse_square_size)]
    pub(crate) resolution: u32,
    /// Print JSON.
    #[arg(long)]
    pub(crate) json: bool,
}
