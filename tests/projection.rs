//! Property tests: projection, intrinsics and rays of the fixed-point core
//! against the f64 reference, 10 000 cases each over the documented ranges.

use crate::common;

use common::*;
use hilcam::geom::projection::{weak_perspective_bound, weak_perspective_error, DepthBox};
use hilcam::{Camera, CameraPoint, Extrinsics, Intrinsics, Len, Model, PixelPoint, WorldPoint};
use host_sim::reference::extrinsics::Pose;
use host_sim::reference::projection::{self as rp, Model as RModel};
use proptest::prelude::*;

/// The bound on projected pixel positions.
const PX_TOL: f64 = 1.0 / 256.0;

fn lens() -> hilcam::LensConfig {
    hilcam::LensConfig {
        aperture: hilcam::Aperture::FNumber(4.0),
        focus_distance: 1e6,
        tolerable_blur: 1e-5,
    }
}

/// Builds the core camera and the reference pieces for one case.
fn cameras(c: &Cam, angles: [f64; 3], t: [f64; 3], model: Model) -> (Camera, Pose) {
    let pose = Extrinsics::from_yaw_pitch_roll(angles[0], angles[1], angles[2], t).expect("valid pose");
    let lc = hilcam::LensConfig {
        focus_distance: 1e6f64.max(c.f * 2.0),
        ..lens()
    };
    let cam = Camera::new(&c.config(), &lc, pose, model).unwrap_or_else(|e| panic!("{e} for {c:?}"));
    (cam, Pose::from_yaw_pitch_roll(angles[0], angles[1], angles[2], t))
}

/// A world point whose reference image lands on `target`: the camera-frame
/// point `(x̂ Z, ŷ Z, Z)` at depth `Z = k f` (beyond the focal length, the
/// documented range) placed in the world, with `|X|, |Y|, Z ≤ 2000 m` so the
/// point stays within ±4096 m (where f64 holds `P − T` exactly).
fn world_point_at(c: &Cam, pose: &Pose, target: (f64, f64), k: f64) -> WorldPoint {
    let s = c.sensor();
    let (xn, yn) = s.pixel_to_normalized(target.0, target.1);
    let z = (k * c.f).min(2000.0 / xn.abs().max(yn.abs()).max(1.0));
    let pw = pose.camera_to_world([xn * z, yn * z, z]);
    WorldPoint::from_f64(pw).expect("in range")
}

static PERSPECTIVE: Max = Max::new("perspective_project_px", "px");

#[test]
fn perspective_projection_within_1_256_px() {
    let strategy = (cam(), pose(), log_uniform(1.0 + 1e-9, 1e6)).prop_flat_map(|(c, (a, t), z)| {
        (
            Just(c),
            Just(a),
            Just((t[0] / 2.0, t[1] / 2.0, t[2] / 2.0)),
            pixel_in(c.w, c.h),
            Just(z),
        )
    });
    check(strategy, |(c, a, t, target, z)| {
        let t = [t.0, t.1, t.2];
        let (cam, rpose) = cameras(&c, a, t, Model::Perspective);
        let wp = world_point_at(&c, &rpose, target, z);
        let pc = rpose.world_to_camera(wp.to_f64());
        let (x, y) = rp::project(RModel::Perspective, c.f, pc).expect("in front");
        let (rx, ry) = c.sensor().image_to_pixel(x, y);
        let got = cam
            .project(wp)
            .map_err(|e| TestCaseError::fail(format!("{e:?}")))?;
        prop_assert!(!got.saturated, "saturated at reference pixel ({rx}, {ry})");
        let [cx, cy] = got.value.to_f64();
        let err = (cx - rx).hypot(cy - ry);
        PERSPECTIVE.record(err);
        prop_assert!(err <= PX_TOL, "error {err} px at ({rx}, {ry}), core ({cx}, {cy})");
        Ok(())
    });
    PERSPECTIVE.report();
}

static ANY_POINT: Max = Max::new("perspective_any_point_px", "px");

