//! Property tests: the thin lens of the fixed-point core against the f64
//! reference, 10 000 cases each over the documented ranges.

use crate::common;

use common::*;
use hilcam::geom::lens::{Aperture, Distance, Lens, LensConfig};
use hilcam::Len;
use host_sim::reference::lens::ThinLens;
use proptest::prelude::*;

/// The bound on lens quantities.
const REL_TOL: f64 = 1e-4;

/// How well the f64 reference satisfies `b(Ẑ_n) = b̃` itself: its
/// `d |ẑ' − ẑ| / ẑ'` cancels, losing `≈ 10⁻¹⁶ · d / b̃` (up to 2·10⁸ here) times
/// a few ulps; measured up to 3.3·10⁻⁷. A check of the reference, not of the
/// core.
const REF_SELF_TOL: f64 = 1e-5;

#[derive(Clone, Copy, Debug)]
struct L {
    f: f64,
    n: f64,
    focus: f64,
    blur: f64,
}

impl L {
    fn core(&self) -> Lens {
        Lens::new(
            self.f,
            &LensConfig {
                aperture: Aperture::FNumber(self.n),
                focus_distance: self.focus,
                tolerable_blur: self.blur,
            },
        )
        .unwrap_or_else(|e| panic!("{e} for {self:?}"))
    }
    fn reference(&self) -> ThinLens {
        ThinLens {
            f: self.f,
            d: self.f / self.n,
            focus: self.focus,
            blur: self.blur,
        }
    }
}

/// f in [0.1 mm, 10 m], N in [0.5, 256], Z̃ = f (1 + u) with u in
/// [10⁻², 10⁶] (capped at 10⁶ m), b̃ in [0.1 µm, 1 cm].
fn lens() -> impl Strategy<Value = L> {
    (
        log_uniform(1e-4, 10.0),
        log_uniform(0.5, 256.0),
        log_uniform(1e-2, 1e6),
        log_uniform(1e-7, 1e-2),
    )
        .prop_map(|(f, n, u, blur)| L {
            f,
            n,
            focus: (f * (1.0 + u)).min(1e6),
            blur,
        })
}

/// An object distance `Ẑ = f (1 + u)`, u in [10⁻³, 10⁸], capped at 10⁶ m,
/// quantized to what the core takes.
fn object(f: f64) -> impl Strategy<Value = Len> {
    log_uniform(1e-3, 1e8).prop_map(move |u| Len::from_num((f * (1.0 + u)).min(1e6)))
}

static SCALARS: Max = Max::new("lens_f_number_angles_sensor_hyperfocal_rel", "relative");

#[test]
fn lens_constants_match_reference() {
    check(lens(), |l| {
        let c = l.core();
        let r = l.reference();
        let n = c.f_number();
        prop_assert!(!n.saturated);
        let hyper = c.hyperfocal_distance();
        let errs = [
            rel(n.value.to_num(), r.f_number(), 0.0),
            rel(c.aperture_half_angle().to_num(), r.aperture_half_angle(), 0.0),
            rel(c.sensor_distance().to_num(), r.sensor_distance(), 0.0),
            if hyper.saturated {
                prop_assert!(r.hyperfocal_distance() > 8.3e6);
                0.0
            } else {
                rel(hyper.value.to_num(), r.hyperfocal_distance(), 0.0)
            },
        ];
        let e = errs.iter().copied().fold(0.0, f64::max);
        SCALARS.record(e);
        prop_assert!(e <= REL_TOL, "relative errors {errs:?}");
        Ok(())
    });
    SCALARS.report();
}

static GAUSS: Max = Max::new("lens_image_distance_gaussian_rel", "relative");
static NEWTON: Max = Max::new("lens_image_distance_newtonian_rel", "relative");

