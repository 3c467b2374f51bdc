//! The PLY header (Turk 1994): `format`, `element NAME COUNT` blocks with their `property`
//! lines, up to `end_header`, parsed into the element layout the data readers follow.

use std::path::Path;
use std::str::SplitAsciiWhitespace;

use super::super::error::{LoadError, Location};

/// A scalar type of the PLY header.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    /// The type named `name` (a 1994 name or a sized alias), if any.
    fn parse(name: &str) -> Option<Scalar> {
        Some(match name {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    /// Bytes per value.
    pub(super) fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    /// Whether values of this type are integers (list counts must be).
    fn is_integer(self) -> bool {
        !matches!(self, Scalar::F32 | Scalar::F64)
    }

    /// Reads one value at the start of `b` (which holds at least `self.size()` bytes).
    #[inline]
    pub(super) fn read(self, b: &[u8], big: bool) -> f64 {
        macro_rules! get {
            ($t:ty, $n:expr) => {{
                let mut a = [0u8; $n];
                a.copy_from_slice(&b[..$n]);
                if big {
                    <$t>::from_be_bytes(a)
                } else {
                    <$t>::from_le_bytes(a)
                }
            }};
        }
        match self {
            Scalar::I8 => f64::from(b[0] as i8),
            Scalar::U8 => f64::from(b[0]),
            Scalar::I16 => f64::from(get!(i16, 2)),
            Scalar::U16 => f64::from(get!(u16, 2)),
            Scalar::I32 => f64::from(get!(i32, 4)),
            Scalar::U32 => f64::from(get!(u32, 4)),
            Scalar::F32 => f64::from(get!(f32, 4)),
            Scalar::F64 => get!(f64, 8),
        }
    }
}

/// A property of an element: a scalar or a list.
#[derive(Clone, Debug)]
pub(super) enum Kind {
    Scalar(Scalar),
    List { count: Scalar, item: Scalar },
}

/// A `property` line: the property's name and type.
#[derive(Clone, Debug)]
pub(super) struct Property {
    pub(super) name: String,
    pub(super) kind: Kind,
}

/// An `element` block: its name, item count and properties in order.
#[derive(Clone, Debug)]
pub(super) struct Element {
    pub(super) name: String,
    pub(super) count: u64,
    pub(super) properties: Vec<Property>,
}

impl Element {
    /// Bytes per item when every property is a scalar.
    pub(super) fn fixed_stride(&self) -> Option<usize> {
        self.properties
            .iter()
            .map(|p| match p.kind {
                Kind::Scalar(s) => Some(s.size()),
                Kind::List { .. } => None,
            })
            .sum()
    }

    /// Index of the first property with one of these names.
    pub(super) fn find(&self, names: &[&str]) -> Option<usize> {
        self.properties
            .iter()
            .position(|p| names.contains(&p.name.as_str()))
    }
}

/// How the data after the header is written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Encoding {
    Ascii,
    BinaryLittle,
    BinaryBig,
}

/// What the header declares.
pub(super) struct Header {
    pub(super) encoding: Encoding,
    pub(super) elements: Vec<Element>,
    /// Byte offset of the first data byte.
    pub(super) data_start: usize,
    /// Number of header lines (ascii data starts at line `lines + 1`).
    pub(super) lines: usize,
}
/// Parses the header: the encoding, every element with its properties, and where the data
/// starts. Errors name the header line; a vertex element without scalar `x`, `y` and `z` is
/// an error naming the element.
pub(super) fn parse_header(path: &Path, bytes: &[u8]) -> Result<Header, LoadError> {
    let line_err = |line: usize, message: String| {
        LoadError::parse(path, Location::Line(line), format!("header: {message}"))
    };
    if !bytes.starts_with(b"ply") {
        return Err(LoadError::parse(
            path,
            Location::Byte(0),
            "not a PLY file (does not start with 'ply')",
        ));
    }
    let mut encoding = None;
    let mut elements: Vec<Element> = Vec::new();
    let mut pos = 0usize;
    let mut line_no = 0usize;
    loop {
        line_no += 1;
        let Some(len) = bytes[pos..].iter().position(|&b| b == b'\n') else {
            return Err(line_err(line_no, "no 'end_header' line".into()));
        };
        let raw = &bytes[pos..pos + len];
        pos += len + 1;
        let text = String::from_utf8_lossy(raw);
        let mut words = text.split_ascii_whitespace();
        let parsed = match words.next() {
            Some("ply") | Some("comment") | Some("obj_info") | None => Ok(()),
            Some("format") => parse_format(words.next()).map(|e| encoding = Some(e)),
            Some("element") => parse_element(&mut words, &mut elements),
            Some("property") => parse_property(&mut words, &mut elements),
            Some("end_header") => break,
            Some(other) => Err(format!("unknown header keyword '{other}'")),
        };
        parsed.map_err(|message| line_err(line_no, message))?;
    }
    let encoding = encoding.ok_or_else(|| line_err(line_no, "no 'format' line".into()))?;
    check_vertex_axes(path, &elements)?;
    Ok(Header {
        encoding,
        elements,
        data_start: pos,
        lines: line_no,
    })
}

/// The encoding a `format` line names (`word` is the one after `format`).
fn parse_format(word: Option<&str>) -> Result<Encoding, String> {
    match word {
        Some("ascii") => Ok(Encoding::Ascii),
        Some("binary_little_endian") => Ok(Encoding::BinaryLittle),
        Some("binary_big_endian") => Ok(Encoding::BinaryBig),
        other => Err(format!("unknown format {:?}", other.unwrap_or(""))),
    }
}

/// Appends the element an `element NAME COUNT` line declares (`words` follow `element`); a
/// name declared before is an error.
fn parse_element(
    words: &mut SplitAsciiWhitespace<'_>,
    elements: &mut Vec<Element>,
) -> Result<(), String> {
    let (Some(name), Some(count)) = (words.next(), words.next()) else {
        return Err("element needs a name and a count".into());
    };
    let count = count
        .parse::<u64>()
        .map_err(|_| format!("bad element count '{count}'"))?;
    if elements.iter().any(|e| e.name == name) {
        return Err(format!(
            "a second 'element {name}' (each element is declared once)"
        ));
    }
    elements.push(Element {
        name: name.to_string(),
        count,
        properties: Vec::new(),
    });
    Ok(())
}

/// Appends the property a `property TYPE NAME` or `property list COUNT ITEM NAME` line
/// declares (`words` follow `property`) to the last element.
fn parse_property(
    words: &mut SplitAsciiWhitespace<'_>,
    elements: &mut [Element],
) -> Result<(), String> {
    let Some(element) = elements.last_mut() else {
        return Err("property before any element".into());
    };
    let ty = words.next().unwrap_or("");
    let scalar = |name: Option<&str>| {
        let name = name.unwrap_or("");
        Scalar::parse(name).ok_or_else(|| format!("unknown type '{name}'"))
    };
    let kind = if ty == "list" {
        let count = scalar(words.next())?;
        let item = scalar(words.next())?;
        if !count.is_integer() {
            return Err("list count type must be an integer".into());
        }
        Kind::List { count, item }
    } else {
        Kind::Scalar(scalar(Some(ty))?)
    };
    let Some(name) = words.next() else {
        return Err("property without a name".into());
    };
    element.properties.push(Property {
        name: name.to_string(),
        kind,
    });
    Ok(())
}

/// A `vertex` element must have scalar `x`, `y` and `z` properties.
fn check_vertex_axes(path: &Path, elements: &[Element]) -> Result<(), LoadError> {
    for e in elements {
        if e.name == "vertex" {
            for axis in ["x", "y", "z"] {
                match e.find(&[axis]).map(|i| &e.properties[i].kind) {
                    Some(Kind::Scalar(_)) => {}
                    _ => {
                        return Err(LoadError::parse(
                            path,
                            Location::Element("element vertex".into()),
                            format!("no scalar property '{axis}'"),
                        ))
                    }
                }
            }
        }
    }
    Ok(())
}

/// Index of the face element's vertex list property, if this is a face element with one.
pub(super) fn face_list(e: &Element) -> Option<usize> {
    if e.name != "face" {
        return None;
    }
    e.find(&["vertex_indices", "vertex_index"])
        .filter(|&i| matches!(e.properties[i].kind, Kind::List { .. }))
}
