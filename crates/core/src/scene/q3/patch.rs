//! Tessellation of Quake 3 bezier patches (surface type 2) into triangles.
//!
//! A patch is a `width x height` grid of control points (both odd, row-major), made of
//! `((width-1)/2) * ((height-1)/2)` biquadratic 3x3 sub-patches that share their border rows and
//! columns. Based on the "Unofficial Quake 3 Map Specs" (section "Faces", bezier patches) as
//! summarised in `shared/scenes/SOURCES.md`.
//!
//! Each sub-patch becomes an `n x n` grid of quads, two triangles each (`2 n²` triangles). The
//! vertices are one `(n*sw + 1) x (n*sh + 1)` grid per patch, so neighbouring sub-patches share
//! their border vertices exactly and a patch is watertight within itself. Triangles are emitted
//! sub-patch by sub-patch (row-major over sub-patches), quads row-major within a sub-patch, and
//! wound clockwise seen from the side the control-point normals face: the same convention as
//! the map's polygon triangles (measured: 99.5 % of czest3ctf's polygon triangles are clockwise
//! about their surface normal, and its patch grids run counter-clockwise in (column, row)).

use glam::Vec3;

/// The tessellation of one patch: new vertices and triangles indexing them (0-based).
#[derive(Debug, Default, PartialEq)]
pub(super) struct Tessellation {
    /// Vertex positions of the evaluated grid.
    pub(super) positions: Vec<Vec3>,
    /// Triangles as indices into `positions`.
    pub(super) triangles: Vec<[u32; 3]>,
}

/// Number of 3x3 sub-patches of a `width x height` control grid (both odd, at least 3).
pub(super) fn sub_patch_count(width: usize, height: usize) -> usize {
    width.saturating_sub(1) / 2 * (height.saturating_sub(1) / 2)
}

/// Quadratic Bernstein weights at `t`.
fn bernstein(t: f32) -> [f32; 3] {
    let s = 1.0 - t;
    [s * s, 2.0 * s * t, t * t]
}

/// Tessellates the patch whose control points are `control` (row-major, `width x height`) with
/// `n` quads along each side of each sub-patch. Returns nothing for `n == 0`.
///
/// Preconditions (checked by the loader with errors): `width` and `height` are odd and at
/// least 3, and `control.len() == width * height`.
pub(super) fn tessellate(control: &[Vec3], width: usize, height: usize, n: usize) -> Tessellation {
    debug_assert!(width % 2 == 1 && height % 2 == 1 && width >= 3 && height >= 3);
    debug_assert_eq!(control.len(), width * height);
    let (sw, sh) = ((width - 1) / 2, (height - 1) / 2);
    if n == 0 {
        return Tessellation::default();
    }
    let (cols, rows) = (n * sw + 1, n * sh + 1);
    // Sub-patch index and local parameter of grid line `k` of `count` sub-patches; the last
    // line belongs to the last sub-patch at parameter 1.
    let local = |k: usize, count: usize| -> (usize, f32) {
        let s = (k / n).min(count - 1);
        (s, (k - s * n) as f32 / n as f32)
    };
    let mut positions = Vec::with_capacity(cols * rows);
    for r in 0..rows {
        let (py, v) = local(r, sh);
        let wv = bernstein(v);
        for c in 0..cols {
            let (px, u) = local(c, sw);
            let wu = bernstein(u);
            let mut p = Vec3::ZERO;
            for (j, &wj) in wv.iter().enumerate() {
                let row = (2 * py + j) * width + 2 * px;
                for (i, &wi) in wu.iter().enumerate() {
                    p += control[row + i] * (wj * wi);
                }
            }
            positions.push(p);
        }
    }
    let mut triangles = Vec::with_capacity(sw * sh * 2 * n * n);
    let at = |r: usize, c: usize| (r * cols + c) as u32;
    for py in 0..sh {
        for px in 0..sw {
            for qr in 0..n {
                for qc in 0..n {
                    let (r, c) = (py * n + qr, px * n + qc);
                    let (p00, p01, p10, p11) =
                        (at(r, c), at(r, c + 1), at(r + 1, c), at(r + 1, c + 1));
                    triangles.push([p00, p10, p01]);
                    triangles.push([p01, p10, p11]);
                }
            }
        }
    }
    Tessellation {
        positions,
        triangles,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A flat 3x3 patch over the unit square in the z = 0 plane.
    fn flat_3x3() -> Vec<Vec3> {
        let mut c = Vec::new();
        for r in 0..3 {
            for col in 0..3 {
                c.push(Vec3::new(col as f32 * 0.5, r as f32 * 0.5, 0.0));
            }
        }
        c
    }

    #[test]
    fn zero_subdivisions_give_nothing() {
        assert_eq!(tessellate(&flat_3x3(), 3, 3, 0), Tessellation::default());
    }

    #[test]
    fn counts_follow_two_n_squared() {
        let control = vec![Vec3::ZERO; 5 * 3];
        for n in 1..5 {
            let t = tessellate(&control, 5, 3, n);
            assert_eq!(t.triangles.len(), 2 * 2 * n * n);
            assert_eq!(t.positions.len(), (2 * n + 1) * (n + 1));
        }
        assert_eq!(sub_patch_count(5, 3), 2);
        assert_eq!(sub_patch_count(0, 0), 0);
    }

    #[test]
    fn flat_patch_interpolates_corners_and_is_clockwise_about_plus_y_cross_x() {
        let t = tessellate(&flat_3x3(), 3, 3, 4);
        assert_eq!(t.positions[0], Vec3::ZERO);
        assert_eq!(t.positions[24], Vec3::new(1.0, 1.0, 0.0));
        // Control grid (column +x, row +y) runs counter-clockwise about +z, so triangles must be
        // clockwise about +z.
        for [a, b, c] in t.triangles {
            let (a, b, c) = (
                t.positions[a as usize],
                t.positions[b as usize],
                t.positions[c as usize],
            );
            assert!((b - a).cross(c - a).z < 0.0);
        }
    }

    #[test]
    fn curved_patch_passes_through_middle_control_point_weighted() {
        // Middle control point lifted: the surface centre is at 1/4 of its height per axis.
        let mut c = flat_3x3();
        c[4].z = 1.0;
        let t = tessellate(&c, 3, 3, 2);
        assert!((t.positions[4].z - 0.25).abs() < 1e-6);
    }
}
