//! End-to-end tests of `sightline report` (and the demo's page) in a real headless browser:
//! Debian's `chromium` loads the page from disk, and the tests read back its DOM, its console
//! and a screenshot. Chromium is required: without it these tests fail and say how to install
//! it (`apt-get install -y chromium`; `.ci/run` does).

// Test helpers panic on broken fixtures; that is the failure report we want.
#![allow(clippy::unwrap_used)]

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use common::{assert_fails_with, sightline, stderr};

const SCENE: &str = "procedural:city?size=3000";

/// The chromium binary (`$SIGHTLINE_CHROMIUM` or `chromium` on the PATH), or a loud failure.
fn chromium() -> PathBuf {
    let bin = std::env::var_os("SIGHTLINE_CHROMIUM")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("chromium"));
    match Command::new(&bin).arg("--version").output() {
        Ok(o) if o.status.success() => bin,
        other => panic!(
            "\n\n*** The report tests need a headless browser: `{}` could not be run ({other:?}).\n\
             *** Install Debian's chromium: `sudo apt-get install -y chromium` (.ci/run does),\n\
             *** or point SIGHTLINE_CHROMIUM at a chromium binary.\n\n",
            bin.display()
        ),
    }
}

/// Runs headless chromium on `page` with `args` added, in a fresh profile, killing it after
/// 90 s (a hung browser must fail the test, not hang it).
fn run_chromium(page: &Path, args: &[&str]) -> Output {
    run_chromium_at(page, "", args)
}

/// [`run_chromium`] on the page's address with `fragment` (`#...`) appended.
fn run_chromium_at(page: &Path, fragment: &str, args: &[&str]) -> Output {
    let profile = tempfile::tempdir().unwrap();
    let url = format!(
        "file://{}{fragment}",
        page.canonicalize().unwrap().display()
    );
    let logs = tempfile::tempdir().unwrap();
    let (out_path, err_path) = (logs.path().join("stdout"), logs.path().join("stderr"));
    let mut child = Command::new(chromium())
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--disable-quic",
            "--enable-logging=stderr",
            "--v=0",
        ])
        .arg(format!("--user-data-dir={}", profile.path().display()))
        .args(args)
        .arg(&url)
        // To files, not pipes: a DOM larger than a pipe's buffer would block chromium while
        // this thread polls for its exit.
        .stdout(Stdio::from(std::fs::File::create(&out_path).unwrap()))
        .stderr(Stdio::from(std::fs::File::create(&err_path).unwrap()))
        .spawn()
        .unwrap();
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > Duration::from_secs(90) {
            child.kill().unwrap();
            panic!("chromium did not finish within 90 s on {url}");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    let out = Output {
        status: child.wait().unwrap(),
        stdout: std::fs::read(&out_path).unwrap(),
        stderr: std::fs::read(&err_path).unwrap(),
    };
    assert!(out.status.success(), "chromium failed: {}", stderr(&out));
    out
}

/// The page's console messages and uncaught exceptions in chromium's `--enable-logging=stderr`
/// output. Chromium logs every console call (log, warn, error) and every uncaught exception as
/// an `INFO:CONSOLE` line without the level, so any such line counts: the report writes
/// nothing to the console.
fn console_messages(chromium_stderr: &str) -> Vec<&str> {
    chromium_stderr
        .lines()
        .filter(|l| l.contains(":CONSOLE") || l.contains("Uncaught"))
        .collect()
}

/// The DOM after load, with the console checked clean.
fn dom_without_console_errors(page: &Path) -> String {
    let out = run_chromium(page, &["--dump-dom"]);
    let err = stderr(&out);
    let messages = console_messages(&err);
    assert!(messages.is_empty(), "console output: {messages:#?}");
    String::from_utf8(out.stdout).unwrap()
}

