//! The sensor stages against what their users check them with:
//! - noise (camera-model.md §9): the EMVA 1288 photon-transfer method on
//!   rendered flat fields recovers the configured system gain and dark
//!   noise within 2 %;
//! - pixel-area sampling (§7) and noise: the core against the f64
//!   reference, which applies the same pattern, rule and generator, on
//!   random poses of a checkerboard;
//! - noise on the fast arithmetic (a scene without sampling or defocus):
//!   the planner's choice, against the reference.

use hilcam::num::scalar::I32F32;
use hilcam::planner::Budget;
use host_sim::harness::{collect, prepare};
use host_sim::scene_file::parse;

/// A flat field: a telecentric camera looking straight at a uniformly lit
/// Lambertian plane (no cos⁴ fall-off, no shading gradient), 12-bit.
fn flat_field(exposure: f64) -> String {
    format!(
        r#"
name = "flat"
[output]
format = "gray16"
bits = 12
exposure = {exposure}
[camera]
width = 640
height = 480
focal_length = 4e-3
pitch = 6e-6
f_number = 2.0
focus_distance = 1.0
tolerable_blur = 6e-6
model = "orthographic"
orthographic_scale = 0.01
pose = {{ eye = [0.0, 0.0, -1.0], target = [0.0, 0.0, 0.0], up = [0.0, 1.0, 0.0] }}
[noise]
saturation = 4000.0
dark_noise = 6.0
dark_offset = 40.0
seed = 7
[[materials]]
name = "grey"
albedo = 0.5
[[lights]]
kind = "directional"
direction = [0.0, 0.0, -1.0]
irradiance = 10.0
[[primitives]]
kind = "plane"
material = "grey"
point = [0.0, 0.0, 0.0]
normal = [0.0, 0.0, -1.0]
"#
    )
}

/// Frame `id` of a scene, as 16-bit values.
fn frame(text: &str, id: u32) -> Vec<f64> {
    let r = parse(text).expect("scene");
    let (_, _, mut f) = prepare::<I32F32>(&r, &Budget::default(), |p| p.options).expect("prepares");
    f.set_frame_id(id);
    let c = collect(&f).expect("renders");
    c.pixels
        .chunks_exact(2)
        .map(|b| f64::from(u16::from_le_bytes([b[0], b[1]])))
        .collect()
}

/// Mean of two frames, and the temporal variance `var(A − B) / 2`.
fn mean_var(a: &[f64], b: &[f64]) -> (f64, f64) {
    let n = a.len() as f64;
    let mean = a.iter().chain(b).sum::<f64>() / (2.0 * n);
    let d: Vec<f64> = a.iter().zip(b).map(|(x, y)| x - y).collect();
    let dm = d.iter().sum::<f64>() / n;
    let var = d.iter().map(|v| (v - dm).powi(2)).sum::<f64>() / (n - 1.0) / 2.0;
    (mean, var)
}

