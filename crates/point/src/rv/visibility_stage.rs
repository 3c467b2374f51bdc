//! The visibility stage for one bin: clip each queued triangle to the bin's frustum, test it
//! against the bin's occluders, mark it visible when not occluded and offer it to the occluders.
//!
//! Based on: Ivanchenko. Massively Parallel Analytic Visibility for Streaming Virtual Reality.
//! 2021, chapter 5 ("clipping against bin", figures 5.7-5.8) and section 6.3 (triangles of a bin
//! are processed one by one, in stream order, against the bin's occluder state; a triangle is
//! visible as soon as it is visible in one bin, so the visible set only ever gains bits).

use glam::{DVec2, DVec3};
use sightline_core::atomic_set::AtomicTriangleSet;

use super::geometry_stage::ProjTri;
use super::memory::Pool;
use super::occluders::{AddOutcome, BinState, Limits};
use super::occlusion_test::{is_occluded, Occludee, TestCounters};
use super::overlap::Rect;
use super::projection::{clip_into, Poly, Projection, MAX_POLY};
use super::types::HiddenOccluders;

/// Per-worker statistics of the visibility stage.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct StageStats {
    pub(crate) tested: u64,
    pub(crate) occluded: u64,
    pub(crate) visible: u64,
    pub(crate) clipped_away: u64,
    pub(crate) occluders_created: u64,
    pub(crate) occluders_grown: u64,
    pub(crate) occluder_merges: u64,
    pub(crate) pool_full: u64,
    /// Occluded only by several occluders together (`fusion.rs`).
    pub(crate) fused_occluded: u64,
    /// Accepted untested by the initialization phase.
    pub(crate) init_accepted: u64,
    pub(crate) counters: TestCounters,
}

impl StageStats {
    /// Adds another worker's counts.
    pub(crate) fn add(&mut self, b: &StageStats) {
        self.tested += b.tested;
        self.occluded += b.occluded;
        self.visible += b.visible;
        self.clipped_away += b.clipped_away;
        self.occluders_created += b.occluders_created;
        self.occluders_grown += b.occluders_grown;
        self.occluder_merges += b.occluder_merges;
        self.pool_full += b.pool_full;
        self.fused_occluded += b.fused_occluded;
        self.init_accepted += b.init_accepted;
        self.counters.silhouette_tests += b.counters.silhouette_tests;
        self.counters.triangle_tests += b.counters.triangle_tests;
    }
}

/// What one bin's processing needs that does not change during a run.
pub(crate) struct BinContext<'a> {
    pub(crate) proj: &'a Projection,
    /// The bin's frustum, grown by the margin.
    pub(crate) planes: [[f64; 4]; 4],
    /// The bin's screen rectangle, grown by the margin (the same region as `planes`).
    pub(crate) bin_rect: Rect,
    pub(crate) margin: f64,
    /// Positive-area semantics ([`super::Guarantee::PositiveArea`]).
    pub(crate) area: bool,
    pub(crate) limits: &'a Limits,
    pub(crate) pool: &'a Pool,
    pub(crate) visible: &'a AtomicTriangleSet,
    /// Whether visible triangles join the occluders (false in the re-test pass).
    pub(crate) build: bool,
    /// The initialization phase (thesis section 6.3.4): accept without testing.
    pub(crate) init: bool,
    /// Whether hidden triangles join the occluders ([`RvOptions::hidden_occluders`]).
    pub(crate) hidden: HiddenOccluders,
}

