//! `docs/getting-started.md`, run as printed: every ```sh block marked `<!-- tested -->` runs,
//! in order, in one temporary folder, under `sh -e` with this build's `sightline` first on the
//! `PATH`, after the budgets of [`SMALLER`] are shrunk (each replacement must apply, so the
//! doc and this table cannot drift apart silently). The only blocks not run are marked
//! `<!-- not tested: ... -->` and may only build or install the tool ([`UNTESTED_COMMANDS`]).
//! Then the files the walkthrough says it makes are checked.

#![cfg(unix)]
// Test helpers panic on broken fixtures; that is the failure report we want.
#![allow(clippy::unwrap_used)]

use std::path::Path;
use std::process::{Command, Output};

const DOC: &str = include_str!("../../../docs/getting-started.md");

/// The walkthrough's budgets as printed, and as run here (a few seconds in all). Bakes the doc
/// runs to convergence get a ray budget: a cell of the stand-in level converges after about
/// 10 M rays, 10-20 s each on two cores, so the test cannot check `converged: true`; it checks
/// that a budgeted bake says and records `converged: false`.
const SMALLER: &[(&str, &str)] = &[
    ("--rays 1000000", "--rays 20000"),
    ("-o probe.pvs", "--rays 20000 -o probe.pvs"),
    ("-o shipped.pvs", "--rays 20000 -o shipped.pvs"),
    ("--views 200 --size 512", "--views 3 --size 32"),
    (
        "-o report\n",
        "-o report --views 2 --size 32 --budgets 5000 --budget-cells 1\n",
    ),
    (
        "-o shipped-report\n",
        "-o shipped-report --views 2 --size 32 --budgets none\n",
    ),
];

/// What the blocks marked `<!-- not tested -->` may run: building or installing the tool.
const UNTESTED_COMMANDS: &[&str] = &["cargo install ", "cargo build ", "cargo run "];

/// A fenced ```sh block of the doc and whether it is marked to run.
struct Block {
    tested: bool,
    text: String,
}

/// The ```sh blocks of `doc`, each with the marker on the line before it. Panics on a fenced
/// block of another language or on a block without a marker.
fn blocks(doc: &str) -> Vec<Block> {
    let lines: Vec<&str> = doc.lines().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < lines.len() {
        let Some(lang) = lines[i].strip_prefix("```") else {
            i += 1;
            continue;
        };
        assert_eq!(lang, "sh", "line {}: only ```sh blocks here", i + 1);
        let marker = if i > 0 { lines[i - 1] } else { "" };
        let tested = match marker {
            "<!-- tested -->" => true,
            m if m.starts_with("<!-- not tested: ") => false,
            m => panic!("line {}: a ```sh block needs a marker, found {m:?}", i + 1),
        };
        let end = (i + 1..lines.len())
            .find(|&j| lines[j] == "```")
            .unwrap_or_else(|| panic!("line {}: unclosed block", i + 1));
        let text = lines[i + 1..end].join("\n") + "\n";
        out.push(Block { tested, text });
        i = end + 1;
    }
    out
}

/// `text` with every replacement of [`SMALLER`] applied; `used[k]` counts the matches of
/// replacement `k`.
fn shrink(text: &str, used: &mut [usize]) -> String {
    let mut text = text.to_string();
    for (k, (from, to)) in SMALLER.iter().enumerate() {
        used[k] += text.matches(from).count();
        text = text.replace(from, to);
    }
    text
}

/// The most rays per cell a bake here may cast (a bake without `--rays` converges: seconds
/// per cell).
const MAX_TEST_RAYS: u64 = 20_000;

