//! Extremes of rendering: each test states the expected behaviour (agreement
//! with the reference over smooth pixels, a typed error, a flag, saturation)
//! and asserts it.

use crate::common;
use hilcam::planner::{plan, Budget};
use hilcam::render::{Frame, FLAG_OUTSIDE_FIELD};
use host_sim::harness::{render_skipping_stage_errors, RenderOutput};
use host_sim::reference::render::RefScene;

use common::fixture::{
    agrees, agrees_off_edges, scene, try_scene, CHECKER_FLOOR, INSIDE_SPHERE, TANGENT_SPHERE,
};

fn run(r: &host_sim::scene_file::Resolved) -> RenderOutput {
    render_skipping_stage_errors(r, &Budget::default()).expect("renders")
}

/// Grazing rays: the camera 5 cm above an infinite checkered floor, looking
/// along it, so the horizon crosses the frame and rays near it meet the
/// floor hundreds to millions of metres away (a division by a vanishing
/// `n̂·d`). Expected: no wrap and no panic; far hits whose quotient leaves
/// I32F32 become misses (background), as the reference's would at the same
/// distances within an edge pixel; smooth pixels agree within 1 LSB.
#[test]
fn extreme_grazing_rays_on_a_plane() {
    let r = scene(
        CHECKER_FLOOR,
        &[(
            "eye = [0.0123, 1.2, -3.0], target = [0.0, 0.4, 0.0]",
            "eye = [0.0123, 0.0537, -3.0], target = [0.0, 0.0537, 10.0]",
        )],
    );
    let o = run(&r);
    agrees(&o.metrics);
    assert!(
        o.metrics.edge_pixels > 0,
        "the far floor aliases into edge pixels"
    );
}

/// Rays tangent to a sphere: a sphere filling most of the frame, its
/// silhouette crossing many pixels where the discriminant is near 0.
/// Expected: agreement over smooth pixels; only edge pixels may differ.
#[test]
fn extreme_rays_tangent_to_a_sphere() {
    let r = scene(TANGENT_SPHERE, &[]);
    let o = run(&r);
    agrees(&o.metrics);
    assert!(o.metrics.exact_fraction >= 0.99);
}

/// The camera inside a sphere sees its inner surface (the far root of the
/// intersection), shaded with the normal turned towards the viewer.
#[test]
fn extreme_camera_inside_a_sphere() {
    let r = scene(
        INSIDE_SPHERE,
        &[("[environment]\nambient = 0.2", "[environment]\nambient = 0.5")],
    );
    let o = run(&r);
    agrees(&o.metrics);
    assert!(o.core_dn.iter().all(|p| p[0] > 0), "every ray hits the inside");
}

/// Extreme wide angle: undistorted corners at slopes of 15 (86.2° off axis),
/// where cos⁴α ≈ 2·10⁻⁵: corner pixels go to 0 with the reference. Past the
/// renderer's slope limit of 16 the frame is refused with a typed error.
#[test]
fn extreme_wide_angle_cos4_to_zero() {
    // 96 px wide, f/s = 3.2 px: corner slope ≈ 47.5/3.2 ≈ 14.8
    let wide = [
        ("focal_length = 2.4e-3", "focal_length = 3.2e-3"),
        ("pitch = 12e-6", "pitch = 1e-3"),
    ];
    let r = scene(CHECKER_FLOOR, &wide);
    let o = run(&r);
    agrees(&o.metrics);
    assert_eq!(o.core_dn[0][0], 0, "corner fully vignetted");
    assert_eq!(o.reference.dn[0][0], 0);
    // f/s = 2.4 px: corner slope ≈ 19.8, past 16: refused when loaded,
    // naming the fields, not at render.
    let too_wide = try_scene(
        CHECKER_FLOOR,
        &[
            ("focal_length = 2.4e-3", "focal_length = 2.4e-3"),
            ("pitch = 12e-6", "pitch = 1e-3"),
        ],
    );
    let e = too_wide.expect_err("a field too wide is refused at load");
    assert!(e.contains("camera.pitch") && e.contains("field too wide"), "{e}");
}

/// Exposure saturation: at K = 10⁹ every lit pixel saturates at DN_max (in
/// every format), never wrapping; at K = 0 every pixel is 0.
#[test]
fn extreme_exposure_saturation() {
    for (fmt, max) in [
        ("format = \"gray8\"", 255u32),
        ("format = \"gray16\"\nbits = 12", 4095),
        ("format = \"rgb565\"", 31),
    ] {
        let r = scene(
            CHECKER_FLOOR,
            &[
                ("exposure = 800.0", "exposure = 1e9"),
                ("format = \"gray8\"", fmt),
            ],
        );
        let o = run(&r);
        assert!(o.core_dn.iter().all(|p| p[0] == max), "{fmt}: not all saturated");
        assert_eq!(o.metrics.max_abs_lsb, 0);
        let dark = run(&scene(
            CHECKER_FLOOR,
            &[
                ("exposure = 800.0", "exposure = 0.0"),
                ("format = \"gray8\"", fmt),
            ],
        ));
        assert!(dark.core_dn.iter().all(|p| *p == [0, 0, 0]));
    }
}

