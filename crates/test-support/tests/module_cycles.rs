//! The redesign's rule, kept: no crate has an import circle between its modules (a module
//! importing from one that imports it back). `scripts/module-cycles` finds them (its docstring
//! says how); it exits 1 and names the circle when there is one.

use std::path::Path;
use std::process::Command;

#[test]
fn no_crate_has_an_import_circle() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let out = Command::new("python3")
        .arg(root.join("scripts/module-cycles"))
        .current_dir(&root)
        .output()
        .expect("python3 runs scripts/module-cycles");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "import circles:\n{text}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // Every crate was looked at (a script that found no crates would also exit 0).
    let crates = text.lines().filter(|l| l.starts_with("crates/")).count();
    assert!(crates >= 13, "only {crates} crates checked:\n{text}");
}
