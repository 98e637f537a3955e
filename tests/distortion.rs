//! Property tests: the distortion table against the polynomial, the
//! bracketed inverse, and the fold, against the f64 reference. 10 000 cases
//! each over k1, k2 in [−1, 1].

use crate::common;

use common::*;
use fixed::types::I32F32;
use hilcam::geom::distortion::{Distortion, OutsideLensField};
use hilcam::{Norm, NormPoint};
use host_sim::reference::distortion::Radial;
use proptest::prelude::*;

fn ks() -> impl Strategy<Value = (f64, f64)> {
    (-1.0f64..=1.0, -1.0f64..=1.0)
}

/// The coefficients as the core stores them, for the reference.
fn radial(d: &Distortion) -> Radial {
    let (k1, k2) = d.coefficients();
    Radial {
        k1: k1.to_num(),
        k2: k2.to_num(),
    }
}

static LUT: Max = Max::new(
    "distortion_lut_vs_polynomial_over_bound",
    "of the documented bound",
);

/// `g` from the table is within the documented interpolation bound
/// `|k2| h²/4` (plus twice the entries' rounding) of the polynomial, with
/// the entry format chosen for the range.
#[test]
fn lut_within_interpolation_bound_of_polynomial() {
    let strategy = (
        ks(),
        1e-3f64..4.0,
        prop::sample::select(vec![2usize, 3, 16, 64, 256, 1024]),
        0.0f64..=1.0,
    );
    check(strategy, |((k1, k2), u_top, n, s)| {
        let d = Distortion::new(k1, k2).expect("in range");
        let r = radial(&d);
        let u_max = d.fold_u().map_or(u_top, |f| u_top.min(f.to_num()));
        let lut = d.lut(I32F32::from_num(u_max), n);
        if lut.saturated {
            // Only allowed when |g| reaches 32 768 on the range (g is
            // quadratic: its extremes are at the ends or the vertex).
            let vertex = if k2 != 0.0 {
                (-k1 / (2.0 * k2)).clamp(0.0, u_max)
            } else {
                0.0
            };
            let big = [0.0, u_max, vertex]
                .iter()
                .map(|u| r.g(*u).abs())
                .fold(0.0, f64::max);
            prop_assert!(big >= 32767.0, "saturated with |g| ≤ {big}");
            return Ok(());
        }
        let lut = lut.value;
        let u = I32F32::from_num(u_max * s);
        let got: f64 = lut.g(u).to_num();
        let want = r.g(u.to_num());
        let bound = d.lut_interp_error(lut.u_max().to_num(), n) + 2f64.powi(-(lut.entry_frac_bits() as i32));
        let e = (got - want).abs();
        LUT.record(e / bound);
        prop_assert!(
            e <= bound,
            "g error {e} over bound {bound} at u = {u} with {n} entries"
        );
        Ok(())
    });
    LUT.report();
}

static FOLD: Max = Max::new("distortion_fold_radius_rel", "relative");
static INVERSE: Max = Max::new("distortion_inverse_round_trip_normalized", "normalized units");

