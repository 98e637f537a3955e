//! Shared helpers of the property tests: generators over the documented valid
//! ranges, and a recorder of the largest error each test saw.
#![allow(dead_code)]

pub mod fixture;

use proptest::prelude::*;
use proptest::test_runner::{Config, TestCaseError, TestRunner};
use std::sync::atomic::{AtomicU64, Ordering};

/// Cases per property, as the foundation issue asks.
pub const CASES: u32 = 10_000;

/// Runs `test` over `CASES` cases of `strategy`, with a fixed seed so a run
/// is reproducible, and panics with the minimal failing case on failure.
pub fn check<S: Strategy>(strategy: S, test: impl Fn(S::Value) -> Result<(), TestCaseError>) {
    let mut config = Config::with_cases(CASES);
    config.failure_persistence = None;
    let mut runner = TestRunner::new_with_rng(
        config,
        proptest::test_runner::TestRng::deterministic_rng(proptest::test_runner::RngAlgorithm::ChaCha),
    );
    if let Err(e) = runner.run(&strategy, test) {
        panic!("{e}");
    }
}

/// The largest value recorded, reported to `target/tmp/accuracy/NAME.txt`.
pub struct Max {
    bits: AtomicU64,
    count: AtomicU64,
    name: &'static str,
    unit: &'static str,
}

impl Max {
    pub const fn new(name: &'static str, unit: &'static str) -> Self {
        Max {
            bits: AtomicU64::new(0),
            count: AtomicU64::new(0),
            name,
            unit,
        }
    }

    pub fn record(&self, v: f64) {
        assert!(v >= 0.0, "{}: error {v} is negative or NaN", self.name);
        self.bits.fetch_max(v.to_bits(), Ordering::Relaxed);
        self.count.fetch_add(1, Ordering::Relaxed);
    }

    pub fn get(&self) -> f64 {
        f64::from_bits(self.bits.load(Ordering::Relaxed))
    }

    /// Writes the figure where the test script collects it.
    pub fn report(&self) {
        let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("accuracy");
        let _ = std::fs::create_dir_all(&dir);
        let line = format!(
            "{:<58} max {:>10.3e} {} over {} comparisons\n",
            self.name,
            self.get(),
            self.unit,
            self.count.load(Ordering::Relaxed)
        );
        let _ = std::fs::write(dir.join(format!("{}.txt", self.name)), line);
    }
}

/// Log-uniform in `[lo, hi]`.
pub fn log_uniform(lo: f64, hi: f64) -> impl Strategy<Value = f64> {
    (0.0f64..=1.0).prop_map(move |u| (lo.ln() + u * (hi.ln() - lo.ln())).exp().clamp(lo, hi))
}

/// Relative error, with `floor` as the smallest magnitude it divides by.
pub fn rel(core: f64, reference: f64, floor: f64) -> f64 {
    (core - reference).abs() / reference.abs().max(floor)
}

/// Random intrinsics over the documented ranges.
#[derive(Clone, Copy, Debug)]
pub struct Cam {
    pub f: f64,
    pub sx: f64,
    pub sy: f64,
    pub w: u16,
    pub h: u16,
    pub pp: Option<(f64, f64)>,
}

pub fn cam() -> impl Strategy<Value = Cam> {
    (
        log_uniform(1e-4, 10.0),
        log_uniform(1e-7, 1e-3),
        0.5f64..2.0,
        1u16..=16384,
        1u16..=16384,
        prop::option::of((-0.2f64..1.2, -0.2f64..1.2)),
    )
        .prop_map(|(f, sx, aspect, w, h, pp)| {
            let sy = (sx * aspect).clamp(1e-7, 1e-3);
            Cam {
                f,
                sx,
                sy,
                w,
                h,
                pp: pp.map(|(u, v)| (u * w as f64, v * h as f64)),
            }
        })
}

impl Cam {
    pub fn config(&self) -> hilcam::IntrinsicsConfig {
        hilcam::IntrinsicsConfig {
            focal_length: self.f,
            pitch: (self.sx, self.sy),
            size: (self.w, self.h),
            principal_point: self.pp,
        }
    }

    pub fn sensor(&self) -> host_sim::reference::intrinsics::Sensor {
        let mut s = host_sim::reference::intrinsics::Sensor::centred(
            self.f,
            self.sx,
            self.sy,
            self.w as u32,
            self.h as u32,
        );
        if let Some((ox, oy)) = self.pp {
            s.ox = ox;
            s.oy = oy;
        }
        s
    }
}

/// A pose: yaw, pitch, roll (radians) and the centre of projection (metres,
/// within ±1000 m so that `P − T` of a quantized point is exact in f64).
pub fn pose() -> impl Strategy<Value = ([f64; 3], [f64; 3])> {
    let a = -std::f64::consts::PI..std::f64::consts::PI;
    let t = -1000.0f64..1000.0;
    ((a.clone(), a.clone(), a), (t.clone(), t.clone(), t))
        .prop_map(|((y, p, r), (tx, ty, tz))| ([y, p, r], [tx, ty, tz]))
}

/// A pixel position within the sensor plus a margin of half the sensor.
pub fn pixel_in(w: u16, h: u16) -> impl Strategy<Value = (f64, f64)> {
    let (w, h) = (w as f64, h as f64);
    (-0.5f64..1.5, -0.5f64..1.5).prop_map(move |(u, v)| (u * w, v * h))
}

/// [`host_sim::scene_file::parse`] with one sample a pixel where the text
/// asks for no pattern: the tests of other stages keep the centre sample (a
/// scene without `[sampling]` gets the sensor's 1/8 px default).
pub fn parse_point(text: &str) -> Result<host_sim::scene_file::Resolved, String> {
    if text.contains("[sampling]") {
        host_sim::scene_file::parse(text)
    } else {
        host_sim::scene_file::parse(&format!("{text}\n[sampling]\nedge_error = 0.5\n"))
    }
}
