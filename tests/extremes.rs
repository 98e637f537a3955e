//! Extremes of the geometry and the lens: each test states the behaviour it
//! expects (a typed result, a flag, saturation, or accuracy held) and asserts
//! it.

use hilcam::geom::error::{Error, Field, NoRealImage, NotVisible};
use hilcam::geom::lens::{Aperture, Distance, Lens, LensConfig};
use hilcam::geom::projection::weak_perspective_error;
use hilcam::{
    Camera, CameraPoint, Extrinsics, Intrinsics, IntrinsicsConfig, Len, Model, PixelPoint, WorldPoint,
};
use host_sim::reference::{extrinsics::Pose, intrinsics::Sensor, lens::ThinLens, projection as rp};

const PX_TOL: f64 = 1.0 / 256.0;

fn intrinsics(f: f64, s: f64, w: u16, h: u16) -> IntrinsicsConfig {
    IntrinsicsConfig {
        focal_length: f,
        pitch: (s, s),
        size: (w, h),
        principal_point: None,
    }
}

fn lens_cfg() -> LensConfig {
    LensConfig {
        aperture: Aperture::FNumber(2.0),
        focus_distance: 1e3,
        tolerable_blur: 1e-5,
    }
}

fn camera(c: &IntrinsicsConfig, model: Model) -> Camera {
    let pose = Extrinsics::from_matrix([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], [0.0; 3])
        .expect("identity");
    Camera::new(c, &lens_cfg(), pose, model).expect("valid camera")
}

/// Projects a camera-frame point (identity pose) with core and reference and
/// returns the distance in pixels; asserts the core did not saturate.
fn project_err(c: &IntrinsicsConfig, p: [f64; 3]) -> f64 {
    let cam = camera(c, Model::Perspective);
    let wp = WorldPoint::from_f64(p).expect("in range");
    let got = cam.project(wp).expect("visible");
    assert!(!got.saturated, "saturated at {p:?}");
    let s = Sensor::centred(
        c.focal_length,
        c.pitch.0,
        c.pitch.1,
        c.size.0 as u32,
        c.size.1 as u32,
    );
    let (x, y) = rp::project(rp::Model::Perspective, c.focal_length, wp.to_f64()).expect("in front");
    let (rx, ry) = s.image_to_pixel(x, y);
    let [cx, cy] = got.value.to_f64();
    (cx - rx).hypot(cy - ry)
}

/// Z → 0⁺: an off-axis point's image runs off to infinity. While it is within
/// ±32 768 px it stays accurate; past that it saturates and says so; at one
/// LSB of depth it is saturated, not wrapped; on the axis it stays at the
/// principal point.
#[test]
fn extreme_z_approaching_zero_from_above() {
    let c = intrinsics(8e-3, 5e-6, 640, 480);
    let cam = camera(&c, Model::Perspective);
    let mut last = 0.0f64;
    for z in [1.0, 1e-1, 1e-2, 1e-3, 1e-4] {
        // 1 mm off axis
        let err = project_err(&c, [1e-3, 0.0, z]);
        assert!(err <= PX_TOL, "z = {z}: error {err} px");
        let px = cam
            .project(WorldPoint::from_f64([1e-3, 0.0, z]).expect("ok"))
            .expect("visible");
        let x = px.value.x.to_num::<f64>();
        assert!(
            x < last || last == 0.0,
            "image should move monotonically outwards"
        );
        last = x;
    }
    for z in [1e-6, 1e-9, Len::DELTA.to_num::<f64>()] {
        let got = cam
            .project(WorldPoint::from_f64([1e-3, 0.0, z]).expect("ok"))
            .expect("visible");
        assert!(got.saturated, "z = {z} must saturate");
        assert_eq!(
            got.value.x,
            hilcam::Px::MIN,
            "saturates towards the true side (x_im → −∞)"
        );
    }
    let on_axis = cam
        .project(WorldPoint {
            x: Len::ZERO,
            y: Len::ZERO,
            z: Len::DELTA,
        })
        .expect("visible");
    assert!(!on_axis.saturated);
    assert_eq!(on_axis.value.to_f64(), [319.5, 239.5]);
}

