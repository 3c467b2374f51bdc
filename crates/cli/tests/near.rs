//! End-to-end tests of the default near plane (issue 16): a 2,000 km ground under a 2-unit box
//! made 1e-4 of the scene diagonal (283 units) the near plane, and every method silently lost
//! the box; and the warning when a given `--near` hides what is in view.

mod common;

use std::collections::BTreeSet;
use std::path::Path;

use common::{assert_fails_with, sightline, stderr};

/// The ground quad (ids 0, 1; Y up, 1,000 km from the origin each way) and the box
/// [-1, 1] x [0, 2] x [-1, 1] on it (ids 2..14: bottom, top, then the sides z = -1, x = 1,
/// z = 1, x = -1, two triangles each).
const HUGE_GROUND: &str = "\
v -1000000 0 -1000000
v 1000000 0 -1000000
v 1000000 0 1000000
v -1000000 0 1000000
f 1 3 2
f 1 4 3
v -1 0 -1
v 1 0 -1
v 1 0 1
v -1 0 1
v -1 2 -1
v 1 2 -1
v 1 2 1
v -1 2 1
f 5 6 7
f 5 7 8
f 9 12 11
f 9 11 10
f 5 6 10
f 5 10 9
f 6 7 11
f 6 11 10
f 7 8 12
f 7 12 11
f 8 5 9
f 8 9 12
";

/// From (5, 3, 4), above the box and 4 units off two of its sides, these faces are in sight:
/// the top, x = 1 and z = 1.
const BOX_IN_SIGHT: [u32; 6] = [4, 5, 8, 9, 10, 11];

const CAMERA: [&str; 6] = ["--eye", "5,3,4", "--look", "0,1,0", "--size", "256x192"];

/// Runs `visible huge.obj` with the camera, `extra` options and `-o ids.txt`; the ids and
/// stderr.
fn visible(dir: &Path, extra: &[&str]) -> (BTreeSet<u32>, String) {
    let mut args = vec!["visible", "huge.obj"];
    args.extend(CAMERA);
    args.extend(extra);
    args.extend(["-o", "ids.txt"]);
    let o = sightline(&args, dir);
    assert!(o.status.success(), "{args:?}: {}", stderr(&o));
    let ids = std::fs::read_to_string(dir.join("ids.txt"))
        .expect("visible -o wrote ids.txt")
        .lines()
        .map(|l| l.parse().expect("ids.txt holds one id a line"))
        .collect();
    (ids, stderr(&o))
}

#[test]
fn huge_ground_keeps_the_box_in_every_visible_set() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("huge.obj"), HUGE_GROUND).unwrap();
    let expected: BTreeSet<u32> = [0, 1].into_iter().chain(BOX_IN_SIGHT).collect();
    for method in [&[][..], &["--exact"], &["--conservative"]] {
        let (ids, err) = visible(dir.path(), method);
        assert!(
            BOX_IN_SIGHT.iter().all(|t| ids.contains(t)),
            "{method:?}: the box's faces in sight are missing from {ids:?}"
        );
        // Sampling and the exact set see just the ground and those faces; the conservative
        // set may add hidden box triangles.
        if method != ["--conservative"] {
            assert_eq!(ids, expected, "{method:?}");
        }
        assert!(!err.contains("near plane"), "{method:?}: no warning: {err}");
    }
}

#[test]
fn too_large_near_warns_naming_its_distance_and_the_flag() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("huge.obj"), HUGE_GROUND).unwrap();
    let (ids, err) = visible(dir.path(), &["--near", "50"]);
    // The near plane lies past the box: only the far ground is left.
    assert!(ids.iter().all(|&t| t < 2), "{ids:?}");
    assert!(
        err.contains("warning: the near plane at 50 (--near) hides 12 of the 14 triangles"),
        "{err}"
    );
    assert!(err.contains("give a smaller --near"), "{err}");
    // The same warning from `render --cube`, which checks its six faces.
    let mut args = vec![
        "render", "huge.obj", "--cube", "--near", "50", "-o", "c.png",
    ];
    args.extend(CAMERA);
    let o = sightline(&args, dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        stderr(&o).matches("warning: the near plane at 50").count(),
        1
    );
}

#[test]
fn non_positive_near_is_a_clean_error() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("huge.obj"), HUGE_GROUND).unwrap();
    let mut args = vec!["visible", "huge.obj", "--near", "0"];
    args.extend(CAMERA);
    assert_fails_with(
        &sightline(&args, dir.path()),
        "near plane 0 must be positive",
    );
}
