//! The C program `examples/c/pvs_query.c`, compiled with `cc` against `include/sightline.h`
//! and the static library this package builds, run on a baked scene: its output must be the
//! Rust runtime's answers, line by line, and under valgrind it must make no memory error and
//! leak nothing. Needs `cc` and `valgrind` (Debian: `gcc`, `valgrind` and `libc6-dbg`;
//! `.ci/run` installs the last two): without them the test fails, it never skips.

// Test helpers panic on failure: that is the report we want.
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

use sightline_runtime::Pvs;

/// The directory cargo put this package's libraries in: the test executable is
/// `<target>/<profile>/deps/c_program-<hash>`, and the static library cargo built for this
/// test run is beside it (`deps/libsightline.a`, without a hash in its name); the copy in
/// `<target>/<profile>/` is the last `cargo build`'s, possibly of other code, so only a
/// fallback.
fn library_dir() -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    let deps = exe.parent().unwrap();
    for dir in [deps, deps.parent().unwrap()] {
        if dir.join(static_library_name()).is_file() {
            return dir.to_path_buf();
        }
    }
    panic!(
        "{} is neither in {} nor in its parent: cargo builds it with this test \
         (crate-type staticlib of sightline-capi)",
        static_library_name(),
        deps.display()
    );
}

fn static_library_name() -> &'static str {
    if cfg!(windows) {
        "sightline.lib"
    } else {
        "libsightline.a"
    }
}

/// `cc`, or `$CC`, failing loudly when there is none.
fn c_compiler() -> String {
    let cc = std::env::var("CC")
        .ok()
        .filter(|c| !c.trim().is_empty())
        .unwrap_or_else(|| "cc".into());
    match Command::new(&cc).arg("--version").output() {
        Ok(o) if o.status.success() => cc,
        _ => panic!(
            "no C compiler: `{cc} --version` failed. This test compiles examples/c/pvs_query.c; \
             install one (Debian: `apt-get install gcc`) or set CC"
        ),
    }
}

fn require_valgrind() {
    match Command::new("valgrind").arg("--version").output() {
        Ok(o) if o.status.success() => {}
        _ => panic!(
            "valgrind is not installed: this test runs the C program under it. Install the \
             Debian packages `valgrind` and `libc6-dbg` (`apt-get install valgrind libc6-dbg`; \
             .ci/run does)"
        ),
    }
}

/// Compiles the C program into `dir`, warnings as errors.
fn compile(dir: &Path) -> PathBuf {
    let crate_dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let exe = dir.join("pvs_query");
    let cc = c_compiler();
    let output = Command::new(&cc)
        .args([
            "-std=c99",
            "-Wall",
            "-Wextra",
            "-Wpedantic",
            "-Werror",
            "-g",
            "-O1",
        ])
        .arg("-I")
        .arg(crate_dir.join("include"))
        .arg(crate_dir.join("examples/c/pvs_query.c"))
        .arg(library_dir().join(static_library_name()))
        // What a Rust static library needs from the system on Linux (glibc).
        .args(["-lpthread", "-ldl", "-lm"])
        .arg("-o")
        .arg(&exe)
        .output()
        .unwrap_or_else(|e| panic!("could not run {cc}: {e}"));
    assert!(
        output.status.success(),
        "compiling examples/c/pvs_query.c failed:\n{}",
        String::from_utf8_lossy(&output.stderr)
    );
    exe
}

/// Runs `command` with `stdin` as standard input.
fn run(mut command: Command, stdin: &str) -> Output {
    let mut child = command
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| panic!("could not start {command:?}: {e}"));
    child
        .stdin
        .take()
        .unwrap()
        .write_all(stdin.as_bytes())
        .unwrap();
    child.wait_with_output().unwrap()
}

/// One token of an expected line: text to match exactly, or a float the program prints with
/// `%.9g` (which round-trips an f32), compared as a value.
#[derive(Debug)]
enum Token {
    Text(String),
    Float(f32),
}

struct Line(Vec<Token>);

impl Line {
    fn new() -> Self {
        Line(Vec::new())
    }
    fn t(mut self, text: impl ToString) -> Self {
        self.0.push(Token::Text(text.to_string()));
        self
    }
    fn f(mut self, values: &[f32]) -> Self {
        self.0.extend(values.iter().map(|&v| Token::Float(v)));
        self
    }
    fn matches(&self, actual: &str) -> bool {
        let words: Vec<&str> = actual.split(' ').collect();
        words.len() == self.0.len()
            && self.0.iter().zip(&words).all(|(token, word)| match token {
                Token::Text(t) => t == word,
                Token::Float(v) => word
                    .parse::<f32>()
                    .is_ok_and(|w| w.to_bits() == v.to_bits() || (w.is_nan() && v.is_nan())),
            })
    }
}