#[test]
fn photon_transfer_recovers_the_system_gain_and_dark_noise() {
    let (k_true, sigma_d_true) = (4095.0 / 4000.0, 6.0);
    // Dark: exposure 0.
    let dark = flat_field(0.0);
    let (mu_dark, var_dark) = mean_var(&frame(&dark, 0), &frame(&dark, 1));
    // Bright levels up to ~70 % of full scale (EMVA fits below saturation).
    let mut pts = Vec::new();
    for (i, exposure) in [100.0, 200.0, 400.0, 600.0, 800.0, 1000.0, 1200.0, 1400.0]
        .into_iter()
        .enumerate()
    {
        let s = flat_field(exposure);
        let id = 2 + 2 * i as u32;
        let (mu, var) = mean_var(&frame(&s, id), &frame(&s, id + 1));
        assert!(mu < 0.75 * 4095.0, "level {exposure} saturates: mean {mu}");
        pts.push((mu - mu_dark, var - var_dark));
    }
    // EMVA 1288: the slope of σ²_y − σ²_y,dark against μ_y − μ_y,dark,
    // through the origin, is K; σ²_y,dark = K² σ_d² + 1/12 (quantization).
    let k = pts.iter().map(|(m, v)| m * v).sum::<f64>() / pts.iter().map(|(m, _)| m * m).sum::<f64>();
    let sigma_d = (var_dark - 1.0 / 12.0).max(0.0).sqrt() / k;
    let (ek, ed) = (k / k_true - 1.0, sigma_d / sigma_d_true - 1.0);
    println!(
        "photon transfer: K = {k:.5} DN/e- (true {k_true:.5}, {:+.2} %), sigma_d = {sigma_d:.4} e- (true {sigma_d_true}, {:+.2} %), dark mean {mu_dark:.3} DN",
        100.0 * ek,
        100.0 * ed
    );
    assert!(ek.abs() <= 0.02, "system gain off by {:.2} %", 100.0 * ek);
    assert!(ed.abs() <= 0.02, "dark noise off by {:.2} %", 100.0 * ed);
    assert!((mu_dark - 40.0).abs() < 0.1, "dark offset {mu_dark}");
}

#[test]
fn noise_depends_on_the_frame_id_and_seed_only() {
    let s = flat_field(500.0);
    let (a, b, a2) = (frame(&s, 3), frame(&s, 4), frame(&s, 3));
    assert_eq!(a, a2, "the same frame id gives the same bytes");
    assert_ne!(a, b, "another frame id gives other noise");
    let other = s.replace("seed = 7", "seed = 8");
    assert_ne!(a, frame(&other, 3), "another seed gives other noise");
}

/// The shipped calibration board (scenes/calibration/plain-00.toml) at a
/// random pose on a smaller, wider-angle sensor under random barrel
/// distortion, with a small sphere in front, sampled for `edge_error`
/// (adaptive or not), with or without noise.
fn board(rng: &mut u64, edge_error: f64, adaptive: bool, noise: bool) -> String {
    let mut next = || {
        *rng = rng
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((*rng >> 11) as f64) / ((1u64 << 53) as f64)
    };
    let yaw = (next() - 0.5) * 1.2;
    let pitch = (next() - 0.5) * 1.0;
    let d = 0.35 + 0.2 * next();
    let roll = (next() - 0.5) * 1.0;
    let k1 = 0.3 * next();
    let eye = [
        d * yaw.sin() * pitch.cos(),
        d * pitch.sin(),
        -d * yaw.cos() * pitch.cos(),
    ];
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/calibration/plain-00.toml");
    let text = std::fs::read_to_string(path).expect("the calibration board");
    let mut t: toml::Table = text.parse().expect("TOML");
    let cam = t
        .get_mut("camera")
        .and_then(toml::Value::as_table_mut)
        .expect("camera");
    cam.insert("width".into(), 200.into());
    cam.insert("height".into(), 150.into());
    cam.insert("focal_length".into(), 1.2e-3.into());
    cam.insert(
        "distortion".into(),
        toml::Value::Array(vec![k1.into(), 0.0.into()]),
    );
    let mut pose = toml::Table::new();
    pose.insert(
        "eye".into(),
        toml::Value::Array(eye.map(toml::Value::from).to_vec()),
    );
    pose.insert("target".into(), toml::Value::Array(vec![0.0.into(); 3]));
    pose.insert(
        "up".into(),
        toml::Value::Array(vec![roll.sin().into(), roll.cos().into(), 0.0.into()]),
    );
    cam.insert("pose".into(), pose.into());
    let mut sampling = toml::Table::new();
    sampling.insert("edge_error".into(), edge_error.into());
    sampling.insert("adaptive".into(), adaptive.into());
    t.insert("sampling".into(), sampling.into());
    if noise {
        let n: toml::Table = "saturation = 9000.0\ndark_noise = 3.0\ndark_offset = 4.0\nseed = 11"
            .parse()
            .expect("noise");
        t.insert("noise".into(), n.into());
    }
    let sphere: toml::Table =
        "kind = \"sphere\"\nmaterial = \"white\"\ncentre = [0.1, 0.08, -0.05]\nradius = 0.02"
            .parse()
            .expect("sphere");
    t.get_mut("primitives")
        .and_then(toml::Value::as_array_mut)
        .expect("primitives")
        .push(sphere.into());
    t.to_string()
}