/// Every bake of `script` has a ray budget of at most [`MAX_TEST_RAYS`] (a new bake in the
/// walkthrough needs its entry in [`SMALLER`]).
fn assert_small_budgets(script: &str) {
    for line in script.lines().filter(|l| l.contains("sightline pvs bake")) {
        let words: Vec<&str> = line.split_whitespace().collect();
        let rays = words
            .windows(2)
            .find(|w| w[0] == "--rays")
            .map(|w| w[1].parse::<u64>().unwrap());
        assert!(
            rays.is_some_and(|r| r <= MAX_TEST_RAYS),
            "a bake too long for the test (add it to SMALLER): {line}"
        );
    }
}

/// Runs `script` with `sh -e` in `dir`, `bin` first on the PATH.
fn run_block(script: &str, dir: &Path, bin: &Path) -> Output {
    let path = std::env::var_os("PATH").unwrap_or_default();
    let mut paths = vec![bin.to_path_buf()];
    paths.extend(std::env::split_paths(&path));
    Command::new("sh")
        .args(["-e", "-c", script])
        .current_dir(dir)
        .env("PATH", std::env::join_paths(paths).unwrap())
        .output()
        .expect("sh runs")
}

/// `pvs show FILE --json` of a file the walkthrough wrote, parsed.
fn show(dir: &Path, file: &str) -> serde_json::Value {
    let o = Command::new(env!("CARGO_BIN_EXE_sightline"))
        .args(["pvs", "show", file, "--json"])
        .current_dir(dir)
        .output()
        .unwrap();
    assert!(o.status.success(), "pvs show {file}: {o:?}");
    serde_json::from_slice(&o.stdout).unwrap()
}

/// The `converged` flags of a file's cells.
fn converged(pvs: &serde_json::Value) -> Vec<Option<bool>> {
    pvs["metadata"]["cells"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["converged"].as_bool())
        .collect()
}

#[test]
fn the_walkthrough_runs_as_printed() {
    let blocks = blocks(DOC);
    for b in blocks.iter().filter(|b| !b.tested) {
        for line in b.text.lines().filter(|l| !l.trim().is_empty()) {
            assert!(
                UNTESTED_COMMANDS.iter().any(|c| line.starts_with(c)),
                "an untested command in docs/getting-started.md: {line:?}"
            );
        }
    }
    let dir = tempfile::tempdir().unwrap();
    let bin = tempfile::tempdir().unwrap();
    std::os::unix::fs::symlink(
        env!("CARGO_BIN_EXE_sightline"),
        bin.path().join("sightline"),
    )
    .unwrap();
    let mut used = vec![0; SMALLER.len()];
    // (the block as printed, its stdout, its stderr)
    let mut runs = Vec::new();
    for b in blocks.iter().filter(|b| b.tested) {
        let script = shrink(&b.text, &mut used);
        assert_small_budgets(&script);
        let o = run_block(&script, dir.path(), bin.path());
        let (out, err) = (
            String::from_utf8_lossy(&o.stdout).into_owned(),
            String::from_utf8_lossy(&o.stderr).into_owned(),
        );
        assert!(
            o.status.success(),
            "this block of docs/getting-started.md failed:\n{script}\nstdout:\n{out}\nstderr:\n{err}"
        );
        assert!(!err.contains("panicked"), "{err}");
        runs.push((b.text.clone(), out, err));
    }
    assert!(runs.len() >= 7, "{} tested blocks", runs.len());
    for ((from, _), n) in SMALLER.iter().zip(&used) {
        assert!(
            *n > 0,
            "{from:?} is no longer in the walkthrough: update SMALLER"
        );
    }
    check_outputs(dir.path(), &runs);
}

/// The output of the tested block whose text contains `needle`: (stdout, stderr).
fn output_of<'a>(runs: &'a [(String, String, String)], needle: &str) -> (&'a str, &'a str) {
    let run = runs.iter().find(|(text, ..)| text.contains(needle));
    let (_, out, err) = run.unwrap_or_else(|| panic!("no tested block runs {needle:?}"));
    (out, err)
}