impl std::fmt::Display for Line {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        for (i, token) in self.0.iter().enumerate() {
            let sep = if i == 0 { "" } else { " " };
            match token {
                Token::Text(t) => write!(f, "{sep}{t}")?,
                Token::Float(v) => write!(f, "{sep}{v:?}")?,
            }
        }
        Ok(())
    }
}

/// The program's name escaping (see pvs_query.c).
fn escape(name: &str) -> String {
    let mut out = String::from("\"");
    for &b in name.as_bytes() {
        if b > b' ' && b <= b'~' && b != b'"' && b != b'\\' {
            out.push(b as char);
        } else {
            out.push_str(&format!("\\x{b:02x}"));
        }
    }
    out.push('"');
    out
}

fn number_or_dash(v: Option<u32>) -> String {
    v.map_or("-".into(), |v| v.to_string())
}

/// What pvs_query must print for `pvs` and `positions`, from the Rust runtime.
fn expected(pvs: &Pvs, positions: &[[&str; 3]]) -> Vec<Line> {
    let mut lines = vec![
        Line::new().t("version").t(pvs.version()),
        Line::new().t("cells").t(pvs.cell_count()),
        Line::new().t("objects").t(pvs.object_count()),
        Line::new().t("triangles").t(pvs.triangle_count()),
        Line::new()
            .t("scene_hash")
            .t(format!("{:016x}", pvs.scene_hash())),
    ];
    for i in 0..pvs.cell_count() {
        let c = pvs.cell(i).unwrap();
        lines.push(
            Line::new()
                .t("cell")
                .t(i)
                .t("center")
                .f(&c.center)
                .t("axes")
                .f(c.axes.as_flattened())
                .t("half_extents")
                .f(&c.half_extents),
        );
    }
    for o in pvs.objects().enumerate() {
        let (i, o) = o;
        lines.push(
            Line::new()
                .t("object")
                .t(i)
                .t("name")
                .t(escape(o.name))
                .t("index")
                .t(number_or_dash(o.index))
                .t("part")
                .t(number_or_dash(o.part))
                .t("bounds")
                .f(&o.bounds_min)
                .f(&o.bounds_max),
        );
    }
    for text in positions {
        let line = Line::new().t("position").t(text[0]).t(text[1]).t(text[2]);
        let Some(cell) = pvs.cell_at(common::position(text)) else {
            lines.push(line.t("outside"));
            continue;
        };
        let mut line = line.t("cell").t(cell).t("objects");
        match pvs.visible_objects(cell) {
            Ok(ids) => {
                line = line.t(format!("{}:", ids.len()));
                for id in ids {
                    line = line.t(id);
                }
            }
            Err(sightline_runtime::Error::NoObjects(_)) => line = line.t("none"),
            Err(e) => panic!("cell {cell}: {e}"),
        }
        lines.push(
            line.t("triangles")
                .t(pvs.visible_triangle_count(cell).unwrap()),
        );
    }
    lines
}

fn assert_output(what: &str, output: &Output, expected: &[Line]) {
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        output.status.success(),
        "{what}: exit status {}\nstdout:\n{stdout}\nstderr:\n{}",
        output.status,
        String::from_utf8_lossy(&output.stderr)
    );
    let actual: Vec<&str> = stdout.lines().collect();
    for (i, line) in expected.iter().enumerate() {
        let got = actual.get(i).copied().unwrap_or("<missing>");
        assert!(
            line.matches(got),
            "{what}: line {}:\n  expected: {line}\n  printed:  {got}\nall output:\n{stdout}",
            i + 1
        );
    }
    assert_eq!(
        actual.len(),
        expected.len(),
        "{what}: extra lines:\n{stdout}"
    );
}