/// Both forms of the lens law against the reference, and against each other
/// (`ẑ = z + f` for `Z = Ẑ − f`).
#[test]
fn lens_law_matches_reference_in_both_forms() {
    let strategy = lens().prop_flat_map(|l| (Just(l), object(l.f)));
    check(strategy, |(l, z_obj)| {
        let c = l.core();
        let r = l.reference();
        let zo: f64 = z_obj.to_num();
        let g = c
            .image_distance(z_obj)
            .map_err(|e| TestCaseError::fail(format!("{e:?}")))?;
        prop_assert!(!g.saturated);
        let eg = rel(g.value.to_num(), r.image_distance(zo).expect("real image"), 0.0);
        GAUSS.record(eg);
        prop_assert!(eg <= REL_TOL, "gaussian rel {eg}");
        // Newtonian, with Z = Ẑ − f as the core's f sees it.
        let z_newton = z_obj - c.focal_length();
        let nz = c
            .image_distance_newtonian(z_newton)
            .map_err(|e| TestCaseError::fail(format!("{e:?}")))?;
        prop_assert!(!nz.saturated);
        // z = f²/Z of a far object is picometres: relative 1e-4 from 10 nm,
        // absolute 1 pm below (documented on `image_distance_newtonian`).
        let rz = r.image_distance_newtonian(z_newton.to_num()).expect("Z > 0");
        let got: f64 = nz.value.to_num();
        if rz >= 1e-8 {
            let en = rel(got, rz, 0.0);
            NEWTON.record(en);
            prop_assert!(en <= REL_TOL, "newtonian rel {en}");
        } else {
            prop_assert!((got - rz).abs() <= 1e-12, "newtonian abs {}", (got - rz).abs());
        }
        // Consistency of the two forms inside the core: ẑ = z + f.
        let sum: f64 = (nz.value + c.focal_length()).to_num();
        prop_assert!(rel(g.value.to_num(), sum, 0.0) <= REL_TOL);
        Ok(())
    });
    GAUSS.report();
    NEWTON.report();
}

static ROUND: Max = Max::new("lens_law_round_trip_rel", "relative");

/// Lens-law round trips. Image side → object side → image side holds for
/// every image distance; object → image → object holds while the image
/// defocus `ẑ − f = f²/(Ẑ − f)` is at least 5 nm, above the 0.45 pm rounding
/// of `ẑ` by 10⁴ (farther objects all image within picometres of the focus,
/// and one distance there cannot be told from the next).
#[test]
fn lens_law_round_trips() {
    let strategy = lens().prop_flat_map(|l| (Just(l), object(l.f), log_uniform(1e-4, 1e4)));
    check(strategy, |(l, z_obj, k)| {
        let c = l.core();
        let f = c.focal_length();
        // image → object → image, ẑ = f (1 + k)
        let zi = Len::from_num(l.f * (1.0 + k)).max(f + Len::from_num(1e-9));
        let zo = c
            .image_distance(zi)
            .map_err(|e| TestCaseError::fail(format!("{e:?}")))?;
        let mut e = 0.0f64;
        if !zo.saturated {
            let back = c
                .image_distance(zo.value)
                .map_err(|e| TestCaseError::fail(format!("{e:?}")))?;
            e = e.max(rel(back.value.to_num(), zi.to_num(), 0.0));
        }
        // object → image → object, in the documented range
        let zi2 = c
            .image_distance(z_obj)
            .map_err(|e| TestCaseError::fail(format!("{e:?}")))?;
        let defocus: f64 = (zi2.value - f).to_num();
        if defocus >= 5e-9 {
            let back = c
                .image_distance(zi2.value)
                .map_err(|e| TestCaseError::fail(format!("{e:?}")))?;
            e = e.max(rel(back.value.to_num(), z_obj.to_num(), 0.0));
        }
        ROUND.record(e);
        prop_assert!(e <= REL_TOL, "round trip rel {e}");
        Ok(())
    });
    ROUND.report();
}

static BLUR: Max = Max::new("lens_blur_diameter_rel", "relative");

/// Blur-circle diameter against the reference: relative 10⁻⁴ for blur of at
/// least 10 nm, absolute 1 pm below (documented on `Lens::blur_diameter`).
#[test]
fn blur_diameter_matches_reference() {
    let strategy = lens().prop_flat_map(|l| (Just(l), object(l.f)));
    check(strategy, |(l, z_obj)| {
        let c = l.core();
        let r = l.reference();
        let b = c
            .blur_diameter(z_obj)
            .map_err(|e| TestCaseError::fail(format!("{e:?}")))?;
        let rb = r.blur_diameter(z_obj.to_num()).expect("real image");
        if b.saturated {
            prop_assert!(rb > 8.3e6);
            return Ok(());
        }
        let got: f64 = b.value.to_num();
        if rb >= 1e-8 {
            let e = rel(got, rb, 0.0);
            BLUR.record(e);
            prop_assert!(e <= REL_TOL, "blur rel {e}: core {got} ref {rb}");
        } else {
            prop_assert!((got - rb).abs() <= 1e-12, "blur abs {} at {rb}", (got - rb).abs());
        }
        Ok(())
    });
    BLUR.report();
}

