//! Side by side with peer libraries, the measuring behind `sightline bench peers`: our occlusion
//! buffer against Intel's Masked Occlusion Culling (MOC), our BVH against tinybvh and Embree,
//! on the same occluder sets, scenes and rays (exchanged as the files of [`super::peer_sets`]).
//!
//! Method: one thread on every side, CPU time of that thread (`CLOCK_THREAD_CPUTIME_ID`, so a
//! shared machine's other tenants do not count), several rounds in which every side runs in
//! turn (A, B, A, B, ...), the median of all samples per side. Ours runs in this process, in a
//! one-thread `rayon` pool; a peer runs as a child process (a harness of `bench/peers/`) that
//! stays up for the whole run and answers one JSON line per command on stdin:
//! - MOC harness: `render SET REPS [DEPTH_OUT]` → `{"ns": [..]}` (clear + render per rep);
//! - tinybvh harness: `scene MESH` → `{"triangles": n}`, `rays RAYS` → `{"rays": n}`,
//!   `build` → `{"ns": [n]}`, `trace RAYS REPS [HITS_OUT]` → `{"ns": [..]}`.
//!
//! Errors are `{"error": "..."}`. The first line a harness prints is a greeting with its
//! configuration (e.g. MOC's implementation), returned by [`PeerProcess::spawn`].
//!
//! Sanity checks, printed beside the times: MOC's per-pixel coverage and depth against ours
//! after rendering the same set ([`CoverageCheck`]), and per ray set the fraction of rays on
//! which a ray caster's closest hit agrees with ours (same triangle, distance within 1e-4
//! relative; both missing counts as agreeing).

use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, ChildStdout, Command, Stdio};

use serde::Serialize;
use sightline_core::cpu_time::thread_cpu_ns;
use sightline_core::trace::RayCaster;
use sightline_core::{Hit, Ray, Scene};
use sightline_cull::{Kernel, OcclusionBuffer};

use super::common::{report, sorted, OnProgress, Progress};
use super::peer_sets::{read_depth, read_hits, OccluderSet, PeerSetError};

/// Relative distance tolerance of the hit agreement.
pub const HIT_T_TOLERANCE: f32 = 1e-4;