/// Runs the program under valgrind and checks its summary: no error, no leak of any kind.
fn valgrind(dir: &Path, exe: &Path, args: &[&str], stdin: &str) -> Output {
    let log = dir.join(format!("valgrind-{}.log", args.len()));
    let mut command = Command::new("valgrind");
    command
        .args([
            "--error-exitcode=99",
            "--leak-check=full",
            "--errors-for-leak-kinds=all",
            "--show-leak-kinds=all",
        ])
        .arg(format!("--log-file={}", log.display()))
        .arg(exe)
        .args(args);
    let output = run(command, stdin);
    let report = std::fs::read_to_string(&log).unwrap_or_default();
    assert!(
        !report.contains("Fatal error at startup"),
        "valgrind cannot start: install the Debian package `libc6-dbg` (glibc's debug symbols; \
         Debian's ld.so is stripped):\n{report}"
    );
    assert_ne!(
        output.status.code(),
        Some(99),
        "valgrind found errors:\n{report}"
    );
    assert!(
        report.contains("ERROR SUMMARY: 0 errors from 0 contexts"),
        "valgrind:\n{report}"
    );
    assert!(
        report.contains("All heap blocks were freed -- no leaks are possible"),
        "valgrind reports memory not freed:\n{report}"
    );
    output
}

#[test]
fn c_program_answers_like_the_runtime_and_is_clean_under_valgrind() {
    // Both tools checked first: a missing one is the first thing said.
    c_compiler();
    require_valgrind();
    let baked = common::bake();
    let pvs = Pvs::open(&baked.path).unwrap();
    if pvs.version() >= 2 {
        // The scene must make the object sets worth comparing.
        assert_eq!(pvs.object_count() as usize, common::NAMES.len());
        let right = pvs.visible_objects(2).unwrap();
        assert!(
            common::LEFT.iter().all(|o| !right.contains(o)),
            "cell 2 sees past the wall: {right:?}"
        );
        assert!(
            !right.is_empty() && !right.contains(&common::HIDDEN),
            "cell 2: {right:?}"
        );
        let left = pvs.visible_objects(0).unwrap();
        assert!(
            common::RIGHT.iter().all(|o| !left.contains(o)),
            "cell 0 sees past the wall: {left:?}"
        );
        assert!(!left.is_empty());
    } else {
        eprintln!(
            "note: the bake wrote version {} (no objects): object sets are not exercised",
            pvs.version()
        );
    }

    let dir = tempfile::tempdir().unwrap();
    let exe = compile(dir.path());
    let file = baked.path.to_str().unwrap();
    let mut args = vec![file];
    args.extend(common::POSITIONS.iter().flatten());
    let want = expected(&pvs, &common::POSITIONS);

    let mut command = Command::new(&exe);
    command.args(&args);
    let output = run(command, "");
    // Shown with `-- --nocapture`.
    println!(
        "pvs_query {}:\n{}",
        args.join(" "),
        String::from_utf8_lossy(&output.stdout)
    );
    assert_output("pvs_query (positions in argv)", &output, &want);

    // Same positions from standard input, under valgrind.
    let stdin: String = common::POSITIONS
        .iter()
        .map(|p| format!("{} {} {}\n", p[0], p[1], p[2]))
        .collect();
    let output = valgrind(dir.path(), &exe, &[file], &stdin);
    assert_output(
        "pvs_query under valgrind (positions on stdin)",
        &output,
        &want,
    );

    // A version-1 file: no objects, triangle counts only.
    let v1 = common::bake_v1();
    let v1_pvs = Pvs::open(&v1.path).unwrap();
    assert_eq!(v1_pvs.version(), 1);
    let v1_file = v1.path.to_str().unwrap();
    let mut command = Command::new(&exe);
    command
        .arg(v1_file)
        .args(common::POSITIONS.iter().flatten());
    assert_output(
        "pvs_query on a version-1 file",
        &run(command, ""),
        &expected(&v1_pvs, &common::POSITIONS),
    );

    // Errors: a damaged file and a missing one end with the library's message, status 1, and
    // free everything on the way out (valgrind again).
    let mut damaged = baked.bytes.clone();
    let middle = damaged.len() / 2;
    damaged[middle] ^= 0x40;
    let damaged_path = dir.path().join("damaged.pvs");
    std::fs::write(&damaged_path, &damaged).unwrap();
    let missing_path = dir.path().join("missing.pvs");
    for path in [&damaged_path, &missing_path] {
        let message = Pvs::open(path).unwrap_err().to_string();
        let output = valgrind(
            dir.path(),
            &exe,
            &[path.to_str().unwrap(), "0", "0", "0"],
            "",
        );
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(
            output.status.code(),
            Some(1),
            "{}: stderr {stderr}",
            path.display()
        );
        assert_eq!(stderr, format!("pvs_query: sl_pvs_open: {message}\n"));
        assert!(output.stdout.is_empty());
    }

    // Bad usage: a coordinate that is not a number.
    let mut command = Command::new(&exe);
    command.args([file, "1", "x", "2"]);
    let output = run(command, "");
    assert_eq!(output.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&output.stderr).contains("not a number: 'x'"));
}
