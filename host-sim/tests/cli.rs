//! The command line: the demo runs, compares core and reference, and passes.

use std::process::Command;

#[test]
fn demo_reports_core_and_reference_within_targets() {
    let out = Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .arg("demo")
        .output()
        .expect("runs");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "demo failed: {text}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for needle in [
        "perspective:",
        "weak-persp",
        "orthographic",
        "lens:",
        "DOF near",
        "summary:",
    ] {
        assert!(text.contains(needle), "missing {needle:?} in:\n{text}");
    }
    // two points are not visible under each of the three models
    assert_eq!(text.matches("not visible").count(), 2 * 2 * 3);
}

#[test]
fn unknown_subcommand_is_a_clear_error() {
    let out = Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .arg("nonsense")
        .output()
        .expect("runs");
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("unrecognized subcommand"));
}

/// The speed/accuracy sweep runs on a tiny configuration (host only) and
/// writes its three files with the keys the report promises.
#[test]
fn tradeoff_sweep_runs_on_a_tiny_configuration() {
    let dir = std::env::temp_dir().join(format!("hilcam-tradeoff-{}", std::process::id()));
    let out = Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .args([
            "tradeoff",
            "--tiny",
            "--boards",
            "none",
            "--repeats",
            "1",
            "--out",
        ])
        .arg(&dir)
        .output()
        .expect("runs");
    assert!(
        out.status.success(),
        "tradeoff failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("tradeoff.json")).expect("json")).expect("parses");
    let rows = json["variants"].as_array().expect("variants");
    // The reference and the four tiny variants.
    assert_eq!(rows.len(), 5);
    for r in rows {
        for key in [
            "variant",
            "max_geom_err_px",
            "max_abs_lsb",
            "max_abs_lsb_smooth",
            "psnr_db",
            "edge_pixels_differing",
            "instructions_per_pixel_m3",
            "instructions_per_pixel_m4f",
            "host_ns_per_pixel",
            "table_bytes",
        ] {
            assert!(r.get(key).is_some(), "{key} missing in {r}");
        }
        assert!(r["host_ns_per_pixel"].as_f64().is_some_and(|v| v > 0.0), "{r}");
    }
    assert!(rows
        .iter()
        .any(|r| r["variant"].as_str().is_some_and(|v| v.contains("f32"))));
    // The planned renderer meets its budget on the tiny scene too.
    let planned = rows.iter().find(|r| r["variant"] == "planned").expect("planned");
    assert!(
        planned["max_geom_err_px"]
            .as_f64()
            .is_some_and(|v| v <= 1.0 / 256.0),
        "{planned}"
    );
    assert!(
        planned["max_abs_lsb_smooth"].as_u64().is_some_and(|v| v <= 1),
        "{planned}"
    );
    // So does the per-quantity 32-bit format set.
    let mix = rows.iter().find(|r| r["variant"] == "mix32-poly").expect("mix32");
    assert!(
        mix["max_abs_lsb_smooth"].as_u64().is_some_and(|v| v <= 1),
        "{mix}"
    );
    let md = std::fs::read_to_string(dir.join("tradeoff.md")).expect("md");
    assert!(md.contains("| tiny | f32-poly |"), "{md}");
    let png = std::fs::read(dir.join("tradeoff.png")).expect("png");
    assert_eq!(&png[1..4], b"PNG");
    let _ = std::fs::remove_dir_all(&dir);
}