/// Why a peer comparison failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PeerError {
    /// A harness could not be started.
    #[error("could not start {program}: {source}")]
    Spawn {
        /// The harness.
        program: String,
        /// The error.
        source: std::io::Error,
    },
    /// Talking to a harness failed, or it exited.
    #[error("{peer}: {message}")]
    Pipe {
        /// The harness's name.
        peer: String,
        /// What happened.
        message: String,
    },
    /// A harness answered `{"error": ...}`.
    #[error("{peer} reported: {message}")]
    Peer {
        /// The harness's name.
        peer: String,
        /// Its message.
        message: String,
    },
    /// An exchange file.
    #[error(transparent)]
    Set(#[from] PeerSetError),
    /// The one-thread pool could not be made, or an in-process caster not built.
    #[error("{0}")]
    Local(String),
    /// Zero rounds or repetitions.
    #[error("{0} must be at least 1")]
    Zero(&'static str),
}

/// A running peer harness.
pub struct PeerProcess {
    name: String,
    child: Child,
    stdin: ChildStdin,
    stdout: BufReader<ChildStdout>,
}

impl PeerProcess {
    /// Starts `program args` and reads its greeting line (returned).
    pub fn spawn(
        name: &str,
        program: &Path,
        args: &[&str],
    ) -> Result<(Self, serde_json::Value), PeerError> {
        let mut child = Command::new(program)
            .args(args)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .spawn()
            .map_err(|source| PeerError::Spawn {
                program: program.display().to_string(),
                source,
            })?;
        let (Some(stdin), Some(stdout)) = (child.stdin.take(), child.stdout.take()) else {
            return Err(PeerError::Local("harness pipes missing".into()));
        };
        let mut peer = Self {
            name: name.to_string(),
            child,
            stdin,
            stdout: BufReader::new(stdout),
        };
        let hello = peer.answer()?;
        Ok((peer, hello))
    }

    /// The harness's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Sends one command line and returns the answer.
    pub fn call(&mut self, command: &str) -> Result<serde_json::Value, PeerError> {
        writeln!(self.stdin, "{command}")
            .and_then(|()| self.stdin.flush())
            .map_err(|e| self.pipe(format!("sending {command:?}: {e}")))?;
        self.answer()
    }

    /// The `ns` array of a command's answer.
    pub fn call_ns(&mut self, command: &str) -> Result<Vec<u64>, PeerError> {
        let v = self.call(command)?;
        v.get("ns")
            .and_then(|ns| ns.as_array())
            .and_then(|ns| ns.iter().map(|x| x.as_u64()).collect::<Option<Vec<u64>>>())
            .ok_or_else(|| self.pipe(format!("answer to {command:?} has no ns list: {v}")))
    }

    fn pipe(&self, message: String) -> PeerError {
        PeerError::Pipe {
            peer: self.name.clone(),
            message,
        }
    }

    fn answer(&mut self) -> Result<serde_json::Value, PeerError> {
        let mut line = String::new();
        let n = self
            .stdout
            .read_line(&mut line)
            .map_err(|e| self.pipe(format!("reading: {e}")))?;
        if n == 0 {
            let status = self.child.wait().map(|s| s.to_string()).unwrap_or_default();
            return Err(self.pipe(format!("exited ({status}) without an answer")));
        }
        let v: serde_json::Value = serde_json::from_str(line.trim())
            .map_err(|e| self.pipe(format!("not JSON ({e}): {}", line.trim())))?;
        if let Some(message) = v.get("error").and_then(|m| m.as_str()) {
            return Err(PeerError::Peer {
                peer: self.name.clone(),
                message: message.to_string(),
            });
        }
        Ok(v)
    }
}

/// MOC's SIMD paths that `bench peers` asks its harness for: the harness's argument and the
/// name MOC gives the implementation (`bench/peers/moc_harness.cpp`).
const MOC_PATHS: [(&str, &str); 2] = [("avx2", "AVX2"), ("avx512", "AVX-512")];

/// Starts MOC's harness (`program`) once for each of its SIMD paths. MOC runs the best path
/// the CPU has up to the one asked for, which its harness reports in its greeting
/// (`{"impl": ...}`): each side is named after the implementation that runs ("MOC AVX2"), and
/// a path that would run an implementation already started (AVX-512 asked on a CPU without
/// it) is left out, with a note saying so among the notes returned beside the sides.
pub fn spawn_moc(program: &Path) -> Result<(Vec<PeerProcess>, Vec<String>), PeerError> {
    let mut sides: Vec<PeerProcess> = Vec::new();
    let mut notes = Vec::new();
    for (arg, asked) in MOC_PATHS {
        let (mut side, hello) = PeerProcess::spawn(&format!("MOC {asked}"), program, &[arg])?;
        let runs = hello
            .get("impl")
            .and_then(|v| v.as_str())
            .unwrap_or(asked)
            .to_string();
        let name = format!("MOC {runs}");
        if sides.iter().any(|s| s.name() == name) {
            notes.push(format!(
                "MOC's {asked} path is left out: this CPU runs its {runs} code for it, \
                 measured already"
            ));
            continue;
        }
        if runs != asked {
            notes.push(format!(
                "MOC's {asked} path runs its {runs} code on this CPU"
            ));
        }
        side.name = name;
        sides.push(side);
    }
    Ok((sides, notes))
}

impl Drop for PeerProcess {
    fn drop(&mut self) {
        // Ask it to quit; kill it if it does not read any more.
        if writeln!(self.stdin, "quit").is_err() {
            let _ = self.child.kill();
        }
        let _ = self.child.wait();
    }
}

/// Rounds and repetitions of `sightline bench peers`.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct PeerBenchOptions {
    /// Rounds; every side runs once per round, in turn.
    pub rounds: usize,
    /// Timed samples of occluder renderings per side and round (after one untimed warm-up in
    /// the first round); a sample is one rendering, or the mean of as many as last
    /// [`MIN_SAMPLE_NS`] where one is shorter.
    pub reps: usize,
    /// Casts of each ray set per side and round.
    pub ray_reps: usize,
}