/// The inverse returns the distorted point whose undistortion is the input
/// (round trip within 10⁻¹², far below 1/256 px at any supported focal
/// length), agrees with the reference's inverse, and reports
/// `OutsideLensField` exactly when the point is beyond the fold's image.
#[test]
fn inverse_round_trip_and_fold() {
    let strategy = (ks(), 0.0f64..1.2, -std::f64::consts::PI..std::f64::consts::PI);
    check(strategy, |((k1, k2), frac, angle)| {
        let d = Distortion::new(k1, k2).expect("in range");
        let r = radial(&d);
        prop_assert_eq!(d.fold_u().is_some(), r.fold_u().is_some());
        if let (Some(c), Some(rf)) = (d.fold_u(), r.fold_u()) {
            let e = rel(c.to_num(), rf, 0.0);
            FOLD.record(e);
            prop_assert!(e <= 1e-9, "fold u {c} vs {rf}");
        }
        // A distorted radius up to 1.2 × the fold (or × 2 without one).
        let r_fold = r.fold_u().map(f64::sqrt);
        let rd = frac * r_fold.unwrap_or(2.0);
        let (xd, yd) = (rd * angle.cos(), rd * angle.sin());
        let p = NormPoint {
            x: Norm::from_num(xd),
            y: Norm::from_num(yd),
        };
        let (xd, yd) = (p.x.to_num::<f64>(), p.y.to_num::<f64>());
        match (d.undistort(p), r.undistort(xd, yd)) {
            (Ok(u), Some((rx, ry))) if rx.abs().max(ry.abs()) >= 32767.0 => {
                prop_assert!(u.saturated, "beyond I16F48 but not flagged");
            }
            (Ok(u), Some((rx, ry))) => {
                prop_assert!(!u.saturated);
                prop_assert!(
                    (u.value.x.to_num::<f64>() - rx).abs() <= 1e-12
                        && (u.value.y.to_num::<f64>() - ry).abs() <= 1e-12
                );
                // Back through the inverse.
                let back = d.distort(u.value);
                let on_branch = r_fold.is_none_or(|f| rd < f * (1.0 - 1e-6));
                if on_branch {
                    let b =
                        back.map_err(|_| TestCaseError::fail("inverse failed on the monotonic branch"))?;
                    let e = (b.value.x.to_num::<f64>() - xd).hypot(b.value.y.to_num::<f64>() - yd);
                    INVERSE.record(e);
                    prop_assert!(e <= 1e-12, "round trip off by {e}");
                    let (ex, ey) = r
                        .distort(u.value.x.to_num(), u.value.y.to_num())
                        .expect("reference inverse");
                    prop_assert!(
                        (b.value.x.to_num::<f64>() - ex).hypot(b.value.y.to_num::<f64>() - ey) <= 1e-12
                    );
                }
            }
            (Err(OutsideLensField), None) => {
                // Beyond the fold: the undistorted image of a point there is
                // also the image of a point on the branch, or beyond the fold's
                // image, and the inverse must say which, never guess.
                let (ux, uy) = (xd * r.g(xd * xd + yd * yd), yd * r.g(xd * xd + yd * yd));
                let q = NormPoint {
                    x: Norm::saturating_from_num(ux),
                    y: Norm::saturating_from_num(uy),
                };
                let fold_image = r_fold.map(|f| f * r.g(f * f)).unwrap_or(f64::INFINITY);
                let ru = ux.hypot(uy);
                match d.distort(q) {
                    Ok(b) => {
                        prop_assert!(ru <= fold_image * (1.0 + 1e-9), "inverse beyond the fold's image");
                        let (bx, by) = (b.value.x.to_num::<f64>(), b.value.y.to_num::<f64>());
                        prop_assert!(
                            r_fold.is_some_and(|f| bx.hypot(by) <= f * (1.0 + 1e-9)),
                            "not on the branch"
                        );
                    }
                    Err(OutsideLensField) => {
                        prop_assert!(ru >= fold_image * (1.0 - 1e-9), "refused a point inside")
                    }
                }
            }
            (c, rf) => prop_assert!(
                (rd - r_fold.unwrap_or(f64::INFINITY)).abs() < 1e-9,
                "in-field flags disagree away from the fold: {c:?} vs {rf:?}"
            ),
        }
        Ok(())
    });
    FOLD.report();
    INVERSE.report();
}

#[test]
fn distortion_rejects_bad_coefficients() {
    use hilcam::{Error, Field};
    assert_eq!(
        Distortion::new(f64::NAN, 0.0),
        Err(Error::NotFinite(Field::Distortion))
    );
    assert_eq!(
        Distortion::new(0.0, f64::INFINITY),
        Err(Error::NotFinite(Field::Distortion))
    );
    assert_eq!(
        Distortion::new(11.0, 0.0),
        Err(Error::OutOfRange(Field::Distortion))
    );
    assert!(Distortion::new(0.0, 0.0).expect("ok").is_none());
    assert!(Distortion::new(0.0, 0.0).expect("ok").fold_u().is_none());
    // k1 < 0 folds at u = −1 / (3 k1).
    let d = Distortion::new(-0.5, 0.0).expect("ok");
    assert!((d.fold_u().expect("folds").to_num::<f64>() - 2.0 / 3.0).abs() < 1e-12);
}

