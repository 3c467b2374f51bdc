//! `include/sightline.h` is what cbindgen makes of `src/lib.rs` with `cbindgen.toml`: this
//! test generates it and fails when the committed header differs.
//! `SIGHTLINE_UPDATE_HEADER=1 cargo test -p sightline-capi --test header` rewrites it.

use std::path::Path;

fn generate(crate_dir: &Path) -> String {
    let config =
        cbindgen::Config::from_file(crate_dir.join("cbindgen.toml")).expect("read cbindgen.toml");
    // One source file (its `mod` files are followed), no `cargo metadata`: quick, and it does
    // not wait for the cargo lock of a build running beside it.
    let bindings = cbindgen::Builder::new()
        .with_config(config)
        .with_src(crate_dir.join("src/lib.rs"))
        .generate()
        .expect("cbindgen could not generate the header");
    let mut out = Vec::new();
    bindings.write(&mut out);
    String::from_utf8(out).expect("cbindgen wrote UTF-8")
}

#[test]
fn committed_header_is_the_generated_one() {
    let crate_dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let path = crate_dir.join("include/sightline.h");
    let generated = generate(crate_dir);
    if std::env::var_os("SIGHTLINE_UPDATE_HEADER").is_some_and(|v| v == "1") {
        std::fs::write(&path, &generated).expect("write include/sightline.h");
        eprintln!("wrote {}", path.display());
        return;
    }
    // A checkout with CRLF line ends still matches.
    let committed = std::fs::read_to_string(&path)
        .unwrap_or_default()
        .replace("\r\n", "\n");
    if committed == generated {
        return;
    }
    let first_difference = committed
        .lines()
        .zip(generated.lines())
        .enumerate()
        .find(|(_, (a, b))| a != b)
        .map(|(i, (a, b))| {
            format!(
                "first difference at line {}:\n  committed: {a}\n  generated: {b}",
                i + 1
            )
        })
        .unwrap_or_else(|| {
            format!(
                "one is a prefix of the other ({} committed lines, {} generated)",
                committed.lines().count(),
                generated.lines().count()
            )
        });
    panic!(
        "{} is not what cbindgen generates from src/lib.rs ({first_difference}).\n\
         Regenerate it with\n    SIGHTLINE_UPDATE_HEADER=1 cargo test -p sightline-capi --test header\n\
         and commit the result.",
        path.display()
    );
}