impl PeerBenchOptions {
    /// Fails on zero rounds or repetitions.
    pub fn validate(&self) -> Result<(), PeerError> {
        for (v, what) in [
            (self.rounds, "rounds"),
            (self.reps, "reps"),
            (self.ray_reps, "ray reps"),
        ] {
            if v == 0 {
                return Err(PeerError::Zero(what));
            }
        }
        Ok(())
    }
}

/// Median, fastest and slowest of a side's samples, in seconds.
#[derive(Clone, Copy, Debug, Serialize, Default)]
pub struct Timing {
    /// Median.
    pub median_s: f64,
    /// Fastest.
    pub min_s: f64,
    /// Slowest.
    pub max_s: f64,
    /// Samples.
    pub samples: usize,
}

impl Timing {
    /// The statistics of nanosecond samples (all zero for none).
    pub fn of_ns(ns: &[u64]) -> Self {
        if ns.is_empty() {
            return Self::default();
        }
        let s = sorted(ns.iter().map(|&n| n as f64 * 1e-9).collect());
        let mid = s.len() / 2;
        let median_s = if s.len() % 2 == 1 {
            s[mid]
        } else {
            0.5 * (s[mid - 1] + s[mid])
        };
        Self {
            median_s,
            min_s: s[0],
            max_s: s[s.len() - 1],
            samples: s.len(),
        }
    }
}

/// An occluder set to rasterize: its name, its exchange file and its contents (as read back
/// from the file, so that ours sees exactly what the peers see).
pub struct OccluderCase {
    /// Name in the table, e.g. "random 10 px".
    pub name: String,
    /// The exchange file.
    pub path: PathBuf,
    /// The set.
    pub set: OccluderSet,
}

/// MOC's buffer against ours after the same set: per-pixel coverage and depth.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct CoverageCheck {
    /// Fraction of pixels ours covers (finite depth).
    pub ours_covered: f64,
    /// Fraction of pixels the peer covers (depth above 0).
    pub peer_covered: f64,
    /// Fraction of pixels where both agree on covered or not.
    pub agree: f64,
    /// Median of `|z_ours - z_peer| / z_ours` over pixels both cover.
    pub median_depth_rel_diff: f64,
}

/// One side on one occluder set.
#[derive(Clone, Debug, Serialize)]
pub struct OccluderRow {
    /// The set's name.
    pub set: String,
    /// Its triangles.
    pub triangles: usize,
    /// The side, e.g. "sightline avx2" or "MOC AVX2".
    pub side: String,
    /// Time per rendering (clear + render).
    pub timing: Timing,
    /// Its median time over ours with the CPU's best kernel (above 1: ours is faster); 1 for
    /// that side.
    pub time_over_ours: f64,
    /// Peers only: the coverage check after the first round.
    pub check: Option<CoverageCheck>,
}