/// Runs the visibility stage on triangle `t` in the bin of `ctx`.
pub(crate) fn process(
    t: &ProjTri,
    ctx: &BinContext<'_>,
    state: &mut BinState,
    st: &mut StageStats,
) {
    // Most triangles of a large scene are small and lie inside one bin: then clipping to the
    // bin's frustum would return them unchanged, so it is skipped and the triangle's own
    // corners and screen points are used. (Keeping the unclipped triangle where rounding might
    // have shaved a sliver off is conservative: a larger occludee is never easier to occlude.
    // The same holds for each bin side the triangle's screen bounds do not cross, which is not
    // clipped against either.)
    let tri_rect = Rect::of(&t.screen);
    let inside_bin = t.whole_front && ctx.bin_rect.contains(&tri_rect, 0.0);
    // Initialised only where clipping needs them (a few hundred bytes each).
    let (mut first, mut second, mut screen_buf);
    let (verts, screen): (&[DVec3], &[DVec2]) = if inside_bin {
        (&t.corners, &t.screen)
    } else {
        // Clip back and forth between two buffers (a polygon is a few hundred bytes).
        first = Poly::from_slice(&t.corners);
        second = Poly::new();
        let (mut poly, mut other) = (&mut first, &mut second);
        if !t.whole_front && clip_into(poly, &ctx.proj.near_plane(), other) {
            std::mem::swap(&mut poly, &mut other);
        }
        let b = &ctx.bin_rect;
        // `BinContext::planes` order: x >= min.x, x <= max.x, y >= min.y, y <= max.y.
        let crossed = [
            tri_rect.min.x < b.min.x,
            tri_rect.max.x > b.max.x,
            tri_rect.min.y < b.min.y,
            tri_rect.max.y > b.max.y,
        ];
        for (plane, crosses) in ctx.planes.iter().zip(crossed) {
            if (crosses || !t.whole_front) && clip_into(poly, plane, other) {
                std::mem::swap(&mut poly, &mut other);
            }
        }
        if poly.is_empty() {
            st.clipped_away += 1;
            return;
        }
        screen_buf = [DVec2::ZERO; MAX_POLY];
        for (s, v) in screen_buf.iter_mut().zip(poly.as_slice()) {
            *s = ctx.proj.screen_of(*v);
        }
        let poly: &Poly = poly;
        (poly.as_slice(), &screen_buf[..poly.len])
    };
    st.tested += 1;
    let (mut zmin, mut zmax) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in verts {
        zmin = zmin.min(v.z);
        zmax = zmax.max(v.z);
    }
    let p = Occludee {
        poly: verts,
        screen,
        rect: if inside_bin {
            tri_rect
        } else {
            Rect::of(screen)
        },
        zmin,
        zmax,
        plane: std::cell::OnceCell::new(),
        corners: &t.corners,
        tri_screen: t.whole_front.then_some(&t.screen),
        area: ctx.area,
    };
    let mut occluded = false;
    if ctx.init {
        st.init_accepted += 1;
    } else if !state.occluders.is_empty() {
        if is_occluded(&p, state, ctx.proj, ctx.margin, &mut st.counters) {
            st.occluded += 1;
            occluded = true;
        } else if state
            .fused
            .hides(screen, &p.rect, zmin, &ctx.bin_rect, ctx.margin)
        {
            st.occluded += 1;
            st.fused_occluded += 1;
            occluded = true;
        }
    }
    if !occluded {
        st.visible += 1;
        ctx.visible.insert(t.id);
    }
    // A hidden triangle is still a surface: as an occluder it is as sound as a visible one
    // (beyond the thesis, which only builds occluders from visible triangles).
    let may_start = match (occluded, ctx.hidden) {
        (false, _) | (true, HiddenOccluders::All) => true,
        (true, HiddenOccluders::Joining) => false,
        (true, HiddenOccluders::Never) => return,
    };
    if ctx.build {
        offer(t, ctx, state, st, may_start);
    }
}

/// Offers triangle `t` to the bin's occluders (starting one only when `may_start`), and
/// updates the fused grid with the occluder that took it.
fn offer(
    t: &ProjTri,
    ctx: &BinContext<'_>,
    state: &mut BinState,
    st: &mut StageStats,
    may_start: bool,
) {
    let outcome = state.add(t, ctx.limits, ctx.pool, may_start);
    match outcome {
        AddOutcome::New => st.occluders_created += 1,
        AddOutcome::Grown => st.occluders_grown += 1,
        AddOutcome::Merged => st.occluder_merges += 1,
        AddOutcome::Full => st.pool_full += 1,
        AddOutcome::NotEligible => {}
    }
    if matches!(
        outcome,
        AddOutcome::New | AddOutcome::Grown | AddOutcome::Merged
    ) {
        // `add` puts the occluder that took the triangle last.
        let BinState {
            occluders, fused, ..
        } = state;
        if let Some(o) = occluders.last() {
            fused.update(o, &Rect::of(&t.screen), &ctx.bin_rect, ctx.margin, ctx.pool);
        }
    }
}

/// Occluder fusion as this stage feeds it: occluders built by the bin state, the fused grid
/// updated with the occluder that took each triangle.
#[cfg(test)]
mod tests {
    use super::*;
    use crate::rv::fusion::FusedDepth;

    const MARGIN: f64 = 4e-3;

    fn bin() -> Rect {
        Rect {
            min: DVec2::new(0.0, 0.0),
            max: DVec2::new(16.0, 16.0),
        }
    }