/// Screenshot of the top 1200x1600 pixels; asserts the page is not blank and returns it.
fn assert_screenshot_not_blank(page: &Path) -> image::RgbImage {
    let dir = tempfile::tempdir().unwrap();
    let shot = dir.path().join("shot.png");
    let out = run_chromium(
        page,
        &[
            &format!("--screenshot={}", shot.display()),
            "--window-size=1200,1600",
        ],
    );
    assert!(console_messages(&stderr(&out)).is_empty());
    let img = image::open(&shot).unwrap().to_rgb8();
    assert_eq!(img.dimensions(), (1200, 1600));
    let mut counts = std::collections::HashMap::new();
    for p in img.pixels() {
        *counts.entry(p.0).or_insert(0usize) += 1;
    }
    let total = (img.width() * img.height()) as usize;
    let background = counts.values().copied().max().unwrap();
    let colourful = img
        .pixels()
        .filter(|p| {
            let (lo, hi) = (p.0.iter().min().unwrap(), p.0.iter().max().unwrap());
            hi - lo > 40
        })
        .count();
    assert!(counts.len() > 200, "only {} distinct colours", counts.len());
    assert!(
        total - background > total / 20,
        "{} of {total} pixels differ from the background",
        total - background
    );
    assert!(colourful > total / 200, "only {colourful} colourful pixels");
    img
}

/// Every `src` and `href` in `html` is inline data or an anchor in the page.
fn assert_self_contained(html: &str) {
    for attr in ["src=\"", "href=\""] {
        for (i, _) in html.match_indices(attr) {
            let value = &html[i + attr.len()..];
            assert!(
                value.starts_with("data:") || value.starts_with('#'),
                "external reference: {}",
                &value[..value.len().min(80)]
            );
        }
    }
    assert!(!html.contains("url(http") && !html.contains("@import"));
}

/// The `<tr>` of cell `i` in the per-cell table, and its `<td>` texts.
fn cell_row(dom: &str, i: usize) -> Vec<String> {
    let table = &dom[dom.find("id=\"cell-table\"").unwrap()..];
    let start = table
        .find(&format!("<tr data-cell=\"{i}\""))
        .unwrap_or_else(|| panic!("no row for cell {i}"));
    let row = &table[start..start + table[start..].find("</tr>").unwrap()];
    row.split("<td")
        .skip(1)
        .map(|td| {
            let text = &td[td.find('>').unwrap() + 1..];
            text[..text.find("</td>").unwrap()].to_string()
        })
        .collect()
}