/// Renders every case with ours and with every peer (MOC harnesses), `options.rounds` rounds
/// of `options.reps` renderings each, in turn. Depth images of the check go to `scratch`.
pub fn bench_occluders(
    cases: &[OccluderCase],
    peers: &mut [PeerProcess],
    options: &PeerBenchOptions,
    scratch: &Path,
    on: OnProgress<'_>,
) -> Result<Vec<OccluderRow>, PeerError> {
    options.validate()?;
    let mut rows = Vec::new();
    for case in cases {
        let cam = &case.set.camera;
        let mut buffer = OcclusionBuffer::new(cam.width, cam.height);
        // Ours with the CPU's best kernel and, where that is AVX-512, with AVX2 too (the
        // kernel of CPUs without AVX-512, to set beside MOC's AVX2 path); the best runs last,
        // so that the coverage check reads its buffer (every kernel's is the same, bit for bit).
        let best = buffer.kernel();
        let kernels: Vec<Kernel> = if best == Kernel::Avx512 {
            vec![Kernel::Avx2, best]
        } else {
            vec![best]
        };
        let mut ours_ns = vec![Vec::new(); kernels.len()];
        let mut peer_ns = vec![Vec::new(); peers.len()];
        let mut checks = vec![None; peers.len()];
        let path = case.path.display().to_string();
        let mut per_sample = 1;
        for round in 0..options.rounds {
            report(
                on,
                Progress::Peers {
                    what: &case.name,
                    round: round + 1,
                    rounds: options.rounds,
                },
            );
            if round == 0 {
                // One untimed warm-up per kernel, then one more rendering with the best
                // kernel, warm, for the renderings a sample needs.
                for &kernel in &kernels {
                    buffer.set_kernel(kernel);
                    buffer.clear();
                    buffer.render_occluders(&case.set.triangles, cam);
                }
                let t = thread_cpu_ns();
                buffer.clear();
                buffer.render_occluders(&case.set.triangles, cam);
                per_sample = renderings_per_sample(thread_cpu_ns() - t);
            }
            for (&kernel, ns) in kernels.iter().zip(&mut ours_ns) {
                buffer.set_kernel(kernel);
                for _ in 0..options.reps {
                    let t = thread_cpu_ns();
                    for _ in 0..per_sample {
                        buffer.clear();
                        buffer.render_occluders(&case.set.triangles, cam);
                    }
                    ns.push((thread_cpu_ns() - t) / per_sample as u64);
                }
            }
            for (i, peer) in peers.iter_mut().enumerate() {
                let mut command = format!("render {path} {}", options.reps * per_sample);
                let depth_path = scratch.join(format!("depth_{i}.bin"));
                if round == 0 {
                    command += &format!(" {}", depth_path.display());
                }
                let renderings = peer.call_ns(&command)?;
                peer_ns[i].extend(sample_means(&renderings, per_sample));
                if round == 0 {
                    checks[i] = Some(coverage_check(&buffer, &depth_path)?);
                }
            }
        }
        let timings: Vec<Timing> = ours_ns.iter().map(|ns| Timing::of_ns(ns)).collect();
        let ours = timings[timings.len() - 1];
        let triangles = case.set.triangles.len() / 3;
        for (kernel, timing) in kernels.iter().zip(timings).rev() {
            rows.push(OccluderRow {
                set: case.name.clone(),
                triangles,
                side: format!("sightline {}", kernel.name()),
                timing,
                time_over_ours: timing.median_s / ours.median_s,
                check: None,
            });
        }
        for (i, peer) in peers.iter().enumerate() {
            let timing = Timing::of_ns(&peer_ns[i]);
            rows.push(OccluderRow {
                set: case.name.clone(),
                triangles,
                side: peer.name().to_string(),
                timing,
                time_over_ours: timing.median_s / ours.median_s,
                check: checks[i],
            });
        }
    }
    Ok(rows)
}

/// Shortest timed sample of occluder renderings: a rendering of a frame's few hundred
/// occluders takes 0.1-0.5 ms, and single renderings that short gave medians 30 % apart from
/// one run to the next on this shared machine (2026-12-07).
const MIN_SAMPLE_NS: u64 = 2_000_000;

/// Renderings per timed sample for a set whose rendering took `once_ns`: enough for
/// [`MIN_SAMPLE_NS`], at least one.
fn renderings_per_sample(once_ns: u64) -> usize {
    MIN_SAMPLE_NS.div_ceil(once_ns.max(1)).clamp(1, 1000) as usize
}

/// The means of consecutive groups of `per_sample` timings (a last partial group dropped).
fn sample_means(ns: &[u64], per_sample: usize) -> Vec<u64> {
    ns.chunks_exact(per_sample)
        .map(|group| group.iter().sum::<u64>() / per_sample as u64)
        .collect()
}