/// Any point at all: visibility, saturation and accuracy agree with the
/// reference.
#[test]
fn perspective_any_point_is_visible_saturated_or_accurate() {
    let coord = -4000.0f64..4000.0;
    let strategy = (cam(), pose(), (coord.clone(), coord.clone(), coord));
    check(strategy, |(c, (a, t), p)| {
        let t = [t[0] / 2.0, t[1] / 2.0, t[2] / 2.0];
        let (cam, rpose) = cameras(&c, a, t, Model::Perspective);
        let wp = WorldPoint::from_f64([p.0, p.1, p.2]).expect("in range");
        let pc = rpose.world_to_camera(wp.to_f64());
        let got = cam.project(wp);
        if pc[2] < -1e-9 {
            prop_assert!(got.is_err(), "behind the camera but {got:?}");
            return Ok(());
        }
        if pc[2] < 1e-6 {
            return Ok(()); // within rounding of the lens plane: either answer is right
        }
        let real_image = pc[2] > c.f;
        let (x, y) = rp::project(RModel::Perspective, c.f, pc).expect("in front");
        let (rx, ry) = c.sensor().image_to_pixel(x, y);
        let got = got.map_err(|e| TestCaseError::fail(format!("{e:?}")))?;
        if rx.abs().max(ry.abs()) < 32000.0 {
            prop_assert!(!got.saturated);
            if real_image {
                let [cx, cy] = got.value.to_f64();
                let err = (cx - rx).hypot(cy - ry);
                ANY_POINT.record(err);
                prop_assert!(err <= PX_TOL, "error {err} px");
            }
        } else if rx.abs().max(ry.abs()) > 32800.0 {
            prop_assert!(
                got.saturated,
                "reference at ({rx}, {ry}) but not flagged: {got:?}"
            );
        }
        Ok(())
    });
    ANY_POINT.report();
}

static WEAK: Max = Max::new("weak_perspective_project_px", "px");

#[test]
fn weak_perspective_projection_within_1_256_px() {
    // Z̄ = q f beyond the focal length (the documented range), within 1 km.
    let strategy = (cam(), pose(), log_uniform(1.0 + 1e-9, 1e6), 0.01f64..10.0)
        .prop_flat_map(|(c, p, q, k)| (Just(c), Just(p), Just(q), Just(k), pixel_in(c.w, c.h)));
    check(strategy, |(c, (a, t), q, k, target)| {
        let zb = (q * c.f).clamp(1e-3, 1e3);
        let t = [t[0] / 2.0, t[1] / 2.0, t[2] / 2.0];
        let (cam, rpose) = cameras(&c, a, t, Model::weak_perspective(zb).expect("valid"));
        // A point at depth k·Z̄ whose weak-perspective image is `target`.
        let (xn, yn) = c.sensor().pixel_to_normalized(target.0, target.1);
        let scale = (2000.0 / (xn.abs().max(yn.abs()) * zb).max(1e-300)).min(1.0);
        let pcam = [xn * zb * scale, yn * zb * scale, (k * zb).min(2000.0)];
        let wp = WorldPoint::from_f64(rpose.camera_to_world(pcam)).expect("in range");
        let pc = rpose.world_to_camera(wp.to_f64());
        let (x, y) = rp::project(RModel::WeakPerspective(zb), c.f, pc).expect("in front");
        let (rx, ry) = c.sensor().image_to_pixel(x, y);
        let got = cam
            .project(wp)
            .map_err(|e| TestCaseError::fail(format!("{e:?}")))?;
        prop_assert!(!got.saturated);
        let [cx, cy] = got.value.to_f64();
        let err = (cx - rx).hypot(cy - ry);
        WEAK.record(err);
        prop_assert!(err <= PX_TOL, "error {err} px");
        Ok(())
    });
    WEAK.report();
}

static ORTHO: Max = Max::new("orthographic_project_px", "px");

/// Points aimed at a pixel (so every case compares), and a quarter anywhere
/// within ±2000 m (so saturation is exercised too).
#[test]
fn orthographic_projection_within_1_256_px() {
    let coord = -2000.0f64..2000.0;
    let strategy = (
        cam(),
        pose(),
        log_uniform(1e-6, 1e2),
        (coord.clone(), coord, 1e-3f64..2000.0),
        0u8..4,
    )
        .prop_flat_map(|(c, p, m, q, aim)| {
            (Just(c), Just(p), Just(m), Just(q), Just(aim), pixel_in(c.w, c.h))
        });
    check(strategy, |(c, (a, t), m, p, aim, target)| {
        let t = [t[0] / 2.0, t[1] / 2.0, t[2] / 2.0];
        let (cam, rpose) = cameras(&c, a, t, Model::orthographic(m).expect("valid"));
        let (px, py) = if aim > 0 {
            let (x, y) = c.sensor().pixel_to_image(target.0, target.1);
            let k = (2000.0 / (x.abs().max(y.abs()) / m).max(1e-300)).min(1.0);
            (x / m * k, y / m * k)
        } else {
            (p.0, p.1)
        };
        let wp = WorldPoint::from_f64(rpose.camera_to_world([px, py, p.2])).expect("in range");
        let pc = rpose.world_to_camera(wp.to_f64());
        prop_assume!(pc[2] > 1e-9);
        let (x, y) = rp::project(RModel::Orthographic(m), c.f, pc).expect("in front");
        let (rx, ry) = c.sensor().image_to_pixel(x, y);
        let got = cam
            .project(wp)
            .map_err(|e| TestCaseError::fail(format!("{e:?}")))?;
        if rx.abs().max(ry.abs()) < 32000.0 {
            prop_assert!(!got.saturated);
            let [cx, cy] = got.value.to_f64();
            let err = (cx - rx).hypot(cy - ry);
            ORTHO.record(err);
            prop_assert!(err <= PX_TOL, "error {err} px");
        } else if rx.abs().max(ry.abs()) > 32800.0 {
            prop_assert!(got.saturated);
        }
        Ok(())
    });
    ORTHO.report();
}