/// A 1×1 sensor renders its single pixel as the reference does.
#[test]
fn extreme_one_pixel_sensor() {
    // (the target moved off a cell boundary: the one ray would meet the
    // floor exactly on one)
    let r = scene(
        CHECKER_FLOOR,
        &[
            ("width = 96", "width = 1"),
            ("height = 64", "height = 1"),
            ("target = [0.0, 0.4, 0.0]", "target = [0.0, 0.4, 0.0371]"),
        ],
    );
    let o = run(&r);
    assert_eq!(o.core_dn.len(), 1);
    assert_eq!(o.metrics.max_abs_lsb, 0);
}

/// The largest supported sensor, 16384×16384: the frame prepares, and its
/// first and last lines (every pixel) match the reference within 1 LSB
/// except at edge pixels (checked by the reference's 1/256 px keys).
#[test]
fn extreme_largest_sensor() {
    let r = scene(
        CHECKER_FLOOR,
        &[
            ("width = 96", "width = 16384"),
            ("height = 64", "height = 16384"),
            ("pitch = 12e-6", "pitch = 1e-7"),
        ],
    );
    let s = r.core_scene().expect("valid");
    let frame = Frame::new(&s, &plan(&s, &Budget::default()).options).expect("prepares");
    let rs = RefScene::new(&r);
    let mut line = vec![0u8; frame.line_bytes()];
    let mut flags = vec![0u8; 16384];
    let mut compared = 0;
    for j in [0u16, 8191, 16383] {
        frame.render_line(j, &mut line, &mut flags).expect("renders");
        for i in (0..16384u16).step_by(7) {
            let core = s.format().unpack(&line[i as usize..i as usize + 1])[0];
            let (want, _) = rs.pixel(i as f64, j as f64);
            let k = rs.key(i as f64, j as f64);
            let e = 1.0 / 256.0;
            let edge = [(e, 0.0), (-e, 0.0), (0.0, e), (0.0, -e)]
                .iter()
                .any(|(dx, dy)| rs.key(i as f64 + dx, j as f64 + dy) != k);
            if !edge {
                assert!(
                    core.abs_diff(want[0]) <= 1,
                    "pixel ({i}, {j}): core {core} reference {}",
                    want[0]
                );
                compared += 1;
            }
        }
    }
    assert!(compared > 6000);
}

/// k1, k2 that fold the image over inside the sensor: pixels beyond the fold
/// radius are flagged outside the lens field and black, the flags agree with
/// the reference's, and the rest agrees with it.
#[test]
fn extreme_fold_inside_the_sensor() {
    // k1 = -6: the fold at u = 1/18, inside the corners' u = 0.081
    let r = scene(
        CHECKER_FLOOR,
        &[(
            "tolerable_blur = 12e-6",
            "tolerable_blur = 12e-6\ndistortion = [-6.0, 0.0]",
        )],
    );
    let o = run(&r);
    assert!(
        o.metrics.outside_field_pixels > 100,
        "{}",
        o.metrics.outside_field_pixels
    );
    agrees(&o.metrics);
    for (k, f) in o.core.flags.iter().enumerate() {
        if f & FLAG_OUTSIDE_FIELD != 0 {
            assert_eq!(o.core_dn[k], [0, 0, 0]);
        }
    }
}

/// A distortion strong enough that g reaches 30 over the sensor: the table's
/// entries take a coarser format chosen for the camera, and the geometry
/// stays within 1/256 px. The lens squeezes checker cells to a pixel or less
/// at the edges, so edge pixels are dense (7 of 6 144 differ, 0.11 %): they
/// may, by definition; smooth pixels agree.
#[test]
fn extreme_strong_distortion_coarser_table_format() {
    let r = scene(
        CHECKER_FLOOR,
        &[(
            "tolerable_blur = 12e-6",
            "tolerable_blur = 12e-6\ndistortion = [10.0, 100.0]",
        )],
    );
    // The fast arithmetic's formats do not hold g = 30: the planner falls
    // back to the wide one, with the polynomial or a table.
    let o = run(&r);
    assert_eq!(o.metrics.plan.arithmetic, "wide");
    assert!(
        o.metrics.max_geom_err_px <= 1.0 / 256.0,
        "{}",
        o.metrics.max_geom_err_px
    );
    agrees_off_edges(&o.metrics);
    // The planner's table candidate, rendered: its entries take a coarser
    // format than I2F30, and it stays within the budget.
    let table = o
        .plan
        .candidates
        .iter()
        .find(|c| c.lut_entries > 0)
        .expect("a table candidate");
    let v = host_sim::variant::Variant::parse(&format!("i32f32-lut{}-linear", table.lut_entries))
        .expect("variant");
    let (_, plan, frame, core) =
        host_sim::variant::core_render_variant::<hilcam::num::scalar::I32F32>(&r, &Budget::default(), &v)
            .expect("renders");
    let rs = host_sim::reference::render::RefScene::new(&r);
    let m = host_sim::harness::compare(&r, &rs, &rs.render(), &plan, &Budget::default(), &frame, &core);
    let fmt = m.plan.lut_format.clone().expect("a table");
    assert!(fmt != "I2F30", "format {fmt} should be coarser");
    assert!(m.max_geom_err_px <= 1.0 / 256.0, "{}", m.max_geom_err_px);
    agrees_off_edges(&m);
}
