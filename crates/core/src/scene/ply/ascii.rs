//! PLY `ascii` data: one item per line (blank lines between items tolerated), exactly the
//! values its element's properties declare; errors name the line and the element.

use std::path::Path;

use glam::Vec3;

use super::super::error::{LoadError, Location};
use super::header::{face_list, Header, Kind};
use super::mesh::{add_face, as_index, Mesh};

/// Reads the ascii data after the header into `mesh`: every element's items in header order,
/// then nothing but blank lines (data after the last item is an error, as the counts of the
/// header then do not match the data).
pub(super) fn read_ascii(
    path: &Path,
    bytes: &[u8],
    header: &Header,
    vertex_count: u32,
    mesh: &mut Mesh,
) -> Result<(), LoadError> {
    let text = &bytes[header.data_start..];
    let mut lines = text
        .split(|&b| b == b'\n')
        .enumerate()
        .map(|(i, l)| (header.lines + 1 + i, l));
    let end_line = header.lines + 1 + text.split(|&b| b == b'\n').count();
    let mut words: Vec<&str> = Vec::new();
    let mut face: Vec<i64> = Vec::new();
    for e in &header.elements {
        let is_vertex = e.name == "vertex";
        let list = face_list(e);
        if is_vertex {
            // At least 6 bytes ("0 0 0\n") per vertex line: bound the reservation by the input.
            mesh.positions
                .reserve((e.count as usize).min(text.len() / 6));
        } else if list.is_some() {
            mesh.triangles
                .reserve((e.count as usize).min(text.len() / 8));
        }
        let axes = [e.find(&["x"]), e.find(&["y"]), e.find(&["z"])];
        let mut values = vec![0.0f64; e.properties.len()];
        for item in 0..e.count {
            // Blank lines between items are tolerated.
            let (line_no, line) = loop {
                let Some((n, l)) = lines.next() else {
                    return Err(LoadError::parse(
                        path,
                        Location::Line(end_line),
                        format!("element {} item {item}: file ends early", e.name),
                    ));
                };
                let l = std::str::from_utf8(l)
                    .map_err(|_| LoadError::parse(path, Location::Line(n), "not UTF-8 text"))?;
                if !l.trim().is_empty() {
                    break (n, l);
                }
            };
            let err = |message: String| {
                LoadError::parse(
                    path,
                    Location::Line(line_no),
                    format!("element {} item {item}: {message}", e.name),
                )
            };
            words.clear();
            words.extend(line.split_ascii_whitespace());
            let mut w = words.iter();
            let mut next = |what: &str| -> Result<f64, LoadError> {
                let word = w.next().ok_or_else(|| err(format!("missing {what}")))?;
                word.parse::<f64>()
                    .map_err(|_| err(format!("{what} '{word}' is not a number")))
            };
            face.clear();
            for (i, p) in e.properties.iter().enumerate() {
                match p.kind {
                    Kind::Scalar(_) => values[i] = next(&p.name)?,
                    Kind::List { .. } => {
                        let n = usize::try_from(as_index(next("list count")?))
                            .map_err(|_| err(format!("bad count of list {}", p.name)))?;
                        for _ in 0..n {
                            let v = next(&p.name)?;
                            if list == Some(i) {
                                face.push(as_index(v));
                            }
                        }
                    }
                }
            }
            let extra = w.count();
            if extra > 0 {
                return Err(err(format!(
                    "{extra} value(s) more than the element's properties declare ({} on the \
                     line): the data does not match the header",
                    words.len()
                )));
            }
            if is_vertex {
                let [x, y, z] = axes.map(|a| values[a.unwrap_or(0)] as f32);
                mesh.positions.push(Vec3::new(x, y, z));
            } else if list.is_some() {
                add_face(&face, item, vertex_count, mesh).map_err(err)?;
            }
        }
    }
    for (n, l) in lines {
        if !l.trim_ascii().is_empty() {
            let last = header.elements.last().map_or("header", |e| e.name.as_str());
            return Err(LoadError::parse(
                path,
                Location::Line(n),
                format!(
                    "data after the last item of element {last}: the element counts of the \
                     header do not match the data"
                ),
            ));
        }
    }
    Ok(())
}