static DOF: Max = Max::new("lens_depth_of_field_rel", "relative");
static DOF_BLUR: Max = Max::new("lens_blur_at_dof_limits_vs_tolerable_rel", "relative");

/// Near and far planes against the reference, and the defining property
/// `b(Ẑ_n) = b(Ẑ_f) = b̃` in the core (and in the reference).
///
/// The far plane is ill-conditioned just short of the hyperfocal distance
/// `H`: the parameters' rounding (≤ 5·10⁻⁶ relative, from `b̃`) is amplified
/// by `H/(H − Z̃)`. The 10⁻⁴ bound is asserted where `Z̃ ≤ 0.95 H`; past
/// `1.05 H` the far plane must be infinite; in between either is right.
#[test]
fn depth_of_field_matches_reference_and_blur_is_tolerable_at_its_limits() {
    check(lens(), |l| {
        let c = l.core();
        let r = l.reference();
        let dof = c.depth_of_field();
        let h = r.hyperfocal_distance();
        let near: f64 = dof.value.near.to_num();
        let mut e = rel(near, r.near(), 0.0);
        let mut eb = 0.0f64;
        // Reference self-consistency: its own formulas satisfy the property.
        let rb = r.blur_diameter(r.near()).expect("real image");
        prop_assert!(
            rel(rb, l.blur, 0.0) <= REF_SELF_TOL,
            "reference b(Z_n) = {rb} vs {}",
            l.blur
        );
        // Rounding a plane Ẑ to 0.46 pm moves b by (|1/(Ẑ − Z̃)| + 1/(Ẑ − f))
        // · 0.46 pm relative: the property is asserted where that is ≤ 5·10⁻⁵
        // (it fails only for depths of field of nanometres, or planes
        // nanometres beyond f).
        let well_conditioned = |z: f64| (1.0 / (z - l.focus).abs() + 1.0 / (z - l.f)) * 0.46e-12 <= 5e-5;
        if well_conditioned(r.near()) {
            let bn = c
                .blur_diameter(dof.value.near)
                .map_err(|e| TestCaseError::fail(format!("{e:?}")))?;
            eb = eb.max(rel(bn.value.to_num(), l.blur, 0.0));
        }
        match (dof.value.far, r.far()) {
            (Distance::Finite(far), Some(rf)) if l.focus <= 0.95 * h => {
                if rf > 8.3e6 {
                    prop_assert!(dof.saturated, "far {rf} m beyond I24F40 but not flagged");
                } else {
                    prop_assert!(!dof.saturated);
                    e = e.max(rel(far.to_num(), rf, 0.0));
                    let rbf = r.blur_diameter(rf).expect("real image");
                    prop_assert!(rel(rbf, l.blur, 0.0) <= REF_SELF_TOL, "reference b(Z_f) = {rbf}");
                    if well_conditioned(rf) {
                        let bf = c
                            .blur_diameter(far)
                            .map_err(|e| TestCaseError::fail(format!("{e:?}")))?;
                        eb = eb.max(rel(bf.value.to_num(), l.blur, 0.0));
                    }
                    if let Distance::Finite(total) = dof.value.total {
                        // relative from 10 nm, absolute 1 pm below (documented)
                        let rt = rf - r.near();
                        let got: f64 = total.to_num();
                        if rt >= 1e-8 {
                            e = e.max(rel(got, rt, 0.0));
                        } else {
                            prop_assert!((got - rt).abs() <= 1e-12, "total abs {}", (got - rt).abs());
                        }
                    }
                }
            }
            (Distance::Infinite, None) => {
                prop_assert_eq!(dof.value.total, Distance::Infinite);
            }
            (far, rf) => {
                prop_assert!(
                    (l.focus - h).abs() <= 0.05 * h,
                    "far plane {far:?} vs reference {rf:?} with Z̃ = {} and H = {h}",
                    l.focus
                );
            }
        }
        DOF.record(e);
        DOF_BLUR.record(eb);
        prop_assert!(e <= REL_TOL, "depth of field rel {e}");
        prop_assert!(eb <= REL_TOL, "b at the DOF limits differs from b̃ by {eb}");
        Ok(())
    });
    DOF.report();
    DOF_BLUR.report();
}