    /// A screen-space triangle at view depth `z` (screen and view coordinates equal: enough
    /// for the grid, which only reads screen corners and depths).
    fn tri(s: [[f64; 2]; 3], z: f64) -> ProjTri {
        ProjTri {
            id: 0,
            corners: s.map(|p| DVec3::new(p[0], p[1], z)),
            screen: s.map(|p| DVec2::new(p[0], p[1])),
            whole_front: true,
            front: true,
        }
    }

    /// Adds a triangle to the bin's occluders and updates the grid as the visibility stage does.
    fn add(state: &mut BinState, t: &ProjTri, pool: &Pool) {
        let limits = Limits {
            max_occluders: 16,
            max_edges: 256,
            min_evicting_area: 0.0,
        };
        state.add(t, &limits, pool, true);
        let BinState {
            occluders, fused, ..
        } = state;
        fused.update(
            occluders.last().expect("an occluder"),
            &Rect::of(&t.screen),
            &bin(),
            MARGIN,
            pool,
        );
    }

    /// A rectangle `x0..x1` by `-h..16+h` (reaching past the bin, as real occluders do).
    fn rect(x0: f64, x1: f64, h: f64, z: f64) -> [ProjTri; 2] {
        let (y0, y1) = (-h, 16.0 + h);
        [
            tri([[x0, y0], [x1, y0], [x1, y1]], z),
            tri([[x0, y0], [x1, y1], [x0, y1]], z),
        ]
    }

    #[test]
    fn two_separate_occluders_together_hide_what_neither_hides_alone() {
        let pool = Pool::new(1 << 20);
        let mut state = BinState::default();
        // Left part at depth 5 and right part at depth 6, overlapping on x = 7.5..8.5 (so each
        // cell is inside one of them, margin included): two occluders.
        for t in rect(-1.0, 8.5, 1.0, 5.0)
            .iter()
            .chain(&rect(7.5, 17.0, 2.0, 6.0))
        {
            add(&mut state, t, &pool);
        }
        assert_eq!(state.occluders.len(), 2);
        // A triangle across the seam, behind both.
        let p = [
            DVec2::new(6.0, 6.0),
            DVec2::new(10.0, 6.0),
            DVec2::new(8.0, 9.0),
        ];
        assert!(state.fused.hides(&p, &Rect::of(&p), 7.0, &bin(), MARGIN));
        // Between the two depths: in front of the right half, so not hidden.
        assert!(!state.fused.hides(&p, &Rect::of(&p), 5.5, &bin(), MARGIN));
    }

    #[test]
    fn a_gap_between_occluders_hides_nothing_behind_it() {
        let pool = Pool::new(1 << 20);
        let mut state = BinState::default();
        // A gap of 0.01 px at x = 8.
        for t in rect(-1.0, 8.0, 1.0, 5.0)
            .iter()
            .chain(&rect(8.01, 17.0, 1.0, 5.0))
        {
            add(&mut state, t, &pool);
        }
        let p = [
            DVec2::new(6.0, 6.0),
            DVec2::new(10.0, 6.0),
            DVec2::new(8.0, 9.0),
        ];
        assert!(!state.fused.hides(&p, &Rect::of(&p), 9.0, &bin(), MARGIN));
        // Away from the gap, inside the left occluder's cells, it is hidden.
        let q = [
            DVec2::new(1.0, 1.0),
            DVec2::new(3.0, 1.0),
            DVec2::new(1.0, 3.0),
        ];
        assert!(state.fused.hides(&q, &Rect::of(&q), 9.0, &bin(), MARGIN));
    }

    #[test]
    fn empty_pool_disables_fusion() {
        let pool = Pool::new(0);
        let mut g = FusedDepth::default();
        let mut state = BinState::default();
        let ok_pool = Pool::new(1 << 20);
        let [a, b] = rect(-1.0, 17.0, 1.0, 5.0);
        state.add(
            &a,
            &Limits {
                max_occluders: 4,
                max_edges: 64,
                min_evicting_area: 0.0,
            },
            &ok_pool,
            true,
        );
        state.add(
            &b,
            &Limits {
                max_occluders: 4,
                max_edges: 64,
                min_evicting_area: 0.0,
            },
            &ok_pool,
            true,
        );
        g.update(
            &state.occluders[0],
            &Rect::of(&a.screen),
            &bin(),
            MARGIN,
            &pool,
        );
        let p = [
            DVec2::new(6.0, 6.0),
            DVec2::new(10.0, 6.0),
            DVec2::new(8.0, 9.0),
        ];
        assert!(!g.hides(&p, &Rect::of(&p), 9.0, &bin(), MARGIN));
    }
}