/// The fidelity targets against the reference: ≤ 1 LSB and ≥ 99 % exact
/// over smooth pixels, ≤ 0.05 % differing edge pixels, the same field
/// flags.
fn meets_fidelity_targets(m: &host_sim::harness::Metrics, k: usize) {
    assert!(
        m.max_abs_lsb_smooth <= 1,
        "case {k}: {} LSB on smooth pixels",
        m.max_abs_lsb_smooth
    );
    assert!(
        m.exact_fraction_smooth >= 0.99,
        "case {k}: exact {}",
        m.exact_fraction_smooth
    );
    assert!(
        m.edge_pixels_differing_fraction <= 0.0005,
        "case {k}: edges differ"
    );
    assert_eq!(m.field_flags_differing, 0, "case {k}: field flags");
}

#[test]
fn sampled_and_noisy_frames_match_the_reference() {
    let mut rng = 0x5eed_u64;
    let cases = [
        (0.25, false, false),
        (0.125, true, false),
        (0.125, false, true),
        (0.0625, true, true),
        (0.03125, true, false),
    ];
    for (k, (edge, adaptive, noise)) in cases.into_iter().cycle().take(15).enumerate() {
        let text = board(&mut rng, edge, adaptive, noise);
        let r = parse(&text).expect("scene");
        let out = host_sim::harness::render(&r, &Budget::default()).expect("renders");
        let m = &out.metrics;
        let st = &m.plan;
        let want = hilcam::render::sensor::sampling::grid_for(edge);
        assert_eq!(
            (st.samples, st.adaptive),
            (want, adaptive),
            "case {k}: the plan's pattern"
        );
        let s = m
            .sampling_error
            .expect("a sampled frame reports its sampling error");
        let predicted = st
            .candidates
            .iter()
            .find(|c| c.name == st.chosen)
            .map_or(f64::NAN, |c| c.edge_differing);
        println!(
            "case {k}: {}x{} adaptive={adaptive} noise={noise}: {}, smooth max {} LSB, exact {:.4}, edges differing {:.5} % (predicted {:.5} %), grid pixels {}, sampling error rms {:.3} max {:.2} DN",
            want, want, st.chosen, m.max_abs_lsb_smooth, m.exact_fraction_smooth, 100.0 * m.edge_pixels_differing_fraction, 100.0 * predicted, s.grid_pixels, s.rms_dn, s.max_dn
        );
        meets_fidelity_targets(m, k);
        assert!(s.grid_pixels > 0, "case {k}: edges cross the board");
        // The grid places straight edges within 1/(2n) px: against the
        // converged 16x16 estimate the RMS error is well under the
        // contrast (≈ 150 DN) times that.
        assert!(
            s.rms_dn <= 150.0 * hilcam::render::sensor::sampling::edge_error(want),
            "case {k}: sampling error {s:?}"
        );
    }
}