/// The relative illumination (camera-model.md §5): the reference's area
/// factor `J` is the area the undistortion maps a small distorted square
/// to over the square's (the shoelace area of its four corners' images,
/// side 2⁻¹², within the fold) — the contract's definition, measured on
/// the mapping, not its formula — and the core's `J` in I32F32 is the
/// reference's within 10⁻⁶ relative.
#[test]
fn the_area_factor_is_the_area_the_mapping_gathers() {
    let strategy = (ks(), 0.0f64..0.95, -std::f64::consts::PI..std::f64::consts::PI);
    check(strategy, |((k1, k2), frac, angle)| {
        let d = Distortion::new(k1, k2).expect("in range");
        let r = radial(&d);
        let rd = frac * r.fold_u().map_or(2.0, f64::sqrt);
        let (xd, yd) = (rd * angle.cos(), rd * angle.sin());
        let h = 1.0 / 8192.0;
        let corners = [(-h, -h), (h, -h), (h, h), (-h, h)].map(|(a, b)| r.undistort(xd + a, yd + b));
        let Some(p) = corners.iter().copied().collect::<Option<Vec<_>>>() else {
            return Ok(());
        };
        let area: f64 = (0..4)
            .map(|i| {
                let (a, b) = (p[i], p[(i + 1) % 4]);
                a.0 * b.1 - b.0 * a.1
            })
            .sum::<f64>()
            / 2.0;
        let j = r.area_factor(xd, yd);
        let measured = area / (4.0 * h * h);
        prop_assert!(
            (measured - j).abs() <= 1e-5 * j.abs().max(1.0),
            "J {j} against the mapped area {measured} at ({xd}, {yd})"
        );
        let q = |v: f64| I32F32::from_num(v);
        let (c1, c2) = d.coefficients();
        let k = [q(c1.to_num()), q(c2.to_num())];
        let core = hilcam::render::vignetting::area_factor(q(xd), q(yd), k).to_num::<f64>();
        prop_assert!(
            (core - j).abs() <= 1e-6 * j.abs().max(1.0),
            "core J {core} against {j}"
        );
        Ok(())
    });
}

