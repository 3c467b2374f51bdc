//! End-to-end tests of scene loading through the binary: `info`'s exit status on a scene with
//! validation errors, the loading limits (`--max-scene-bytes`, `--allow-outside-refs`) and
//! load warnings on stderr.

mod common;

use common::{assert_fails_with, sightline, stderr};

const NAN_OBJ: &str = "v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n";

#[test]
fn info_prints_the_report_then_exits_1_on_errors() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("nan.obj"), NAN_OBJ).unwrap();
    let o = sightline(&["info", "nan.obj"], dir.path());
    assert_fails_with(&o, "validation error");
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("NaN"), "the report comes first: {out}");

    let o = sightline(&["info", "nan.obj", "--json"], dir.path());
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["errors"].as_array().unwrap().len(), 1);
}

#[test]
fn info_of_an_empty_scene_exits_1() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("empty.obj"), "# nothing\n").unwrap();
    let o = sightline(&["info", "empty.obj"], dir.path());
    assert_fails_with(&o, "validation error");
}

#[test]
fn cull_refuses_nan_vertices() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("nan.obj"), NAN_OBJ).unwrap();
    let o = sightline(&["cull", "nan.obj", "--frames", "1"], dir.path());
    assert_fails_with(&o, "NaN");
}

#[test]
fn max_scene_bytes_limits_and_names_itself() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("t.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    )
    .unwrap();
    let o = sightline(&["info", "t.obj", "--max-scene-bytes", "20"], dir.path());
    assert_fails_with(&o, "--max-scene-bytes");
    let o = sightline(&["info", "t.obj", "--max-scene-bytes", "1K"], dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
}

/// A `.gltf` in `dir/inner` whose one buffer is the file `uri` (42 bytes: 3 positions and 3
/// u16 indices), written to `dir/up.bin`.
fn gltf_with_buffer(dir: &std::path::Path, uri: &str) {
    let mut bin = Vec::new();
    for v in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0] {
        bin.extend_from_slice(&v.to_le_bytes());
    }
    for i in [0u16, 1, 2, 0] {
        bin.extend_from_slice(&i.to_le_bytes());
    }
    std::fs::write(dir.join("up.bin"), &bin).expect("write up.bin");
    std::fs::create_dir_all(dir.join("inner")).expect("create inner/");
    let text = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1}}]}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}},
                     {{"bufferView":1,"componentType":5123,"count":3,"type":"SCALAR"}}],
        "bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":36}},{{"buffer":0,"byteOffset":36,"byteLength":6}}],
        "buffers":[{{"byteLength":42,"uri":"{uri}"}}]}}"#
    );
    std::fs::write(dir.join("inner/m.gltf"), text).expect("write m.gltf");
}

#[test]
fn outside_buffer_needs_allow_outside_refs() {
    let dir = tempfile::tempdir().unwrap();
    gltf_with_buffer(dir.path(), "../up.bin");
    let o = sightline(&["info", "inner/m.gltf"], dir.path());
    assert_fails_with(&o, "--allow-outside-refs");
    let o = sightline(
        &["info", "inner/m.gltf", "--allow-outside-refs"],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn load_warnings_go_to_stderr() {
    let dir = tempfile::tempdir().unwrap();
    let ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
               property float z\nelement face 2\nproperty list uchar int vertex_indices\n\
               end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n2 0 1\n";
    std::fs::write(dir.path().join("s.ply"), ply).unwrap();
    let o = sightline(&["info", "s.ply"], dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("warning: s.ply: 1 face(s) with fewer than 3"),
        "{}",
        stderr(&o)
    );
}