/// Z ≤ 0 is not visible under every model; the lens forms no image at or
/// inside the focal length.
#[test]
fn extreme_z_zero_and_behind_not_visible() {
    let c = intrinsics(8e-3, 5e-6, 640, 480);
    for model in [
        Model::Perspective,
        Model::weak_perspective(2.0).expect("ok"),
        Model::orthographic(0.01).expect("ok"),
    ] {
        let cam = camera(&c, model);
        for z in [Len::ZERO, -Len::DELTA, Len::from_num(-1e6), Len::MIN] {
            let p = WorldPoint {
                x: Len::from_num(0.1),
                y: Len::ZERO,
                z,
            };
            assert_eq!(
                cam.project(p),
                Err(NotVisible::BehindCamera),
                "{model:?} at z = {z}"
            );
            assert_eq!(
                model.project(Len::from_num(8e-3), CameraPoint { x: p.x, y: p.y, z }),
                Err(NotVisible::BehindCamera)
            );
        }
    }
    let p = CameraPoint {
        x: Len::ONE,
        y: Len::ONE,
        z: Len::ZERO,
    };
    assert_eq!(
        weak_perspective_error(Len::from_num(8e-3), p, Len::ONE),
        Err(NotVisible::BehindCamera)
    );
}

/// World coordinates at the ends of I24F40: accepted up to ±8 388 607 m,
/// rejected beyond with the field named. A camera at one end of the range
/// looking at a point at the other: the camera-frame coordinates do not fit
/// I24F40 (world_to_camera saturates and says so) but the fused projection
/// still lands within 1/256 px of the reference.
#[test]
fn extreme_world_coordinates_at_range_ends() {
    // Len::MAX itself rounds up to 2²³ in f64; the largest f64 within range:
    let max = 8_388_607.999_999_9;
    assert!(WorldPoint::from_f64([max, -max, -8_388_608.0]).is_ok());
    assert_eq!(
        WorldPoint::from_f64([8_388_608.0, 0.0, 0.0]),
        Err(Error::OutOfRange(Field::Point))
    );
    assert_eq!(
        WorldPoint::from_f64([9e6, 0.0, 0.0]),
        Err(Error::OutOfRange(Field::Point))
    );
    assert_eq!(
        WorldPoint::from_f64([0.0, f64::NAN, 0.0]),
        Err(Error::NotFinite(Field::Point))
    );
    assert_eq!(
        WorldPoint::from_f64([0.0, 0.0, f64::NEG_INFINITY]),
        Err(Error::NotFinite(Field::Point))
    );

    let c = intrinsics(8e-3, 5e-6, 640, 480);
    let eye = [-8.0e6, -8.0e6, -8.0e6];
    let target = [8.0e6, 8.0e6, 8.0e6];
    let pose = Extrinsics::look_at(eye, target, [0.0, 1.0, 0.0]).expect("valid");
    let cam = Camera::new(&c, &lens_cfg(), pose, Model::Perspective).expect("valid");
    let wp = WorldPoint::from_f64([8.0e6, 7.9e6, 8.0e6]).expect("in range");
    assert!(
        pose.world_to_camera(wp).saturated,
        "|P − T| = 2.7e7 m exceeds I24F40"
    );
    let got = cam.project(wp).expect("visible");
    assert!(!got.saturated);
    let rpose = Pose::look_at(eye, target, [0.0, 1.0, 0.0]);
    let (x, y) =
        rp::project(rp::Model::Perspective, 8e-3, rpose.world_to_camera(wp.to_f64())).expect("in front");
    let (rx, ry) = Sensor::centred(8e-3, 5e-6, 5e-6, 640, 480).image_to_pixel(x, y);
    let [cx, cy] = got.value.to_f64();
    let err = (cx - rx).hypot(cy - ry);
    assert!(err <= PX_TOL, "error {err} px at the range ends");
}