/// Compares ours (as rendered last) with a peer's depth image.
fn coverage_check(ours: &OcclusionBuffer, peer_depth: &Path) -> Result<CoverageCheck, PeerError> {
    let peer = read_depth(peer_depth)?;
    if (peer.width, peer.height) != (ours.width(), ours.height()) {
        return Err(PeerError::Local(format!(
            "{}: depth image of {}x{}, expected {}x{}",
            peer_depth.display(),
            peer.width,
            peer.height,
            ours.width(),
            ours.height()
        )));
    }
    let (mut ours_n, mut peer_n, mut agree) = (0u64, 0u64, 0u64);
    let mut diffs = Vec::new();
    for y in 0..peer.height {
        for x in 0..peer.width {
            let z = ours.depth_at(x, y).unwrap_or(f32::INFINITY);
            let r = peer.inv_depth[(y * peer.width + x) as usize];
            let (a, b) = (z.is_finite(), r > 0.0);
            ours_n += u64::from(a);
            peer_n += u64::from(b);
            agree += u64::from(a == b);
            if a && b {
                diffs.push(f64::from(((z - 1.0 / r) / z).abs()));
            }
        }
    }
    let n = (peer.width as u64 * peer.height as u64).max(1) as f64;
    let diffs = sorted(diffs);
    Ok(CoverageCheck {
        ours_covered: ours_n as f64 / n,
        peer_covered: peer_n as f64 / n,
        agree: agree as f64 / n,
        median_depth_rel_diff: diffs.get(diffs.len() / 2).copied().unwrap_or(0.0),
    })
}

/// An in-process ray caster: its name and how to build it over a scene.
pub struct InProcessCaster<'a> {
    /// Name in the table.
    pub name: String,
    /// Builds it (called in a one-thread pool; errors as text).
    #[allow(clippy::type_complexity)]
    pub build: Box<dyn Fn(&Scene) -> Result<Box<dyn RayCaster>, String> + Send + Sync + 'a>,
}

/// A ray set: its name ("coherent", "incoherent"), file and rays (read back from the file).
pub struct RaySetCase {
    /// Name.
    pub name: String,
    /// The exchange file.
    pub path: PathBuf,
    /// The rays.
    pub rays: Vec<Ray>,
}

/// One backend on one scene and ray set.
#[derive(Clone, Debug, Serialize)]
pub struct RayRow {
    /// The scene.
    pub scene: String,
    /// Its triangles.
    pub triangles: usize,
    /// The backend.
    pub backend: String,
    /// The ray set ("build" for the build row).
    pub set: String,
    /// Rays in the set (0 for the build row).
    pub rays: usize,
    /// Time per cast of the set, or per build.
    pub timing: Timing,
    /// Million rays per second at the median (0 for the build row).
    pub mrays: f64,
    /// Its median time over ours (above 1: ours is faster); 1 for ours.
    pub time_over_ours: f64,
    /// Fraction of rays whose closest hit agrees with ours (ray rows of other backends).
    pub agree_with_ours: Option<f64>,
}

/// Per backend: build samples, per ray set cast samples and the first round's hits.
struct Samples {
    name: String,
    build: Vec<u64>,
    cast: Vec<Vec<u64>>,
    hits: Vec<Vec<Hit>>,
}