/// A calibrated lens (OpenCV's models, `geom::calibrated`): the core's
/// per-sample solve against the reference's (Newton on finite differences;
/// the fisheye's θ by bisection) over the distorted field `|x̂_d|, |ŷ_d| ≤
/// 1.2`: the same undistorted point within the core's stated bound
/// (`Calibrated::solve_bound`) and the same area factor within 10⁻⁵ J²
/// where both image it; where one says the point is
/// outside the lens field and the other does not, it lies at the field's
/// edge.
#[test]
fn calibrated_solve_matches_the_reference() {
    use hilcam::geom::calibrated::Calibrated;
    use host_sim::reference::distortion::Lens;
    let opencv = (
        (
            -0.5f64..0.5,
            -0.2f64..0.2,
            -0.005f64..0.005,
            -0.005f64..0.005,
            -0.05f64..0.05,
        ),
        (0.0f64..0.5, 0.0f64..0.2, 0.0f64..0.05),
        (
            -0.0005f64..0.0005,
            -0.0005f64..0.0005,
            -0.0005f64..0.0005,
            -0.0005f64..0.0005,
        ),
    )
        .prop_map(|((k1, k2, p1, p2, k3), (k4, k5, k6), (s1, s2, s3, s4))| {
            (false, vec![k1, k2, p1, p2, k3, k4, k5, k6, s1, s2, s3, s4])
        });
    let fisheye = (-0.1f64..0.1, -0.05f64..0.05, -0.02f64..0.02, -0.01f64..0.01)
        .prop_map(|(a, b, c, d)| (true, vec![a, b, c, d]));
    let points = proptest::collection::vec((-1.2f64..1.2, -1.2f64..1.2), 64);
    // Seeded: the same 2 000 lenses every run.
    let mut runner = proptest::test_runner::TestRunner::new_with_rng(
        ProptestConfig::with_cases(2000),
        proptest::test_runner::TestRng::deterministic_rng(proptest::test_runner::RngAlgorithm::ChaCha),
    );
    let (both, edge, apart) = (
        std::cell::Cell::new(0u64),
        std::cell::Cell::new(0u64),
        std::cell::Cell::new(0u64),
    );
    runner
        .run(&(prop_oneof![opencv, fisheye], points), |((fish, c), pts)| {
            let (core, lens) = if fish {
                let k: [f64; 4] = c.clone().try_into().expect("4");
                (Calibrated::fisheye(k).expect("valid"), Lens::Fisheye(k))
            } else {
                let k: [f64; 12] = c.clone().try_into().expect("12");
                (Calibrated::opencv(k).expect("valid"), Lens::OpenCv(k))
            };
            let model = core.to::<I32F32>();
            let r_max = lens.valid_radius();
            for (xd, yd) in pts {
                let got = model.undistort(I32F32::from_num(xd), I32F32::from_num(yd));
                // The reference at the core's (rounded) input.
                let (qx, qy) = (
                    I32F32::from_num(xd).to_num::<f64>(),
                    I32F32::from_num(yd).to_num::<f64>(),
                );
                let want = lens.undistort(qx, qy, r_max);
                match (got, want) {
                    (Some((x, y, j)), Some((wx, wy, wj))) => {
                        both.set(both.get() + 1);
                        // The core's own bound on its solve, and the
                        // reference's 10⁻¹².
                        let tol = core.solve_bound((wx, wy)) + 1e-12;
                        prop_assert!(
                            (x.to_num::<f64>() - wx).abs() <= tol && (y.to_num::<f64>() - wy).abs() <= tol,
                            "{c:?} at ({xd}, {yd}): core ({x}, {y}), reference ({wx}, {wy})"
                        );
                        // J = 1/det: near a fold its error grows as J² (det's).
                        prop_assert!(
                            (j.to_num::<f64>() - wj).abs() <= 1e-5 * wj.abs().max(1.0).powi(2),
                            "{c:?}: J {j} vs {wj}"
                        );
                    }
                    (None, None) => {}
                    // One solver images the point, the other does not: at
                    // the field's edge, or where the lens all but folds
                    // (J > 8: eight times the undistorted area on a unit of
                    // image, where the reference's damped Newton can stop
                    // short of the root — random rational lenses reach it
                    // between the axis and the fold).
                    (Some((x, y, j)), None) => {
                        edge.set(edge.get() + 1);
                        let r = x.to_num::<f64>().hypot(y.to_num::<f64>());
                        let j = j.to_num::<f64>();
                        if !((r / r_max - 1.0).abs() < 1e-3 || j > 8.0) {
                            apart.set(apart.get() + 1);
                            eprintln!("{c:?}: core images ({xd}, {yd}) at r {r}, J {j}, field ends at {r_max}");
                        }
                    }
                    (None, Some((wx, wy, wj))) => {
                        edge.set(edge.get() + 1);
                        let r = wx.hypot(wy);
                        if !((r / r_max - 1.0).abs() < 1e-3 || wj > 8.0) {
                            apart.set(apart.get() + 1);
                            eprintln!("{c:?}: reference images ({xd}, {yd}) at r {r}, J {wj}, field ends at {r_max}");
                        }
                    }
                }
            }
            Ok(())
        })
        .expect("calibrated solve");
    let (both, edge, apart) = (both.get(), edge.get(), apart.get());
    println!("calibrated: {both} points imaged by both, {edge} by one ({apart} of them inside the field)");
    assert!(both > 50_000, "{both}");
    // Inside the field, one solver stopping short of a root the other
    // finds (the reference's damped Newton, on random rational lenses): at
    // most one point in ten thousand.
    assert!(apart * 10_000 <= both, "{apart} of {both}");
}