/// Focal lengths at the ends of the supported range project within 1/256 px;
/// just outside, and zero, negative, NaN, ∞, are rejected naming the field.
#[test]
fn extreme_focal_length_at_range_ends() {
    for f in [1e-4, 10.0] {
        let c = intrinsics(f, 1e-5, 1000, 1000);
        // a point imaged 400 px off centre at 100 f depth
        let z = 100.0 * f;
        let x = 400.0 * 1e-5 / f * z;
        let err = project_err(&c, [x, -x / 2.0, z]);
        assert!(err <= PX_TOL, "f = {f}: error {err} px");
    }
    for (f, want) in [
        (0.99e-4, Error::OutOfRange(Field::FocalLength)),
        (10.01, Error::OutOfRange(Field::FocalLength)),
        (0.0, Error::NotPositive(Field::FocalLength)),
        (-1.0, Error::NotPositive(Field::FocalLength)),
        (f64::NAN, Error::NotFinite(Field::FocalLength)),
        (f64::INFINITY, Error::NotFinite(Field::FocalLength)),
    ] {
        assert_eq!(
            Intrinsics::new(&intrinsics(f, 1e-5, 10, 10)),
            Err(want),
            "f = {f}"
        );
    }
}

/// Pixel pitches at the ends of the supported range project within 1/256 px
/// (the 0.1 µm pitch is why pitch has its own I4F60 format); just outside are
/// rejected naming the axis.
#[test]
fn extreme_pixel_pitch_at_range_ends() {
    for s in [1e-7, 1e-3] {
        let c = intrinsics(0.05, s, 16384, 16384);
        let z = 10.0;
        let x = 8000.0 * s / 0.05 * z;
        let err = project_err(&c, [x, x, z]);
        assert!(err <= PX_TOL, "pitch = {s}: error {err} px");
    }
    let mut c = intrinsics(0.05, 0.99e-7, 10, 10);
    assert_eq!(Intrinsics::new(&c), Err(Error::OutOfRange(Field::PitchX)));
    c.pitch = (1e-5, 1.01e-3);
    assert_eq!(Intrinsics::new(&c), Err(Error::OutOfRange(Field::PitchY)));
    c.pitch = (1e-5, f64::NAN);
    assert_eq!(Intrinsics::new(&c), Err(Error::NotFinite(Field::PitchY)));
}

/// Sensors of 1×1 and of the largest supported size; 0 and one past the
/// largest are rejected.
#[test]
fn extreme_sensor_sizes() {
    let one = Intrinsics::new(&intrinsics(8e-3, 5e-6, 1, 1)).expect("1x1");
    assert_eq!(one.principal_point(), (hilcam::Px::ZERO, hilcam::Px::ZERO));
    let big = Intrinsics::new(&intrinsics(8e-3, 5e-6, 16384, 16384)).expect("largest");
    assert_eq!(big.principal_point().0.to_num::<f64>(), 8191.5);
    assert_eq!(
        Intrinsics::new(&intrinsics(8e-3, 5e-6, 0, 1)),
        Err(Error::NotPositive(Field::Width))
    );
    assert_eq!(
        Intrinsics::new(&intrinsics(8e-3, 5e-6, 1, 16385)),
        Err(Error::OutOfRange(Field::Height))
    );
    // the far corner of the largest sensor maps to a normalized point and back
    let corner = PixelPoint::from_f64(16383.0, 16383.0).expect("ok");
    let n = big.pixel_to_normalized(corner);
    assert!(!n.saturated);
    let back = big.normalized_to_pixel(n.value);
    assert!(!back.saturated);
    assert!((back.value.x.to_num::<f64>() - 16383.0).abs() <= PX_TOL);
}