/// Builds and casts on one scene: every in-process caster (the first is ours, the reference of
/// the ratios and the agreement) and the tinybvh harness, each built once per round (timed)
/// and casting every ray set `ray_reps` times per round, in turn. The scene must already be
/// loaded in the harness (`scene MESH`); hit files go to `scratch`.
#[allow(clippy::too_many_arguments)]
pub fn bench_rays(
    scene_name: &str,
    scene: &Scene,
    sets: &[RaySetCase],
    casters: &[InProcessCaster<'_>],
    mut tinybvh: Option<&mut PeerProcess>,
    options: &PeerBenchOptions,
    scratch: &Path,
    on: OnProgress<'_>,
) -> Result<Vec<RayRow>, PeerError> {
    options.validate()?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .map_err(|e| PeerError::Local(format!("one-thread pool: {e}")))?;
    let new = |name: &str| Samples {
        name: name.to_string(),
        build: Vec::new(),
        cast: vec![Vec::new(); sets.len()],
        hits: vec![Vec::new(); sets.len()],
    };
    let mut samples: Vec<Samples> = casters.iter().map(|c| new(&c.name)).collect();
    if let Some(peer) = tinybvh.as_deref_mut() {
        samples.push(new(peer.name()));
        for set in sets {
            peer.call(&format!("rays {}", set.path.display()))?;
        }
    }
    for round in 0..options.rounds {
        report(
            on,
            Progress::Peers {
                what: scene_name,
                round: round + 1,
                rounds: options.rounds,
            },
        );
        for (c, s) in casters.iter().zip(samples.iter_mut()) {
            pool.install(|| in_process_round(c, scene, sets, options.ray_reps, round == 0, s))?;
        }
        if let Some(peer) = tinybvh.as_deref_mut() {
            let s = samples
                .last_mut()
                .ok_or(PeerError::Local("no samples".into()))?;
            s.build.extend(peer.call_ns("build")?);
            for (i, set) in sets.iter().enumerate() {
                let hits_path = scratch.join(format!("hits_{i}.bin"));
                let mut command = format!("trace {} {}", set.path.display(), options.ray_reps);
                if round == 0 {
                    command += &format!(" {}", hits_path.display());
                }
                s.cast[i].extend(peer.call_ns(&command)?);
                if round == 0 {
                    s.hits[i] = read_hits(&hits_path)?;
                }
            }
        }
    }
    Ok(ray_rows(scene_name, scene.triangle_count(), sets, &samples))
}

/// One round of an in-process caster, on the calling (pool) thread: build, then cast.
fn in_process_round(
    c: &InProcessCaster<'_>,
    scene: &Scene,
    sets: &[RaySetCase],
    reps: usize,
    keep_hits: bool,
    s: &mut Samples,
) -> Result<(), PeerError> {
    let t = thread_cpu_ns();
    let caster = (c.build)(scene).map_err(|e| PeerError::Local(format!("{}: {e}", c.name)))?;
    s.build.push(thread_cpu_ns() - t);
    for (i, set) in sets.iter().enumerate() {
        let mut hits = vec![Hit::MISS; set.rays.len()];
        for _ in 0..reps {
            let t = thread_cpu_ns();
            caster.cast(&set.rays, &mut hits);
            s.cast[i].push(thread_cpu_ns() - t);
        }
        if keep_hits {
            s.hits[i] = hits;
        }
    }
    Ok(())
}

/// The table rows: per backend a build row and a row per ray set.
fn ray_rows(
    scene: &str,
    triangles: usize,
    sets: &[RaySetCase],
    samples: &[Samples],
) -> Vec<RayRow> {
    let Some(ours) = samples.first() else {
        return Vec::new();
    };
    let ours_build = Timing::of_ns(&ours.build).median_s;
    let mut rows = Vec::new();
    for s in samples {
        let timing = Timing::of_ns(&s.build);
        rows.push(RayRow {
            scene: scene.to_string(),
            triangles,
            backend: s.name.clone(),
            set: "build".into(),
            rays: 0,
            timing,
            mrays: 0.0,
            time_over_ours: timing.median_s / ours_build,
            agree_with_ours: None,
        });
        for (i, set) in sets.iter().enumerate() {
            let timing = Timing::of_ns(&s.cast[i]);
            let ours_t = Timing::of_ns(&ours.cast[i]).median_s;
            let is_ours = std::ptr::eq(s, ours);
            rows.push(RayRow {
                scene: scene.to_string(),
                triangles,
                backend: s.name.clone(),
                set: set.name.clone(),
                rays: set.rays.len(),
                timing,
                mrays: set.rays.len() as f64 / timing.median_s.max(1e-12) / 1e6,
                time_over_ours: timing.median_s / ours_t,
                agree_with_ours: (!is_ours).then(|| hit_agreement(&ours.hits[i], &s.hits[i])),
            });
        }
    }
    rows
}

/// Fraction of rays on which two casters' closest hits agree: both miss, or the same triangle
/// at distances within [`HIT_T_TOLERANCE`] relative. 0 when the lengths differ.
pub fn hit_agreement(a: &[Hit], b: &[Hit]) -> f64 {
    if a.len() != b.len() || a.is_empty() {
        return 0.0;
    }
    let same = a
        .iter()
        .zip(b)
        .filter(|(x, y)| match (x.is_hit(), y.is_hit()) {
            (false, false) => true,
            (true, true) => {
                x.triangle == y.triangle
                    && (x.t - y.t).abs() <= HIT_T_TOLERANCE * x.t.abs().max(y.t.abs())
            }
            _ => false,
        })
        .count();
    same as f64 / a.len() as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hits_agree_on_the_same_triangle_within_the_tolerance_or_both_missing() {
        let h = |triangle, t| Hit { triangle, t };
        let ours = [h(1, 10.0), h(2, 10.0), Hit::MISS, h(3, 5.0), h(4, 1.0)];
        let peer = [h(1, 10.0005), h(2, 10.01), Hit::MISS, Hit::MISS, h(5, 1.0)];
        assert!((hit_agreement(&ours, &peer) - 0.4).abs() < 1e-12);
        assert_eq!(hit_agreement(&ours, &ours), 1.0);
        assert_eq!(hit_agreement(&ours, &peer[..2]), 0.0);
    }

    #[test]
    fn timing_is_the_median_and_extremes_in_seconds() {
        let t = Timing::of_ns(&[3_000_000_000, 1_000_000_000, 2_000_000_000]);
        assert_eq!(
            (t.median_s, t.min_s, t.max_s, t.samples),
            (2.0, 1.0, 3.0, 3)
        );
        assert_eq!(Timing::of_ns(&[1_000_000_000, 2_000_000_000]).median_s, 1.5);
        assert_eq!(Timing::of_ns(&[]).samples, 0);
    }

    #[test]
    fn short_renderings_are_timed_in_groups() {
        // A 0.2 ms rendering takes 10 to a 2 ms sample, a 5 ms one stands alone, and a
        // rendering timed at 0 ns does not divide by zero.
        assert_eq!(renderings_per_sample(200_000), 10);
        assert_eq!(renderings_per_sample(5_000_000), 1);
        assert_eq!(renderings_per_sample(0), 1000);
        assert_eq!(sample_means(&[1, 3, 5, 7, 100], 2), vec![2, 6]);
        assert_eq!(sample_means(&[4, 8], 1), vec![4, 8]);
    }

    #[test]
    fn zero_rounds_or_reps_are_refused() {
        let o = PeerBenchOptions {
            rounds: 1,
            reps: 0,
            ray_reps: 1,
        };
        assert!(matches!(o.validate(), Err(PeerError::Zero("reps"))));
    }

    /// A stand-in for MOC's harness: greets with the implementation `impl_for_avx512` for an
    /// `avx512` argument (AVX2 for `avx2`), then quits on `quit`.
    #[cfg(unix)]
    fn fake_moc(dir: &Path, impl_for_avx512: &str) -> std::path::PathBuf {
        use std::os::unix::fs::PermissionsExt;
        let path = dir.join(format!("moc_{}", impl_for_avx512.replace('-', "")));
        let script = format!(
            r#"#!/bin/sh
if [ "$1" = avx512 ]; then i='{impl_for_avx512}'; else i=AVX2; fi
printf '{{"impl": "%s", "requested": "%s"}}\n' "$i" "$1"
read line
"#
        );
        std::fs::write(&path, script).unwrap();
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o755)).unwrap();
        path
    }

    #[cfg(unix)]
    #[test]
    fn moc_sides_are_named_after_what_runs_and_a_fallback_is_left_out() {
        let dir = tempfile::tempdir().unwrap();
        // A CPU without AVX-512: MOC runs its AVX2 code for both paths; one side, one note.
        let (sides, notes) = spawn_moc(&fake_moc(dir.path(), "AVX2")).unwrap();
        let names: Vec<&str> = sides.iter().map(|s| s.name()).collect();
        assert_eq!(names, ["MOC AVX2"]);
        assert_eq!(notes.len(), 1, "{notes:?}");
        assert!(notes[0].contains("AVX-512 path is left out"), "{notes:?}");
        // A CPU with AVX-512: both sides, no note.
        let (sides, notes) = spawn_moc(&fake_moc(dir.path(), "AVX-512")).unwrap();
        let names: Vec<&str> = sides.iter().map(|s| s.name()).collect();
        assert_eq!(names, ["MOC AVX2", "MOC AVX-512"]);
        assert!(notes.is_empty(), "{notes:?}");
    }

    #[test]
    fn a_missing_harness_is_a_spawn_error() {
        let r = PeerProcess::spawn("x", Path::new("/nonexistent/harness"), &[]);
        assert!(matches!(r, Err(PeerError::Spawn { .. })));
    }
}
