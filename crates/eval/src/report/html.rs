//! The HTML page of a report: escaping, tables, inline images, and the page shell (inline CSS
//! and one small inline script that sorts tables; no network, no external files).

use std::fmt::Write as _;

use image::RgbImage;

use super::base64;
use super::error::ReportError;

/// `s` with the five HTML-special characters escaped (safe in text and in quoted attributes).
pub fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            _ => out.push(c),
        }
    }
    out
}

/// `image` as a `data:image/png;base64,...` URI.
pub(crate) fn png_data_uri(image: &RgbImage) -> Result<String, ReportError> {
    let mut bytes = std::io::Cursor::new(Vec::new());
    image.write_to(&mut bytes, image::ImageFormat::Png)?;
    Ok(format!(
        "data:image/png;base64,{}",
        base64::encode(bytes.get_ref())
    ))
}

/// An `<img>` element showing `image` inline.
pub fn img(image: &RgbImage, alt: &str, width: u32) -> Result<String, ReportError> {
    Ok(format!(
        "<img src=\"{}\" alt=\"{}\" width=\"{width}\">",
        png_data_uri(image)?,
        escape(alt)
    ))
}

/// One cell of a table row: text (escaped) or numeric (right-aligned).
pub enum Cell {
    /// Left-aligned text.
    Text(String),
    /// A right-aligned number, already formatted.
    Num(String),
}

/// A table with a header row; `id` names it for the page and for tests. Rows may carry
/// `data-*` attributes so the numbers can be read back from the DOM exactly.
pub struct Table {
    id: String,
    header: Vec<String>,
    rows: String,
}

impl Table {
    /// An empty table with these column names.
    pub fn new(id: &str, header: &[&str]) -> Self {
        Self {
            id: id.to_string(),
            header: header.iter().map(|h| h.to_string()).collect(),
            rows: String::new(),
        }
    }

    /// Appends a row; `data` are `(name, value)` pairs written as `data-name="value"`.
    pub fn row(&mut self, cells: Vec<Cell>, data: &[(&str, String)]) {
        self.row_with(cells, data, &[]);
    }

    /// [`Table::row`] with further attributes (`id`, `class`) on the row.
    pub fn row_with(&mut self, cells: Vec<Cell>, data: &[(&str, String)], attrs: &[(&str, &str)]) {
        self.rows.push_str("<tr");
        for (name, value) in data {
            let _ = write!(self.rows, " data-{}=\"{}\"", escape(name), escape(value));
        }
        for (name, value) in attrs {
            let _ = write!(self.rows, " {}=\"{}\"", escape(name), escape(value));
        }
        self.rows.push('>');
        for c in cells {
            match c {
                Cell::Text(t) => {
                    let _ = write!(self.rows, "<td>{}</td>", escape(&t));
                }
                Cell::Num(n) => {
                    let _ = write!(self.rows, "<td class=\"num\">{}</td>", escape(&n));
                }
            }
        }
        self.rows.push_str("</tr>\n");
    }

    /// The table's HTML.
    pub fn html(&self) -> String {
        let header: String = self
            .header
            .iter()
            .map(|h| format!("<th>{}</th>", escape(h)))
            .collect();
        format!(
            "<table id=\"{}\" class=\"sortable\"><thead><tr>{header}</tr></thead>\n<tbody>\n{}</tbody></table>\n",
            escape(&self.id),
            self.rows
        )
    }
}

/// A two-column key/value table.
pub(crate) fn key_value_table(id: &str, rows: &[(&str, String)]) -> String {
    let mut t = format!("<table id=\"{}\" class=\"kv\">\n", escape(id));
    for (k, v) in rows {
        let _ = writeln!(t, "<tr><th>{}</th><td>{}</td></tr>", escape(k), escape(v));
    }
    t.push_str("</table>\n");
    t
}

/// A titled part of the page; `body` is HTML.
pub struct Section {
    /// Anchor id.
    pub id: String,
    /// Heading (plain text, escaped when written).
    pub title: String,
    /// Body HTML.
    pub body: String,
}

impl Section {
    /// A section from its parts.
    pub fn new(id: &str, title: &str, body: String) -> Self {
        Self {
            id: id.to_string(),
            title: title.to_string(),
            body,
        }
    }
}

const STYLE: &str = "body{font-family:sans-serif;max-width:1180px;margin:1.5em auto;padding:0 1em;\
background:#fafafa;color:#222}h1{margin-bottom:.2em}h2{border-bottom:1px solid #ccc;\
padding-bottom:.2em;margin-top:1.6em}table{border-collapse:collapse;margin:.5em 0}\
td,th{border:1px solid #ccc;padding:3px 7px;font-size:13px}th{background:#eee}\
td.num{text-align:right;font-variant-numeric:tabular-nums}table.sortable th{cursor:pointer}\
nav a{margin-right:1em}figure{display:inline-block;margin:.4em;vertical-align:top}\
figcaption{font-size:12px;max-width:400px}figure.worst img{image-rendering:pixelated}.note{color:#555;font-style:italic}\
svg{background:#fff;border:1px solid #ddd}\
#cell-table-all:not(:checked)~#cell-table tr.rest{display:none}\
#map-by-pvs:checked~svg .by-error,#map-by-error:checked~svg .by-pvs{display:none}\
#floor-1:checked~svg .floor:not(.band-1),#floor-2:checked~svg .floor:not(.band-2),\
#floor-3:checked~svg .floor:not(.band-3),#floor-4:checked~svg .floor:not(.band-4){display:none}\
.controls{margin:.3em 0}.controls label{margin-right:1em}tr:target{outline:2px solid #d00}";