static PIX_IMG: Max = Max::new("pixel_image_normalized_roundtrip_px", "px");

/// image ↔ pixel and normalized ↔ pixel against the reference, expressed in
/// pixels.
#[test]
fn intrinsics_maps_match_reference() {
    let strategy = cam().prop_flat_map(|c| (Just(c), pixel_in(c.w, c.h)));
    check(strategy, |(c, (u, v))| {
        let k = Intrinsics::new(&c.config()).expect("valid");
        let s = c.sensor();
        let p = PixelPoint::from_f64(u, v).expect("in range");
        let [pu, pv] = p.to_f64();
        // pixel → image
        let ip = k.pixel_to_image(p);
        prop_assert!(!ip.saturated);
        let (rx, ry) = s.pixel_to_image(pu, pv);
        let e1 = ((ip.value.x.to_num::<f64>() - rx) / c.sx).hypot((ip.value.y.to_num::<f64>() - ry) / c.sy);
        // image → pixel (of the core's own image point)
        let back = k.image_to_pixel(ip.value);
        prop_assert!(!back.saturated);
        let (bx, by) = s.image_to_pixel(ip.value.x.to_num(), ip.value.y.to_num());
        let e2 = (back.value.x.to_num::<f64>() - bx).hypot(back.value.y.to_num::<f64>() - by);
        // pixel → normalized → pixel
        let n = k.pixel_to_normalized(p);
        let (rnx, rny) = s.pixel_to_normalized(pu, pv);
        let e3 = if n.saturated {
            // only a focal length under 1 px can push x̂ past 32 768
            prop_assert!(rnx.abs().max(rny.abs()) > 32000.0);
            0.0
        } else {
            let e = ((n.value.x.to_num::<f64>() - rnx) * c.f / c.sx)
                .hypot((n.value.y.to_num::<f64>() - rny) * c.f / c.sy);
            let back = k.normalized_to_pixel(n.value);
            prop_assert!(!back.saturated);
            let (bx, by) = s.normalized_to_pixel(n.value.x.to_num(), n.value.y.to_num());
            e.max((back.value.x.to_num::<f64>() - bx).hypot(back.value.y.to_num::<f64>() - by))
        };
        let err = e1.max(e2).max(e3);
        PIX_IMG.record(err);
        prop_assert!(err <= PX_TOL, "errors {e1} {e2} {e3} px");
        Ok(())
    });
    PIX_IMG.report();
}

static RAYS: Max = Max::new("pixel_ray_vs_reference_px", "px");
static REPROJECT: Max = Max::new("pixel_ray_reprojection_px", "px");