/// A lens with f = 2⁻⁴ m, d = 2⁻⁵ m, b̃ = 2⁻²⁰ m (all exact in I24F40) has
/// the hyperfocal distance H = 2048 m exactly. Focused exactly there, the far
/// plane is infinite (an enum value, not a huge number) and the near plane is
/// H (d + b̃) / 2d.
#[test]
fn extreme_focus_exactly_at_hyperfocal() {
    let l = hyper_lens(2048.0);
    assert_eq!(l.hyperfocal_distance().value, Len::from_num(2048));
    let dof = l.depth_of_field();
    assert!(!dof.saturated);
    assert_eq!(dof.value.far, Distance::Infinite);
    assert_eq!(dof.value.total, Distance::Infinite);
    let r = hyper_ref(2048.0);
    assert!(r.far().is_none(), "reference: infinite too");
    let near: f64 = dof.value.near.to_num();
    assert!(
        ((near - r.near()) / r.near()).abs() <= 1e-9,
        "near {near} vs {}",
        r.near()
    );
    assert!((near - 2048.0 * (1.0 + 2f64.powi(-15)) / 2.0).abs() <= 1e-9);
}

/// One LSB past the hyperfocal distance the far plane is infinite; a little
/// short of it the far plane is finite and beyond I24F40, so it saturates and
/// says so; at 0.9 H it is finite and matches the reference.
#[test]
fn extreme_focus_just_past_hyperfocal() {
    let past = hyper_lens(2048.0 + Len::DELTA.to_num::<f64>()).depth_of_field();
    assert_eq!(past.value.far, Distance::Infinite);
    let short = hyper_lens(2048.0 - 1e-3).depth_of_field();
    assert!(short.saturated, "far plane ≈ 4e9 m must be flagged: {short:?}");
    assert_eq!(short.value.far, Distance::Finite(Len::MAX));
    let z = 0.9 * 2048.0;
    let ok = hyper_lens(z).depth_of_field();
    assert!(!ok.saturated);
    let Distance::Finite(far) = ok.value.far else {
        panic!("finite expected")
    };
    let rf = hyper_ref(z).far().expect("finite");
    assert!(((far.to_num::<f64>() - rf) / rf).abs() <= 1e-6);
}

fn hyper_lens(focus: f64) -> Lens {
    Lens::new(
        2f64.powi(-4),
        &LensConfig {
            aperture: Aperture::Diameter(2f64.powi(-5)),
            focus_distance: focus,
            tolerable_blur: 2f64.powi(-20),
        },
    )
    .expect("valid")
}

fn hyper_ref(focus: f64) -> ThinLens {
    ThinLens {
        f: 2f64.powi(-4),
        d: 2f64.powi(-5),
        focus,
        blur: 2f64.powi(-20),
    }
}

/// A very wide camera: the widest aperture (N = 0.5, w = 45°) and the widest
/// field of view the ranges allow (W s / 2f = 81 920, a half-angle of
/// 89.9993°): angles match the reference, and a point 89.99° off axis
/// projects within 1/256 px.
#[test]
fn extreme_very_wide_camera() {
    let l = Lens::new(
        1e-4,
        &LensConfig {
            aperture: Aperture::FNumber(0.5),
            focus_distance: 1.0,
            tolerable_blur: 1e-6,
        },
    )
    .expect("valid");
    assert!((l.aperture_half_angle().to_num::<f64>() - std::f64::consts::FRAC_PI_4).abs() < 1e-15);
    let c = intrinsics(1e-4, 1e-3, 16384, 16384);
    let k = Intrinsics::new(&c).expect("valid");
    let (hx, _) = k.half_angles_of_view();
    let want = (16384.0f64 * 1e-3 / 2e-4).atan();
    assert!((hx.to_num::<f64>() - want).abs() < 1e-15);
    assert!(want.to_degrees() > 89.999);
    let a = 89.99f64.to_radians();
    let err = project_err(&c, [a.tan() * 0.01, 0.0, 0.01]);
    assert!(err <= PX_TOL, "error {err} px at 89.99°");
}