/// Sorts a table by the clicked column (numbers numerically), so long per-cell tables can be
/// read from the worst cell down; filters the cell table's rows by the text typed in its filter
/// box (or given in the page address as `#cell-filter=TEXT`, so a filtered view can be linked
/// to), showing the matching rows even among those collapsed. Written defensively: it must
/// never raise a console error.
const SCRIPT: &str = "document.querySelectorAll('table.sortable').forEach(function(t){\
var hs=t.querySelectorAll('thead th');hs.forEach(function(h,i){h.addEventListener('click',\
function(){var b=t.tBodies[0];if(!b)return;var rs=Array.prototype.slice.call(b.rows);\
var asc=h.getAttribute('data-sort')!=='asc';hs.forEach(function(o){o.removeAttribute('data-sort');});\
h.setAttribute('data-sort',asc?'asc':'desc');rs.sort(function(x,y){\
var a=x.cells[i]?x.cells[i].textContent:'',c=y.cells[i]?y.cells[i].textContent:'';\
var p=parseFloat(a),q=parseFloat(c);var r=(isNaN(p)||isNaN(q))?a.localeCompare(c):p-q;\
return asc?r:-r;});rs.forEach(function(r){b.appendChild(r);});});});});\
(function(){var t=document.getElementById('cell-table'),f=document.getElementById('cell-table-filter');\
if(!t||!f||!t.tBodies[0])return;function apply(){var q=f.value.trim().toLowerCase();\
Array.prototype.forEach.call(t.tBodies[0].rows,function(r){\
r.style.display=!q?'':(r.textContent.toLowerCase().indexOf(q)>=0?'table-row':'none');});}\
f.addEventListener('input',apply);var m=/^#cell-filter=(.*)$/.exec(location.hash);\
if(m){try{f.value=decodeURIComponent(m[1]);}catch(e){f.value=m[1];}apply();}})();";

/// The whole page: title, a one-line intro, a table of contents and the sections.
pub fn page(title: &str, intro: &str, sections: &[Section]) -> String {
    let nav: String = sections
        .iter()
        .map(|s| format!("<a href=\"#{}\">{}</a>", escape(&s.id), escape(&s.title)))
        .collect();
    let mut body = String::new();
    for s in sections {
        let _ = write!(
            body,
            "<section id=\"{}\">\n<h2>{}</h2>\n{}</section>\n",
            escape(&s.id),
            escape(&s.title),
            s.body
        );
    }
    format!(
        "<!doctype html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\
         <meta name=\"viewport\" content=\"width=device-width\">\
         <title>{t}</title>\n<style>{STYLE}</style></head>\n<body>\n<h1>{t}</h1>\n<p>{}</p>\n\
         <nav>{nav}</nav>\n{body}<script>{SCRIPT}</script>\n</body></html>\n",
        escape(intro),
        t = escape(title),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escape_of_empty_is_empty() {
        assert_eq!(escape(""), "");
    }

    #[test]
    fn escape_replaces_every_special_character() {
        assert_eq!(
            escape("<a href=\"x\">Tom & 'Jerry'</a>"),
            "&lt;a href=&quot;x&quot;&gt;Tom &amp; &#39;Jerry&#39;&lt;/a&gt;"
        );
    }

    #[test]
    fn escape_keeps_unicode() {
        assert_eq!(escape("256² ⊆ ok"), "256² ⊆ ok");
    }

    #[test]
    fn table_escapes_cells_and_attributes() {
        let mut t = Table::new("t<1>", &["a&b"]);
        t.row(
            vec![Cell::Text("<script>".into())],
            &[("cell", "\"0\"".into())],
        );
        let h = t.html();
        assert!(h.contains("id=\"t&lt;1&gt;\""));
        assert!(h.contains("<th>a&amp;b</th>"));
        assert!(h.contains("<td>&lt;script&gt;</td>"));
        assert!(h.contains("data-cell=\"&quot;0&quot;\""));
        assert!(!h.contains("<script>"));
    }

    #[test]
    fn page_escapes_title_and_has_no_external_references() {
        let p = page(
            "a <b>",
            "intro & more",
            &[Section::new("s1", "One & two", "<p>x</p>".into())],
        );
        assert!(p.contains("<title>a &lt;b&gt;</title>"));
        assert!(p.contains("intro &amp; more"));
        assert!(p.contains("<h2>One &amp; two</h2>"));
        assert!(!p.contains("http://") && !p.contains("https://"));
        assert!(!p.contains(" src=\""));
    }

    #[test]
    fn png_data_uri_round_trips() {
        let img = RgbImage::from_pixel(3, 2, image::Rgb([10, 20, 30]));
        let uri = png_data_uri(&img).unwrap();
        assert!(uri.starts_with("data:image/png;base64,iVBORw0KGgo"));
    }
}
