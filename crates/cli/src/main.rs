//! The `sightline` command-line tool.
fn main() {}