fn bake(dir: &Path) {
    let o = sightline(
        &[
            "pvs",
            "bake",
            SCENE,
            "--grid",
            "3,2,1",
            "--bounds=-150,-150,1,150,150,3",
            "--n-rand",
            "20000",
            "--rays",
            "60000",
            "-o",
            "a.pvs",
        ],
        dir,
    );
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn report_loads_in_chromium_with_the_pvs_numbers() {
    let dir = tempfile::tempdir().unwrap();
    bake(dir.path());
    let o = sightline(&["pvs", "show", "a.pvs", "--json"], dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    let pvs: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let o = sightline(
        &[
            "report",
            SCENE,
            "a.pvs",
            "-o",
            "out",
            "--views",
            "4",
            "--size",
            "128",
            "--budgets",
            "20000,80000",
            "--budget-cells",
            "2",
            "--cell-rows",
            "2",
            "--json",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let summary: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let page = dir.path().join("out/index.html");

    let dom = dom_without_console_errors(&page);
    assert_self_contained(&dom);
    for id in ["summary-table", "cell-table", "cell-map"] {
        assert!(dom.contains(&format!("id=\"{id}\"")), "no #{id} in the DOM");
    }
    // One row per cell with the .pvs file's set sizes, shown and in data attributes.
    let cells = pvs["cells"].as_array().unwrap();
    assert_eq!(cells.len(), 6);
    assert_eq!(dom.matches("<tr data-cell=").count(), cells.len());
    for (i, c) in cells.iter().enumerate() {
        let size = c["pvs_size"].as_u64().unwrap().to_string();
        let row = cell_row(&dom, i);
        assert_eq!(row[0], i.to_string());
        assert_eq!(row[3], size, "cell {i}: {row:?}");
        // A version 2 bake: the cell's visible-object count, as `pvs show` lists the set.
        let objects = c["objects"].as_array().expect("a version 2 file").len();
        assert_eq!(row[5], objects.to_string(), "cell {i}: {row:?}");
        let rays = pvs["metadata"]["cells"][i]["rays"].as_u64().unwrap();
        assert_eq!(row[6], rays.to_string());
        let max_error = summary["cells"][i]["max_error_pixels"].as_u64().unwrap();
        assert_eq!(row[8], "no: budget", "cell {i}: {row:?}");
        assert_eq!(row[10], max_error.to_string());
        assert!(dom.contains(&format!("<tr data-cell=\"{i}\" data-pvs=\"{size}\"")));
    }
    let table = pvs["objects"].as_array().unwrap().len();
    assert!(
        dom.contains(&format!("<th>objects</th><td>{table}</td>")),
        "the summary names the object table's size"
    );
    assert!(
        dom.contains("<td>gvs++</td>")
            && dom.contains("<td>procedural:city?seed=1&amp;size=3000</td>")
    );
    assert_designer_layout(&dom, &summary, cells.len());
    assert_cell_filter(&page, &dom);
    // Worst views: the cells with errors, each image showing exactly the counted pixels.
    let with_errors = (0..cells.len())
        .filter(|&i| summary["cells"][i]["max_error_pixels"].as_u64().unwrap() > 0)
        .count();
    assert_eq!(
        dom.matches("<figure class=\"worst\"").count(),
        with_errors.min(6)
    );
    let figure = "<figure class=\"worst\" data-cell=\"";
    for (i, _) in dom.match_indices(figure) {
        let rest = &dom[i + figure.len()..];
        let cell: usize = rest[..rest.find('"').unwrap()].parse().unwrap();
        let errors = summary["cells"][cell]["max_error_pixels"].as_u64().unwrap();
        assert!(
            rest.contains(&format!("data-errors=\"{errors}\"")),
            "cell {cell}"
        );
    }
    // Convergence: a plot when the bake recorded curves, a notice when it did not.
    let recorded = pvs["metadata"]["cells"][0].get("convergence").is_some();
    if recorded {
        assert!(dom.contains("id=\"convergence-plot\"") && dom.contains("<polyline"));
    } else {
        assert!(dom.contains("id=\"no-convergence\""));
    }

    assert_equal_budget_section(&dom, &summary);

    // The top of the page shows the summary and the map: the cells that missed triangles are
    // outlined in pure red there (worst views, whose error pixels are red too, come below).
    let shot = assert_screenshot_not_blank(&page);
    let flagged = (0..cells.len())
        .filter(|&i| summary["cells"][i]["false_negatives"].as_u64().unwrap() > 0)
        .count();
    let red = shot
        .pixels()
        .filter(|p| p.0[0] > 180 && p.0[1] < 50 && p.0[2] < 50)
        .count();
    if flagged > 0 {
        assert!(
            red > 100 * flagged,
            "{flagged} flagged cells, {red} red pixels"
        );
    } else {
        assert!(red < 20, "no flagged cell, but {red} red pixels");
    }
}

/// What a designer sees first (issue 19): the summary, the map and the worst views before the
/// per-cell table; the table's worst `--cell-rows 2` cells shown and the rest collapsed; the
/// map coloured by PVS size and by pixel error, cells that missed triangles outlined in red,
/// every cell linked to its table row.
fn assert_designer_layout(dom: &str, summary: &serde_json::Value, n: usize) {
    let at = |id: &str| {
        dom.find(&format!("<section id=\"{id}\""))
            .unwrap_or_else(|| panic!("no section {id}"))
    };
    assert!(at("summary") < at("map") && at("map") < at("worst-views"));
    assert!(at("worst-views") < at("cells") && at("cells") < at("convergence"));
    // The two worst cells (largest average error, then largest view error) are not collapsed.
    let errors: Vec<(f64, u64)> = (0..n)
        .map(|i| {
            let c = &summary["cells"][i];
            (
                c["avg_error_pixels"].as_f64().unwrap(),
                c["max_error_pixels"].as_u64().unwrap(),
            )
        })
        .collect();
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| {
        errors[b]
            .0
            .total_cmp(&errors[a].0)
            .then(errors[b].1.cmp(&errors[a].1))
            .then(a.cmp(&b))
    });
    for (rank, &i) in order.iter().enumerate() {
        let row_start = dom.find(&format!("<tr data-cell=\"{i}\"")).unwrap();
        let row = &dom[row_start..row_start + dom[row_start..].find('>').unwrap()];
        assert!(row.contains(&format!("data-rank=\"{rank}\"")), "{row}");
        assert!(row.contains(&format!("id=\"cell-row-{i}\"")), "{row}");
        assert_eq!(row.contains("class=\"rest\""), rank >= 2, "{row}");
    }
    assert!(dom.contains("show all 6 cells (the 2 worst are shown)"));
    // The map: every cell in both layers, the error layer's values the evaluation's.
    for layer in ["by-pvs", "by-error"] {
        let start = dom.find(&format!("<g class=\"layer {layer}\">")).unwrap();
        let group = &dom[start..start + dom[start..].find("</g>").unwrap()];
        assert_eq!(group.matches("<polygon class=\"cell").count(), n, "{layer}");
        for i in 0..n {
            assert!(
                group.contains(&format!("<a href=\"#cell-row-{i}\">")),
                "{layer} {i}"
            );
            let missed = summary["cells"][i]["false_negatives"].as_u64().unwrap() > 0;
            let class = if missed { "cell flagged" } else { "cell" };
            let tag = format!("<polygon class=\"{class}\" data-cell=\"{i}\" data-value=\"");
            let value_at = group.find(&tag).unwrap_or_else(|| panic!("{layer}: {tag}"));
            let value = &group[value_at + tag.len()..];
            let value: f64 = value[..value.find('"').unwrap()].parse().unwrap();
            if layer == "by-error" {
                assert_eq!(value, errors[i].0, "cell {i}");
            }
        }
    }
    assert!(dom.contains("id=\"map-by-pvs\" checked") && dom.contains("id=\"map-by-error\""));
    // Each worst view links to its cell's row.
    for (i, _) in dom.match_indices("<figure class=\"worst\" data-cell=\"") {
        let rest = &dom[i + "<figure class=\"worst\" data-cell=\"".len()..];
        let cell = &rest[..rest.find('"').unwrap()];
        let figure = &rest[..rest.find("</figure>").unwrap()];
        assert!(
            figure.contains(&format!("href=\"#cell-row-{cell}\"")),
            "{figure}"
        );
    }
}

/// The cell table's filter, given in the page address (`#cell-filter=TEXT`): only the rows
/// containing the text stay, collapsed ones included.
fn assert_cell_filter(page: &Path, dom: &str) {
    // A text that only one row has: the centre of the last cell, a collapsed one.
    let last = dom.rfind("<tr data-cell=").unwrap();
    let cell: usize = {
        let rest = &dom[last + "<tr data-cell=\"".len()..];
        rest[..rest.find('"').unwrap()].parse().unwrap()
    };
    let centre = cell_row(dom, cell)[1].clone();
    // The rows whose text (all cells run together, as the filter reads it) holds it.
    let matching: Vec<usize> = (0..6)
        .filter(|&i| cell_row(dom, i).concat().contains(&centre))
        .collect();
    assert!(
        matching.contains(&cell) && matching.len() < 6,
        "{matching:?}"
    );
    let fragment = format!("#cell-filter={}", centre.replace(' ', "%20"));
    let out = run_chromium_at(page, &fragment, &["--dump-dom"]);
    assert!(console_messages(&stderr(&out)).is_empty());
    let filtered = String::from_utf8(out.stdout).unwrap();
    let shown = filtered.matches("style=\"display: table-row;\"").count();
    let hidden = filtered.matches("style=\"display: none;\"").count();
    assert_eq!(
        (shown, hidden),
        (matching.len(), 6 - matching.len()),
        "filter {centre:?}"
    );
    let row_start = filtered.find(&format!("<tr data-cell=\"{cell}\"")).unwrap();
    let row = &filtered[row_start..row_start + filtered[row_start..].find('>').unwrap()];
    assert!(row.contains("display: table-row"), "{row}");
}

/// The equal-budget section shows GVS++ and RAND at `--budgets 20000,80000` on two cells: a
/// plot with both lines, and a table whose ratios are the JSON summary's errors divided.
fn assert_equal_budget_section(dom: &str, summary: &serde_json::Value) {
    let b = &summary["budgets"];
    assert_eq!(b["cells"], serde_json::json!([0, 3]), "{b}");
    let points = b["points"].as_array().unwrap();
    let methods: Vec<&str> = points
        .iter()
        .map(|p| p["method"].as_str().unwrap())
        .collect();
    assert_eq!(methods, ["GVS++", "RAND", "GVS++", "RAND"]);
    for p in points {
        let budget = p["budget"].as_f64().unwrap();
        let rays = p["rays"].as_f64().unwrap();
        // Within one batch of the budget (GVS++ may finish a batch a few rays past it).
        assert!(rays > 0.0 && (rays - budget).abs() <= 0.05 * budget, "{p}");
        assert!(p["seconds"].as_f64().unwrap() > 0.0, "{p}");
        assert!(p["avg_error_pixels"].as_f64().unwrap() >= 0.0, "{p}");
    }
    let plot = &dom[dom.find("id=\"budget-plot\"").expect("no #budget-plot")..];
    assert!(plot.matches("<polyline").count() >= 2);
    assert!(plot.contains("GVS++") && plot.contains("RAND"));
    let table = &dom[dom.find("id=\"budget-table\"").expect("no #budget-table")..];
    for (k, budget) in [20000u64, 80000].iter().enumerate() {
        let (g, r) = (&points[2 * k], &points[2 * k + 1]);
        let (ge, re) = (
            g["avg_error_pixels"].as_f64().unwrap(),
            r["avg_error_pixels"].as_f64().unwrap(),
        );
        let start = table
            .find(&format!("<tr data-budget=\"{budget}\" data-ratio=\""))
            .unwrap_or_else(|| panic!("no row for {budget} rays"));
        let rest = &table[start..];
        let ratio = &rest[rest.find("data-ratio=\"").unwrap() + 12..];
        let ratio = &ratio[..ratio.find('"').unwrap()];
        let expected = if ge > 0.0 {
            re / ge
        } else if re > 0.0 {
            f64::INFINITY
        } else {
            1.0
        };
        let shown: f64 = ratio.parse().unwrap();
        assert!(
            shown == expected || (shown - expected).abs() <= 1e-9 * expected,
            "{budget} rays: {shown} vs {expected}"
        );
    }
}

#[test]
fn report_rejects_bad_budgets_before_writing_anything() {
    let dir = tempfile::tempdir().unwrap();
    bake(dir.path());
    let report = |budgets: &str| {
        sightline(
            &["report", SCENE, "a.pvs", "-o", "out", "--budgets", budgets],
            dir.path(),
        )
    };
    for (budgets, why) in [("80000,20000", "increase"), ("0", "outside")] {
        assert_fails_with(&report(budgets), why);
    }
    // Not a number: the argument parser's usage error (exit 2), naming the value.
    let o = report("20000,lots");
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("`lots` is not a ray count"),
        "{}",
        stderr(&o)
    );
    assert!(!dir.path().join("out").exists());
}

#[test]
fn report_refuses_a_pvs_of_another_scene() {
    let dir = tempfile::tempdir().unwrap();
    bake(dir.path());
    let o = sightline(
        &["report", "procedural:rooms?size=2000", "a.pvs", "-o", "out"],
        dir.path(),
    );
    assert_fails_with(&o, "another scene");
    assert!(!dir.path().join("out/index.html").exists());
}

#[test]
fn demo_page_loads_in_chromium() {
    let dir = tempfile::tempdir().unwrap();
    let o = sightline(
        &[
            "demo",
            "procedural:city?size=3000",
            "--size",
            "128",
            "--cells",
            "2",
            "--n-rand",
            "50000",
            "--views",
            "2",
            "--frames",
            "20",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let page = dir.path().join("sightline-report/index.html");
    let dom = dom_without_console_errors(&page);
    assert_self_contained(&dom);
    for id in [
        "steps-table",
        "from-point-table",
        "cell-table",
        "rand-table",
        "culling-table",
    ] {
        assert!(dom.contains(&format!("id=\"{id}\"")), "no #{id} in the DOM");
    }
    // The demo records convergence itself, so its plot is always there; five culling methods.
    assert!(dom.contains("id=\"convergence-plot\""));
    assert_eq!(dom.matches("<tr data-method=").count(), 5);
    assert_screenshot_not_blank(&page);
}

/// The console detector must see what chromium prints for a page with a broken script,
/// or the checks above prove nothing.
#[test]
fn console_detector_catches_a_deliberate_error() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.html");
    std::fs::write(
        &bad,
        "<!doctype html><html><body><p>x</p><script>console.error('deliberate console error');\
         undefinedFunction();</script></body></html>",
    )
    .unwrap();
    let out = run_chromium(&bad, &["--dump-dom"]);
    let err = stderr(&out);
    let messages = console_messages(&err);
    assert!(
        messages
            .iter()
            .any(|m| m.contains("deliberate console error")),
        "{err}"
    );
    assert!(
        messages.iter().any(|m| m.contains("undefinedFunction")),
        "{err}"
    );

    let good = dir.path().join("good.html");
    std::fs::write(
        &good,
        "<!doctype html><html><body><p>fine</p></body></html>",
    )
    .unwrap();
    let out = run_chromium(&good, &["--dump-dom"]);
    assert!(console_messages(&stderr(&out)).is_empty());
    assert!(String::from_utf8_lossy(&out.stdout).contains("<p>fine</p>"));
}
