//! Connected regions of erroneous pixels (4-connectivity): a single large region is more
//! noticeable than scattered pixels, so Koch & Wimmer 2021 (section 6) report the number and
//! the maximum size of connected error regions besides the pixel count.

/// Number of 4-connected regions of `true` pixels in the `width x height` mask, and the size of
/// the largest (0, 0 for an empty mask).
pub fn connected_regions(mask: &[bool], width: usize, height: usize) -> (usize, usize) {
    assert_eq!(
        mask.len(),
        width * height,
        "mask size must be width x height"
    );
    let mut seen = vec![false; mask.len()];
    let mut stack = Vec::new();
    let (mut regions, mut largest) = (0, 0);
    for start in 0..mask.len() {
        if !mask[start] || seen[start] {
            continue;
        }
        regions += 1;
        let mut size = 0;
        seen[start] = true;
        stack.push(start);
        while let Some(p) = stack.pop() {
            size += 1;
            let (x, y) = (p % width, p / width);
            let mut visit = |q: usize| {
                if mask[q] && !seen[q] {
                    seen[q] = true;
                    stack.push(q);
                }
            };
            if x > 0 {
                visit(p - 1);
            }
            if x + 1 < width {
                visit(p + 1);
            }
            if y > 0 {
                visit(p - width);
            }
            if y + 1 < height {
                visit(p + width);
            }
        }
        largest = largest.max(size);
    }
    (regions, largest)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mask(rows: &[&str]) -> (Vec<bool>, usize, usize) {
        let w = rows[0].len();
        (
            rows.iter()
                .flat_map(|r| r.chars().map(|c| c == '#'))
                .collect(),
            w,
            rows.len(),
        )
    }

    #[test]
    fn empty_mask_has_no_regions() {
        assert_eq!(connected_regions(&[], 0, 0), (0, 0));
        let (m, w, h) = mask(&["...", "..."]);
        assert_eq!(connected_regions(&m, w, h), (0, 0));
    }

    #[test]
    fn diagonal_pixels_are_separate_regions() {
        let (m, w, h) = mask(&["#..", ".#.", "..#"]);
        assert_eq!(connected_regions(&m, w, h), (3, 1));
    }

    #[test]
    fn regions_do_not_wrap_around_rows() {
        let (m, w, h) = mask(&["..#", "#.."]);
        assert_eq!(connected_regions(&m, w, h), (2, 1));
    }

    #[test]
    fn snake_is_one_region() {
        let (m, w, h) = mask(&["###.", "..#.", "###.", "#..#"]);
        assert_eq!(connected_regions(&m, w, h), (2, 8));
    }
}
