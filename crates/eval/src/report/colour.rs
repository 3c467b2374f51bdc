//! The colour scale of the map: values to colours along a perceptually ordered ramp (dark
//! purple for the smallest PVS, yellow for the largest, after matplotlib's viridis, sampled at
//! five stops and interpolated linearly), and its legend as SVG. Public so that other views
//! of the cells (the viewer's top-down overview) colour them exactly as the report's map does.

use std::fmt::Write as _;

use super::html::escape;

/// Five stops of viridis at 0, 1/4, 1/2, 3/4, 1.
const STOPS: [[u8; 3]; 5] = [
    [68, 1, 84],
    [59, 82, 139],
    [33, 145, 140],
    [94, 201, 98],
    [253, 231, 37],
];

/// The ramp's colour at `t` in [0, 1] (clamped; NaN gives the low end).
pub fn ramp(t: f64) -> [u8; 3] {
    let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
    let x = t * (STOPS.len() - 1) as f64;
    let i = (x.floor() as usize).min(STOPS.len() - 2);
    let f = x - i as f64;
    let (a, b) = (STOPS[i], STOPS[i + 1]);
    [0, 1, 2].map(|k| (a[k] as f64 + (b[k] as f64 - a[k] as f64) * f).round() as u8)
}

/// `#rrggbb` of a colour.
pub fn hex(c: [u8; 3]) -> String {
    format!("#{:02x}{:02x}{:02x}", c[0], c[1], c[2])
}

/// A linear scale from `[min, max]` onto the ramp.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ColourScale {
    /// Value at the low end.
    pub min: f64,
    /// Value at the high end.
    pub max: f64,
}

impl ColourScale {
    /// The scale spanning `values` (0..1 when empty).
    pub fn spanning(values: impl IntoIterator<Item = f64>) -> Self {
        let (mut min, mut max) = (f64::INFINITY, f64::NEG_INFINITY);
        for v in values.into_iter().filter(|v| v.is_finite()) {
            min = min.min(v);
            max = max.max(v);
        }
        if min > max {
            (min, max) = (0.0, 1.0);
        }
        Self { min, max }
    }

    /// Position of `v` on the scale in [0, 1]; the middle when the range is one value.
    pub fn position(&self, v: f64) -> f64 {
        if self.max - self.min <= f64::EPSILON * self.max.abs().max(1.0) {
            return 0.5;
        }
        ((v - self.min) / (self.max - self.min)).clamp(0.0, 1.0)
    }

    /// The colour of `v`.
    pub fn colour(&self, v: f64) -> [u8; 3] {
        ramp(self.position(v))
    }

    /// An SVG group: a horizontal gradient bar `width` x 12 at `(x, y)` with the end values
    /// and `label` written under it. `id` must be unique in the page (gradient id).
    pub(crate) fn legend_svg(&self, id: &str, x: f64, y: f64, width: f64, label: &str) -> String {
        let mut stops = String::new();
        for k in 0..=8 {
            let t = k as f64 / 8.0;
            let _ = write!(
                stops,
                "<stop offset=\"{:.3}\" stop-color=\"{}\"/>",
                t,
                hex(ramp(t))
            );
        }
        let id = escape(id);
        format!(
            "<g class=\"legend\"><defs><linearGradient id=\"{id}\" x1=\"0\" x2=\"1\" y1=\"0\" y2=\"0\">{stops}\
             </linearGradient></defs><rect x=\"{x:.1}\" y=\"{y:.1}\" width=\"{width:.1}\" height=\"12\" \
             fill=\"url(#{id})\" stroke=\"#444\" stroke-width=\"0.5\"/>\
             <text x=\"{x:.1}\" y=\"{ty:.1}\" font-size=\"12\">{min}</text>\
             <text x=\"{xm:.1}\" y=\"{ty:.1}\" font-size=\"12\" text-anchor=\"middle\">{label}</text>\
             <text x=\"{xe:.1}\" y=\"{ty:.1}\" font-size=\"12\" text-anchor=\"end\">{max}</text></g>",
            ty = y + 26.0,
            xm = x + width / 2.0,
            xe = x + width,
            min = escape(&format_value(self.min)),
            max = escape(&format_value(self.max)),
            label = escape(label),
        )
    }
}

/// A compact number: integers without decimals, others with three significant digits.
pub(crate) fn format_value(v: f64) -> String {
    if (v.fract() == 0.0 && v.abs() < 1e15) || v.abs() >= 100.0 {
        format!("{v:.0}")
    } else {
        format!("{v:.3}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn luminance(c: [u8; 3]) -> f64 {
        0.2126 * c[0] as f64 + 0.7152 * c[1] as f64 + 0.0722 * c[2] as f64
    }

    #[test]
    fn ramp_ends_are_the_first_and_last_stops() {
        assert_eq!(ramp(0.0), STOPS[0]);
        assert_eq!(ramp(1.0), STOPS[4]);
        assert_eq!(ramp(0.5), STOPS[2]);
    }

    #[test]
    fn ramp_clamps_out_of_range_and_nan() {
        assert_eq!(ramp(-3.0), STOPS[0]);
        assert_eq!(ramp(7.0), STOPS[4]);
        assert_eq!(ramp(f64::NAN), STOPS[0]);
    }

    #[test]
    fn ramp_gets_brighter_from_low_to_high() {
        let l: Vec<f64> = (0..=20).map(|k| luminance(ramp(k as f64 / 20.0))).collect();
        assert!(l.windows(2).all(|w| w[1] > w[0]), "{l:?}");
    }

    #[test]
    fn scale_of_no_values_is_unit() {
        let s = ColourScale::spanning([]);
        assert_eq!((s.min, s.max), (0.0, 1.0));
    }

    #[test]
    fn scale_maps_its_range_onto_the_ramp() {
        let s = ColourScale::spanning([30.0, 10.0, 20.0, f64::NAN]);
        assert_eq!((s.min, s.max), (10.0, 30.0));
        assert_eq!(s.colour(10.0), ramp(0.0));
        assert_eq!(s.colour(30.0), ramp(1.0));
        assert_eq!(s.position(20.0), 0.5);
        assert_eq!(s.position(99.0), 1.0);
    }

    #[test]
    fn scale_of_one_value_is_the_middle_colour() {
        let s = ColourScale::spanning([5.0, 5.0]);
        assert_eq!(s.colour(5.0), ramp(0.5));
    }

    #[test]
    fn hex_pads_with_zeros() {
        assert_eq!(hex([1, 0xab, 255]), "#01abff");
    }

    #[test]
    fn legend_shows_both_ends_and_escapes_label() {
        let s = ColourScale {
            min: 3.0,
            max: 1200.0,
        };
        let svg = s.legend_svg("g1", 0.0, 0.0, 200.0, "PVS <triangles>");
        assert!(svg.contains(">3<") && svg.contains(">1200<"));
        assert!(svg.contains("PVS &lt;triangles&gt;"));
        assert!(svg.contains("url(#g1)"));
    }
}
