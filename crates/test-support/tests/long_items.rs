//! The redesign's size rule, kept: no product file over 800 lines and no function over 120
//! (tests left out) unless a `Long because:` comment says why. `scripts/long-items` finds them
//! (its docstring says how); it exits 1 and names each one.

use std::path::Path;
use std::process::Command;

#[test]
fn no_file_or_function_is_over_its_limit_without_a_reason() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let out = Command::new("python3")
        .arg(root.join("scripts/long-items"))
        .current_dir(&root)
        .output()
        .expect("python3 runs scripts/long-items");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "too long:\n{text}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // The script looked at the workspace (one that found no files would also exit 0).
    let checked: usize = text
        .lines()
        .find_map(|l| l.split(" files checked").next()?.trim().parse().ok())
        .unwrap_or(0);
    assert!(checked > 200, "only {checked} files checked:\n{text}");
}

/// The finder must see a long function, or the check above proves nothing.
#[test]
fn the_finder_reports_a_long_function_and_accepts_a_reason() {
    let dir = std::env::temp_dir().join(format!("long-items-{}", std::process::id()));
    let src = dir.join("crate/src");
    std::fs::create_dir_all(&src).unwrap();
    let body = "    let x = 1;\n".repeat(130);
    let long = format!(
        "fn long() {{\n{body}}}\n#[cfg(test)]\nmod tests {{\n    fn t() {{\n{body}    }}\n}}\n"
    );
    std::fs::write(src.join("lib.rs"), &long).unwrap();
    let run = || {
        Command::new("python3")
            .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scripts/long-items"))
            .arg(dir.join("crate"))
            .output()
            .unwrap()
    };
    let out = run();
    let text = String::from_utf8_lossy(&out.stdout).to_string();
    assert!(!out.status.success(), "{text}");
    // The function in the test module is not counted: exactly one finding.
    assert_eq!(text.matches("TOO LONG").count(), 1, "{text}");
    assert!(text.contains("fn long: 132 lines"), "{text}");
    std::fs::write(
        src.join("lib.rs"),
        format!("// Long because: a table.\n{long}"),
    )
    .unwrap();
    let out = run();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
