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
