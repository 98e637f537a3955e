use super::closed_mean::MeanCells;
use proptest::prelude::*;

/// Cells for a camera `dist` above the plane, the light `h` above it
/// with its foot `foot` from the camera's.
fn cells(dist: f64, foot: f64, h: f64, d: f64, row: (f64, f64, f64, f64)) -> MeanCells {
    let l = libm::sqrt(foot * foot + (h - dist) * (h - dist));
    MeanCells::new((dist, foot, h, l), d, row)
}

#[test]
fn the_standard_scene_s_cells_stop_early() {
    // The standard scene's: the camera 1.2 m up, the light 3 m up with
    // its foot 2.24 m off; `closed_mean_err`'s row bounds for f = 200
    // px, k1 0.15, k2 0.05 to the corner (u = 0.2465) and the floor's
    // normal 14.9° off the camera's y axis (|n_x| 0, |n_y| 0.966); `D`
    // scales every cell alike.
    let c = cells(1.2, 2.236, 3.0, 1.0, (5.63e-3, 1.53e-5, 2.08e-4, 5.37e-6));
    let (full, early) = (c.worst(false), c.worst(true));
    assert_eq!(full.0.to_bits(), early.0.to_bits());
    assert!(early.1 < full.1, "{early:?} {full:?}");
}

proptest! {
    /// Stopping early gives the largest cell's bound to the bit.
    #[test]
    fn the_tail_bound_stops_only_where_no_cell_left_is_larger(
        dist in -3.0f64..3.0,
        foot in -3.0f64..3.0,
        h in -3.0f64..3.0,
        d in -6.0f64..6.0,
        row in (-6.0f64..0.0, -9.0f64..-3.0, -6.0f64..0.0, -9.0f64..-3.0),
        no_tilt in any::<bool>(),
    ) {
        let e = |x: f64| libm::pow(10.0, x);
        let n1 = if no_tilt { 0.0 } else { e(row.2) };
        let c = cells(e(dist), e(foot), e(h), e(d), (e(row.0), e(row.1), n1, e(row.3)));
        let (full, early) = (c.worst(false), c.worst(true));
        prop_assert_eq!(full.0.to_bits(), early.0.to_bits(), "{:?}: {:?} {:?}", c, full, early);
        prop_assert!(early.1 <= full.1);
    }
}