/// Noise without sampling or defocus runs on the fast arithmetic (the
/// planner's choice: it is cheaper and within budget), and its frames
/// match the reference's — which draws the same `z` and takes `σ` in f64 —
/// within the fidelity targets, at every exposure from dark to
/// saturating, in gray16 and RGB565.
#[test]
fn noise_on_the_fast_arithmetic_matches_the_reference() {
    let base = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/low-light.toml"))
        .expect("scenes/low-light.toml");
    assert!(base.contains("exposure = 2000.0") && base.contains("[noise]"));
    for (k, (exposure, rgb)) in [
        (0.0, false),
        (300.0, false),
        (2000.0, false),
        (40000.0, false),
        (2000.0, true),
    ]
    .into_iter()
    .enumerate()
    {
        let mut text = base.replace("exposure = 2000.0", &format!("exposure = {exposure:.1}"));
        if rgb {
            // RGB565: 5 bits of red and blue, so a dark offset within them.
            text = text
                .replace("format = \"gray16\"", "format = \"rgb565\"")
                .replace("bits = 12\n", "")
                .replace("dark_offset = 40.0", "dark_offset = 2.0");
            assert!(text.contains("rgb565") && text.contains("dark_offset = 2.0"));
        }
        let r = parse(&text).expect("scene");
        let out = host_sim::harness::render(&r, &Budget::default()).expect("renders");
        let m = &out.metrics;
        assert_eq!(m.plan.arithmetic, "fast", "case {k}: the planner's arithmetic");
        println!(
            "fast noise case {k} (exposure {exposure}, rgb {rgb}): smooth max {} LSB, exact {:.4}, psnr {:?} dB, edges differing {:.5} %",
            m.max_abs_lsb_smooth,
            m.exact_fraction_smooth,
            m.psnr_db_smooth,
            100.0 * m.edge_pixels_differing_fraction
        );
        meets_fidelity_targets(m, k);
    }
}

/// The core's table of `|z|` cubics is the fit docs/sensor.md defines,
/// computed again from the reference's inverse normal distribution.
#[test]
fn the_normal_table_is_the_documented_fit() {
    let fit = host_sim::reference::noise::half_normal_table();
    let core = hilcam::render::sensor::noise::HALF_NORMAL;
    if fit.as_slice() != core.as_slice() {
        let rows: Vec<String> = fit
            .iter()
            .map(|c| format!("    [{}, {}, {}, {}],", c[0], c[1], c[2], c[3]))
            .collect();
        panic!("HALF_NORMAL differs from the fit; it is:\n{}", rows.join("\n"));
    }
}

/// The core's deviate against the reference's `±√2 erfc⁻¹(t)` (f64),
/// within `hilcam::render::sensor::noise::Z_ERR`: on every half octave at 257 points of
/// its fraction (both ends included), and on random hashes.
#[test]
fn the_normal_deviate_is_the_references_within_its_bound() {
    use host_sim::reference::noise::{abs_deviate, uniform_of};
    let check = |h: u64, worst: &mut (f64, u64)| {
        let core = f64::from(hilcam::render::sensor::noise::normal_of_hash(h)) / 65_536.0;
        let exact = abs_deviate(uniform_of(h)) * if h >> 63 == 1 { -1.0 } else { 1.0 };
        let err = (core - exact).abs();
        if err > worst.0 {
            *worst = (err, h);
        }
    };
    let mut worst = (0.0, 0);
    for lz in 1..=63u32 {
        // v with lz leading zeros: 2^(63 − lz) plus a fraction of it.
        let top = 1u64 << (63 - lz);
        for k in 0..=256u64 {
            let below = top - 1;
            let frac = if k == 256 {
                below
            } else {
                ((u128::from(below) * u128::from(k)) >> 8) as u64
            };
            for sign in [0, 1u64 << 63] {
                check(sign | top | frac | 1, &mut worst);
            }
        }
    }
    let mut x = 0x5eed_u64;
    for _ in 0..1_000_000 {
        x = hilcam::render::sensor::noise::mix(x.wrapping_add(0x9e37_79b9_7f4a_7c15));
        check(x, &mut worst);
    }
    println!("largest |z| error: {:.3e} (hash {:#018x})", worst.0, worst.1);
    assert!(
        worst.0 <= hilcam::render::sensor::noise::Z_ERR,
        "{:.3e} at {:#018x}",
        worst.0,
        worst.1
    );
}
