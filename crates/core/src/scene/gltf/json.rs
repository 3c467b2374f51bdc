//! The glTF JSON document: parsed and validated by the `gltf` crate (`json::Root::from_slice`
//! then `Document::from_json`, what `Gltf::from_slice` does), with two checks of our own
//! around it for what gltf-json 1.4 gets wrong (indices above `u32::MAX`, and a `POSITION`
//! reference its validator trusts), and its errors turned into [`LoadError`]s.

use std::path::Path;

use gltf::mesh::Semantic;

use super::super::error::{LoadError, Location};

/// Parses and validates the JSON of a glTF file (the whole `.gltf` file, or a GLB's JSON
/// chunk). Errors name the line (JSON syntax), the element (validation) or the mesh and
/// primitive (a `POSITION` accessor that does not exist).
pub(super) fn parse_document(path: &Path, json: &[u8]) -> Result<gltf::Document, LoadError> {
    check_index_widths(path, json)?;
    let root = gltf::json::Root::from_slice(json)
        .map_err(|e| json_error(path, gltf::Error::Deserialize(e)))?;
    check_position_indices(path, &root)?;
    gltf::Document::from_json(root).map_err(|e| json_error(path, e))
}

/// gltf-json 1.4 reads every index as `value as u32`, so `"mesh": 4294967296` would silently
/// be mesh 0: every integer above `u32::MAX` is an error here, except in the size and count
/// members (`byteLength`, `byteOffset`, `byteStride`, `count`, read as 64-bit) and in
/// `extras` and `extensions` (application data that is not read). JSON that does not parse is
/// left to the `gltf` crate, whose error names the line.
fn check_index_widths(path: &Path, json: &[u8]) -> Result<(), LoadError> {
    let Ok(value) = serde_json::from_slice::<serde_json::Value>(json) else {
        return Ok(());
    };
    match first_wide_integer(&value, &mut String::new()) {
        Some((at, v)) => Err(LoadError::parse(
            path,
            Location::Element(at),
            format!("{v} is not a valid index (above 2^32 - 1)"),
        )),
        None => Ok(()),
    }
}

/// The JSON path and value of the first integer too wide for an index, in document order
/// (`at` is the path of `value`, extended and restored on the way down).
fn first_wide_integer(value: &serde_json::Value, at: &mut String) -> Option<(String, u64)> {
    match value {
        serde_json::Value::Number(n) => n
            .as_u64()
            .filter(|&v| v > u64::from(u32::MAX))
            .map(|v| (at.clone(), v)),
        serde_json::Value::Array(items) => items.iter().enumerate().find_map(|(i, item)| {
            let len = at.len();
            at.push_str(&format!("[{i}]"));
            let found = first_wide_integer(item, at);
            at.truncate(len);
            found
        }),
        serde_json::Value::Object(members) => members.iter().find_map(|(key, item)| {
            let skip = [
                "extras",
                "extensions",
                "byteLength",
                "byteOffset",
                "byteStride",
                "count",
            ];
            if skip.contains(&key.as_str()) {
                return None;
            }
            let len = at.len();
            if !at.is_empty() {
                at.push('.');
            }
            at.push_str(key);
            let found = first_wide_integer(item, at);
            at.truncate(len);
            found
        }),
        _ => None,
    }
}

/// gltf-json 1.4 validation indexes `accessors[POSITION]` without a bounds check (a panic on
/// a bad index, found by our fuzz test), so that one reference is checked here first.
fn check_position_indices(path: &Path, root: &gltf::json::Root) -> Result<(), LoadError> {
    let position = gltf::json::validation::Checked::Valid(Semantic::Positions);
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            if let Some(index) = primitive.attributes.get(&position) {
                if index.value() >= root.accessors.len() {
                    return Err(LoadError::parse(
                        path,
                        Location::Element(format!("mesh {m}, primitive {p}")),
                        format!(
                            "POSITION accessor {} does not exist ({} accessors)",
                            index.value(),
                            root.accessors.len()
                        ),
                    ));
                }
            }
        }
    }
    Ok(())
}

/// The `gltf` crate's error as a [`LoadError`]: syntax errors name the line, validation
/// errors the first element they list.
fn json_error(path: &Path, e: gltf::Error) -> LoadError {
    match e {
        gltf::Error::Deserialize(e) => {
            LoadError::parse(path, Location::Line(e.line()), format!("glTF JSON: {e}"))
        }
        gltf::Error::Validation(list) => match list.first() {
            Some((where_, what)) => LoadError::parse(
                path,
                Location::Element(where_.to_string()),
                format!("invalid glTF: {what}"),
            ),
            None => LoadError::Invalid {
                path: path.to_path_buf(),
                message: "invalid glTF".into(),
            },
        },
        other => LoadError::Invalid {
            path: path.to_path_buf(),
            message: format!("glTF: {other}"),
        },
    }
}
