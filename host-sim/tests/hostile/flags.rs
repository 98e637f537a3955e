//! Every command's numeric flags, range-checked.

use super::*;

/// Every numeric flag is range-checked with an error naming it (no panic,
/// no huge allocation), before anything is written.
#[test]
fn numeric_flags_are_range_checked() {
    let dir = scratch("flags");
    let out = dir.join("out");
    let o = out.to_str().expect("utf-8");
    let scene = repo().join("scenes/standard.toml");
    let s = scene.to_str().expect("utf-8");
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (
            vec![
                "receive",
                "--device",
                "/dev/null",
                "--out",
                o,
                "--timeout",
                "1e20",
            ],
            "--timeout",
        ),
        (
            vec!["receive", "--device", "/dev/null", "--out", o, "--timeout", "nan"],
            "--timeout",
        ),
        (
            vec!["receive", "--device", "/dev/null", "--out", o, "--timeout=-1"],
            "--timeout",
        ),
        (
            vec![
                "receive",
                "--device",
                "/dev/null",
                "--out",
                o,
                "--deadline",
                "inf",
            ],
            "--deadline",
        ),
        (
            vec!["receive", "--device", "/dev/null", "--out", o, "--frames", "0"],
            "--frames",
        ),
        (
            vec![
                "receive",
                "--device",
                "/dev/null",
                "--out",
                o,
                "--frames",
                "18446744073709551615",
            ],
            "--frames",
        ),
        (
            vec!["receive", "--device", "/dev/null", "--out", o, "--baud", "0"],
            "--baud",
        ),
        (
            vec!["stream", "--scene", s, "--out", o, "--frames", "4294967295"],
            "--frames",
        ),
        (
            vec!["stream", "--scene", s, "--out", o, "--frames", "0"],
            "--frames",
        ),
        (
            vec!["render", "--scene", s, "--out", o, "--max-lsb", "1e300"],
            "--max-lsb",
        ),
        (
            vec!["render", "--scene", s, "--out", o, "--max-geom-err-px", "nan"],
            "--max-geom-err-px",
        ),
        (vec!["faults", "--out", o, "--scale", "1e9"], "--scale"),
        (vec!["throughput", "--scene", s, "--frames", "0"], "--frames"),
        (vec!["tradeoff", "--out", o, "--repeats", "0"], "--repeats"),
        (
            vec![
                "profile",
                "--board",
                "lm3s6965evb",
                "--scene",
                s,
                "--out",
                o,
                "--top",
                "0",
            ],
            "--top",
        ),
        (
            vec![
                "profile",
                "--board",
                "lm3s6965evb",
                "--out",
                o,
                "--top",
                "18446744073709551616",
            ],
            "--top",
        ),
    ];
    for (args, flag) in cases {
        let r = run(&args);
        assert!(
            matches!(r.code, Some(1) | Some(2)) && !r.stderr.contains("panicked"),
            "{args:?}: exit {:?}: {}",
            r.code,
            r.stderr
        );
        assert!(
            r.stderr.contains(flag),
            "{args:?}: {flag} not named: {}",
            r.stderr
        );
        assert!(!out.exists(), "{args:?}: wrote {:?}", entries(&out));
    }
}