/// The files and messages the walkthrough promises.
fn check_outputs(dir: &Path, runs: &[(String, String, String)]) {
    // Section 2: the level, its checks, an overview image; the OBJ copy's axis as given.
    let (out, _) = output_of(runs, "sightline info level.glb");
    assert!(out.contains("sightline"), "--version: {out}");
    assert!(
        out.lines()
            .any(|l| l.starts_with("up axis") && l.ends_with('Z')),
        "{out}"
    );
    let png = std::fs::read(dir.join("overview.png")).unwrap();
    assert!(png.starts_with(b"\x89PNG"), "overview.png is a PNG");
    let (out, _) = output_of(runs, "sightline info level.obj --up-axis z");
    assert!(
        out.lines()
            .any(|l| l.starts_with("up axis") && l.ends_with('Z')),
        "{out}"
    );
    // Section 3: the two hand-placed cells.
    assert_eq!(show(dir, "rooms.pvs")["cells"].as_array().unwrap().len(), 2);
    // Section 4: a budgeted bake warns and records unconverged cells.
    let (_, err) = output_of(runs, "-o level.pvs");
    assert!(
        err.contains("16 of 16 cells stopped on the budget"),
        "{err}"
    );
    let level = show(dir, "level.pvs");
    assert_eq!(converged(&level), vec![Some(false); 16]);
    let probe: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("probe.json")).unwrap()).unwrap();
    let curve = probe["metadata"]["cells"][0]["convergence"]
        .as_array()
        .unwrap();
    assert!(curve.len() > 1, "a convergence curve: {curve:?}");
    // Section 5: the error table over every cell, the report page.
    let (out, _) = output_of(runs, "sightline eval level.glb");
    assert!(out.contains("mean over 16 cells"), "{out}");
    let page = std::fs::read_to_string(dir.join("report/index.html")).unwrap();
    assert!(
        page.contains("converged cells"),
        "the report shows convergence"
    );
    assert!(
        page.contains("GVS++ against RAND"),
        "the equal-budget section"
    );
    // Section 5: the two-sided file; its bounds miss no pixel of any view.
    let (out, _) = output_of(runs, "--side bound");
    assert!(out.contains("two-sided: conservative bounds"), "{out}");
    assert!(
        out.contains("mean over 16 cells: 0.00 erroneous pixels") && out.contains("max 0,"),
        "{out}"
    );
    let two_sided = show(dir, "level-two-sided.pvs");
    let cells = two_sided["cells"].as_array().unwrap();
    assert!(
        cells.iter().all(|c| c["gap"].is_array()),
        "every cell has a bound"
    );
    // Section 6: the incremental rebake kept some cells.
    let (out, _) = output_of(runs, "--since level.pvs");
    assert!(
        out.contains("incremental:") && out.contains("kept"),
        "{out}"
    );
    assert_eq!(
        show(dir, "level-v2.pvs")["cells"].as_array().unwrap().len(),
        16
    );
    // Section 7: the shipped file has the edit's object, and its report exists.
    let shipped = show(dir, "shipped.pvs");
    assert_eq!(shipped["cells"].as_array().unwrap().len(), 16);
    let (out, _) = output_of(runs, "sightline pvs show shipped.pvs --objects");
    assert!(
        out.contains("partition"),
        "the added object is listed: {out}"
    );
    assert!(dir.join("shipped-report/index.html").is_file());
}

#[test]
fn blocks_are_found_with_their_markers() {
    let doc = "text\n<!-- tested -->\n```sh\na\nb\n```\n<!-- not tested: x -->\n```sh\nc\n```\n";
    let b = blocks(doc);
    assert_eq!(b.len(), 2);
    assert!(b[0].tested && !b[1].tested);
    assert_eq!(b[0].text, "a\nb\n");
    assert_eq!(b[1].text, "c\n");
    let unmarked = std::panic::catch_unwind(|| blocks("```sh\na\n```\n"));
    assert!(unmarked.is_err(), "an unmarked block is refused");
}