/// Rays through pixels, per model: origin and direction against the
/// reference (in pixel units), and a point on the ray projects back onto
/// the pixel.
#[test]
fn pixel_rays_match_reference_and_reproject() {
    let model = prop_oneof![
        Just(RModel::Perspective),
        // Z̄ as a multiple of f (Z̄ > f, the documented range), resolved below.
        log_uniform(1.0 + 1e-9, 1e4).prop_map(RModel::WeakPerspective),
        log_uniform(1e-4, 1e1).prop_map(RModel::Orthographic),
    ];
    let strategy = (cam(), model, log_uniform(0.1, 100.0))
        .prop_flat_map(|(c, m, t)| (Just(c), Just(m), Just(t), pixel_in(c.w, c.h)));
    check(strategy, |(c, rm, depth, (u, v))| {
        let rm = match rm {
            RModel::WeakPerspective(q) => RModel::WeakPerspective((q * c.f).clamp(1e-3, 1e3)),
            other => other,
        };
        let model = match rm {
            RModel::Perspective => Model::Perspective,
            RModel::WeakPerspective(z) => Model::weak_perspective(z).expect("valid"),
            RModel::Orthographic(m) => Model::orthographic(m).expect("valid"),
        };
        let (cam, _) = cameras(&c, [0.0; 3], [0.0; 3], model);
        let s = c.sensor();
        let p = PixelPoint::from_f64(u, v).expect("in range");
        let [pu, pv] = p.to_f64();
        let ray = cam.pixel_ray(p);
        let (ro, rd) = rp::ray(rm, &s, pu, pv);
        // Express ray differences as image displacements in pixels.
        let (kx, ky, k_origin) = match rm {
            RModel::Perspective => (c.f / c.sx, c.f / c.sy, 0.0),
            RModel::WeakPerspective(zb) => (c.f / c.sx / zb, c.f / c.sy / zb, 1.0),
            RModel::Orthographic(m) => (m / c.sx, m / c.sy, 1.0),
        };
        if ray.saturated {
            // Only a slope beyond I16F48 or an origin beyond I24F40 may saturate.
            prop_assert!(
                rd[0].abs().max(rd[1].abs()) > 32000.0 || ro[0].abs().max(ro[1].abs()) > 8.3e6,
                "saturated for a representable ray {ro:?} {rd:?}"
            );
            return Ok(());
        }
        let r = ray.value;
        let ed = ((r.dir.x.to_num::<f64>() - rd[0]) * c.f / c.sx)
            .hypot((r.dir.y.to_num::<f64>() - rd[1]) * c.f / c.sy);
        let eo = ((r.origin.x.to_num::<f64>() - ro[0]) * kx).hypot((r.origin.y.to_num::<f64>() - ro[1]) * ky)
            * k_origin;
        let e = ed.max(eo);
        RAYS.record(e);
        prop_assert!(e <= PX_TOL, "ray error {ed} (dir) {eo} (origin) px");
        // Reproject a point on the core's ray (identity pose: camera = world).
        let pt = [
            r.origin.x.to_num::<f64>() + depth * r.dir.x.to_num::<f64>(),
            r.origin.y.to_num::<f64>() + depth * r.dir.y.to_num::<f64>(),
            r.origin.z.to_num::<f64>() + depth * r.dir.z.to_num::<f64>(),
        ];
        prop_assume!(pt.iter().all(|v| v.abs() < 4000.0));
        let back = cam
            .project(WorldPoint::from_f64(pt).expect("in range"))
            .map_err(|e| TestCaseError::fail(format!("{e:?}")))?;
        prop_assert!(!back.saturated);
        let [bx, by] = back.value.to_f64();
        // The point was rounded to 1 pm; in pixels that is f/s·1e-12/depth.
        let quant = (c.f / c.sx.min(c.sy)) * 1e-12 / depth * 2.0;
        let e = (bx - pu).hypot(by - pv);
        REPROJECT.record(e);
        prop_assert!(e <= PX_TOL + quant, "reprojection error {e} px");
        Ok(())
    });
    RAYS.report();
    REPROJECT.report();
}

static WP_ERR: Max = Max::new("weak_perspective_error_rel", "relative");
static WP_BOUND: Max = Max::new("weak_perspective_bound_rel_vs_sampled", "relative");

/// The §2 weak-perspective error of a point, and its bound over a box (the
/// core's corner argument against the reference's dense sampling).
#[test]
fn weak_perspective_error_and_bound_match_reference() {
    let zr = || log_uniform(1e-2, 1e3);
    let xy = -100.0f64..100.0;
    let strategy = (cam(), zr(), zr(), zr(), (xy.clone(), xy.clone(), xy.clone(), xy));
    check(strategy, |(c, z0, z1, zb, (x0, x1, y0, y1))| {
        let k = Intrinsics::new(&c.config()).expect("valid");
        let f = k.focal_length();
        let zbl = Len::from_num(zb);
        let p = CameraPoint::from_f64([x0, y0, z0]).expect("in range");
        let e = weak_perspective_error(f, p, zbl).map_err(|e| TestCaseError::fail(format!("{e:?}")))?;
        let r = rp::weak_perspective_error(c.f, p.to_f64(), zbl.to_num());
        let er = rel(e.value.to_num(), r, 1e-9);
        WP_ERR.record(er);
        prop_assert!(er <= 1e-4, "point error rel {er}: core {} ref {r}", e.value);
        let b = DepthBox {
            min: CameraPoint::from_f64([x0.min(x1), y0.min(y1), z0.min(z1)]).expect("in range"),
            max: CameraPoint::from_f64([x0.max(x1), y0.max(y1), z0.max(z1)]).expect("in range"),
        };
        let bound = weak_perspective_bound(&k, b, zbl).map_err(|e| TestCaseError::fail(format!("{e:?}")))?;
        prop_assume!(!bound.saturated);
        let sampled =
            rp::weak_perspective_bound_sampled(&c.sensor(), b.min.to_f64(), b.max.to_f64(), zbl.to_num(), 5);
        let eb = rel(bound.value.to_num(), sampled, 1e-6);
        WP_BOUND.record(eb);
        prop_assert!(eb <= 1e-4, "bound {} vs sampled max {sampled}", bound.value);
        Ok(())
    });
    WP_ERR.report();
    WP_BOUND.report();
}