/// A long telephoto: f = 10 m on 0.1 µm pixels is a focal length of 10⁸ px
/// (half-angle of view 8.2·10⁻⁵ rad). Points across its field at 1 km
/// project within 1/256 px, and its depth of field matches the reference.
#[test]
fn extreme_long_telephoto() {
    let c = intrinsics(10.0, 1e-7, 16384, 16384);
    let k = Intrinsics::new(&c).expect("valid");
    assert_eq!(k.focal_px().0.to_num::<f64>(), 1e8);
    for u in [-8000.0, -1234.5, 0.25, 8191.0] {
        let z = 1000.0;
        let err = project_err(&c, [u * 1e-7 / 10.0 * z, u * 0.5e-7 / 10.0 * z, z]);
        assert!(err <= PX_TOL, "offset {u} px: error {err} px");
    }
    let l = Lens::new(
        10.0,
        &LensConfig {
            aperture: Aperture::FNumber(8.0),
            focus_distance: 1000.0,
            tolerable_blur: 1e-7,
        },
    )
    .expect("valid");
    let r = ThinLens {
        f: 10.0,
        d: 1.25,
        focus: 1000.0,
        blur: 1e-7,
    };
    let dof = l.depth_of_field();
    assert!(((dof.value.near.to_num::<f64>() - r.near()) / r.near()).abs() <= 1e-4);
    let Distance::Finite(far) = dof.value.far else {
        panic!("finite far plane expected")
    };
    let rf = r.far().expect("finite");
    assert!(((far.to_num::<f64>() - rf) / rf).abs() <= 1e-4);
}

/// R at the rotation tolerance: a row stretched so that R Rᵀ − I reaches
/// 0.99 of the tolerance is accepted; 1.01 of it is rejected; a reflection
/// and a NaN entry are rejected with their own errors.
#[test]
fn extreme_rotation_at_tolerance() {
    let tol = hilcam::geom::extrinsics::ROTATION_TOLERANCE;
    let stretched = |dev: f64| {
        // (1 + δ)² − 1 = dev
        let k = (1.0 + dev).sqrt();
        [[k, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    };
    assert!(Extrinsics::from_matrix(stretched(0.99 * tol), [0.0; 3]).is_ok());
    assert_eq!(
        Extrinsics::from_matrix(stretched(1.01 * tol), [0.0; 3]),
        Err(Error::NotOrthonormal)
    );
    let reflect = [[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    assert_eq!(Extrinsics::from_matrix(reflect, [0.0; 3]), Err(Error::Reflection));
    let mut nan = stretched(0.0);
    nan[1][2] = f64::NAN;
    assert_eq!(
        Extrinsics::from_matrix(nan, [0.0; 3]),
        Err(Error::NotFinite(Field::Rotation))
    );
    // An accepted R at the tolerance still projects consistently with the
    // reference using the same matrix.
    let r = stretched(0.99 * tol);
    let pose = Extrinsics::from_matrix(r, [0.0; 3]).expect("ok");
    let cp = pose.world_to_camera(WorldPoint::from_f64([1.0, 2.0, 3.0]).expect("ok"));
    assert!((cp.value.x.to_num::<f64>() - r[0][0]).abs() < 1e-12);
}

/// An object at the focal length forms no image; one LSB beyond it, the
/// image is beyond I24F40 and saturates with the flag; the Newtonian form
/// rejects Z ≤ 0.
#[test]
fn extreme_objects_at_and_inside_focal_length() {
    let l = hyper_lens(10.0);
    let f = l.focal_length();
    assert_eq!(l.image_distance(f), Err(NoRealImage::InsideFocalLength));
    assert_eq!(
        l.image_distance(f - Len::DELTA),
        Err(NoRealImage::InsideFocalLength)
    );
    assert_eq!(l.blur_diameter(f), Err(NoRealImage::InsideFocalLength));
    assert_eq!(
        l.image_distance_newtonian(Len::ZERO),
        Err(NoRealImage::InsideFocalLength)
    );
    let just = l.image_distance(f + Len::DELTA).expect("real image");
    assert!(just.saturated);
    assert_eq!(just.value, Len::MAX);
    assert!(l.blur_diameter(f + Len::DELTA).expect("real image").saturated);
    // Focus at or inside f is a construction error.
    let bad = Lens::new(
        0.05,
        &LensConfig {
            focus_distance: 0.05,
            ..lens_cfg()
        },
    );
    assert_eq!(bad, Err(Error::FocusInsideFocalLength));
}
