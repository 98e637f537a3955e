//! The sweep's figures as reported: the rows, growth and pruning figures
//! and recommendations (`tradeoff.json`), and the markdown table
//! (`tradeoff.md`).

use crate::harness::Metrics;
use crate::scene_file::Resolved;
use crate::variant::Variant;
use serde::Serialize;

/// One variant on one scene.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    /// Variant name (`f64-reference` for the reference itself).
    pub variant: String,
    /// Per-pixel number type.
    pub scalar: String,
    /// Scene.
    pub scene: String,
    /// Largest pixel → undistorted error against the reference, px.
    pub max_geom_err_px: f64,
    /// RMS of it, px.
    pub rms_geom_err_px: f64,
    /// Largest |variant − reference| over all pixels, LSB.
    pub max_abs_lsb: u32,
    /// RMS over all pixels, LSB.
    pub rms_lsb: f64,
    /// PSNR over all pixels, dB (null: identical).
    pub psnr_db: Option<f64>,
    /// Largest |variant − reference| over smooth pixels, LSB.
    pub max_abs_lsb_smooth: u32,
    /// RMS over smooth pixels, LSB.
    pub rms_lsb_smooth: f64,
    /// PSNR over smooth pixels, dB (null: identical).
    pub psnr_db_smooth: Option<f64>,
    /// Fraction of pixels identical to the reference.
    pub exact_fraction: f64,
    /// Edge pixels whose values differ from the reference.
    pub edge_pixels_differing: usize,
    /// Sample grid side (1: the pixel centre).
    pub samples: u8,
    /// The sample pattern's RMS error against 16×16 samples a pixel, DN
    /// (null with one sample).
    pub sampling_rms_dn: Option<f64>,
    /// Instructions per pixel on the Cortex-M3 (QEMU icount; not cycles).
    pub instructions_per_pixel_m3: Option<f64>,
    /// Instructions per pixel on the Cortex-M4F.
    pub instructions_per_pixel_m4f: Option<f64>,
    /// The M3 frame was byte-identical to the host render of the variant.
    pub bit_exact_m3: Option<bool>,
    /// The M4F frame was byte-identical to the host render of the variant.
    pub bit_exact_m4f: Option<bool>,
    /// Host ns per pixel, median of the repeats (prepare + render).
    pub host_ns_per_pixel: f64,
    /// Distortion table bytes.
    pub table_bytes: usize,
    /// Flash of the M3 firmware holding this scalar type's variants, bytes.
    pub flash_bytes_m3: Option<u64>,
    /// Flash of the M4F firmware holding this scalar type's variants, bytes.
    pub flash_bytes_m4f: Option<u64>,
}

/// Instructions per frame at one size or primitive count.
#[derive(Clone, Debug, Serialize)]
pub struct GrowthPoint {
    /// Scene.
    pub scene: String,
    /// Pixels.
    pub pixels: u64,
    /// Primitives.
    pub primitives: usize,
    /// Instructions per frame (M3, M4F).
    pub instructions_m3: Option<u64>,
    /// Instructions per frame on the M4F.
    pub instructions_m4f: Option<u64>,
}

/// Growth of one variant.
#[derive(Clone, Debug, Serialize)]
pub struct Growth {
    /// Variant.
    pub variant: String,
    /// 80×60 to 640×480, standard scene.
    pub resolution: Vec<GrowthPoint>,
    /// 1 to 16 primitives, standard scene at 160×120.
    pub primitives: Vec<GrowthPoint>,
    /// Least-squares slope of instructions per frame against pixels (M3).
    pub per_pixel_slope_m3: Option<f64>,
    /// The same on the M4F.
    pub per_pixel_slope_m4f: Option<f64>,
    /// Least-squares slope of instructions per frame against primitives (M3).
    pub per_primitive_slope_m3: Option<f64>,
    /// The same on the M4F.
    pub per_primitive_slope_m4f: Option<f64>,
}

/// What the planner's pruning saves on one scene.
#[derive(Clone, Debug, Serialize)]
pub struct Pruning {
    /// Scene.
    pub scene: String,
    /// Stages the planner dropped (or simplified) for it.
    pub dropped: Vec<String>,
    /// Instructions per pixel, planned / with every stage (M3).
    pub planned_m3: Option<f64>,
    /// With every stage (M3).
    pub all_stages_m3: Option<f64>,
    /// Planned (M4F).
    pub planned_m4f: Option<f64>,
    /// With every stage (M4F).
    pub all_stages_m4f: Option<f64>,
    /// Host ns per pixel, planned.
    pub planned_host_ns: f64,
    /// Host ns per pixel, every stage.
    pub all_stages_host_ns: f64,
    /// Largest |planned − all stages| over all pixels, LSB (the pruning's
    /// own effect on the image).
    pub max_abs_lsb_between: u32,
}

/// A recommendation.
#[derive(Clone, Debug, Serialize)]
pub struct Recommendation {
    /// M0, M3, M4F or host.
    pub target: String,
    /// Variant.
    pub variant: String,
    /// Why.
    pub reason: String,
}

/// `tradeoff.json`.
#[derive(Clone, Debug, Serialize)]
pub struct Report {
    /// Every variant on every sweep scene.
    pub variants: Vec<Row>,
    /// Growth runs.
    pub growth: Vec<Growth>,
    /// Pruning runs.
    pub pruning: Vec<Pruning>,
    /// Recommendations.
    pub recommendations: Vec<Recommendation>,
    /// The fixed-point variant with the fewest M3 instructions per pixel of
    /// those within 1 LSB on smooth pixels on every sweep scene.
    pub best_fixed_m3: Option<String>,
    /// On the M3, first sweep scene: the cheapest f32 (soft-float) variant's
    /// instructions per pixel divided by `best_fixed_m3`'s (target ≥ 10).
    pub m3_fixed_speedup_over_f32: Option<f64>,
    /// The same ratio on the M4F (hardware f32).
    pub m4f_fixed_speedup_over_f32: Option<f64>,
    /// The same ratio on the M3 for the cheapest fixed-point variant
    /// whatever its error.
    pub m3_fastest_fixed_speedup_over_f32: Option<f64>,
}

impl Row {
    /// A row with the metrics `m` of `variant` against the reference (`None`:
    /// the reference itself, exact by definition); device figures are filled
    /// in after the firmware runs.
    pub(super) fn new(
        variant: String,
        scalar: &str,
        scene: &str,
        m: Option<&Metrics>,
        host_ns: f64,
        table_bytes: usize,
    ) -> Row {
        Row {
            variant,
            scalar: scalar.into(),
            scene: scene.into(),
            max_geom_err_px: m.map_or(0.0, |m| m.max_geom_err_px),
            rms_geom_err_px: m.map_or(0.0, |m| m.rms_geom_err_px),
            max_abs_lsb: m.map_or(0, |m| m.max_abs_lsb),
            rms_lsb: m.map_or(0.0, |m| m.rms_lsb),
            psnr_db: m.and_then(|m| m.psnr_db),
            max_abs_lsb_smooth: m.map_or(0, |m| m.max_abs_lsb_smooth),
            rms_lsb_smooth: m.map_or(0.0, |m| m.rms_lsb_smooth),
            psnr_db_smooth: m.and_then(|m| m.psnr_db_smooth),
            exact_fraction: m.map_or(1.0, |m| m.exact_fraction),
            edge_pixels_differing: m.map_or(0, |m| m.edge_pixels_differing),
            samples: m.map_or(1, |m| m.plan.samples),
            sampling_rms_dn: m.and_then(|m| m.sampling_error.map(|s| s.rms_dn)),
            instructions_per_pixel_m3: None,
            instructions_per_pixel_m4f: None,
            bit_exact_m3: None,
            bit_exact_m4f: None,
            host_ns_per_pixel: host_ns,
            table_bytes,
            flash_bytes_m3: None,
            flash_bytes_m4f: None,
        }
    }

    pub(super) fn is_fixed_point(&self) -> bool {
        self.scalar != "f32" && self.scalar != "f64"
    }
}

/// The cheapest variant (by `cost` on the first sweep scene) whose smooth
/// pixels are within 1 LSB of the reference on every sweep scene (any
/// variant with `any_error`).
pub(super) fn cheapest(
    rows: &[Row],
    scenes: &[Resolved],
    cost: impl Fn(&Row) -> Option<f64>,
    any_error: bool,
) -> Option<String> {
    let mut names: Vec<&str> = rows.iter().map(|r| r.variant.as_str()).collect();
    names.dedup();
    let first = scenes.first().map(|r| r.desc.name.as_str())?;
    names
        .into_iter()
        .filter(|n| *n != "f64-reference")
        .filter(|n| {
            rows.iter()
                .filter(|r| r.variant == *n)
                .all(|r| any_error || r.max_abs_lsb_smooth <= 1)
        })
        .filter_map(|n| {
            let row = rows.iter().find(|r| r.variant == n && r.scene == first)?;
            cost(row).map(|c| (n, c))
        })
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(n, _)| n.to_string())
}

/// The recommendations, given the cheapest fixed-point variant on the M3
/// within 1 LSB (`best_fixed`) and of all (`fastest_fixed`).
pub(super) fn recommend(
    rows: &[Row],
    scenes: &[Resolved],
    best_fixed: Option<&str>,
    fastest_fixed: Option<&str>,
) -> Vec<Recommendation> {
    let first = scenes.first().map(|s| s.desc.name.as_str()).unwrap_or("");
    let row = |name: &str| rows.iter().find(|r| r.variant == name && r.scene == first);
    let fmt = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.0}"));
    let mut out = Vec::new();
    let fixed_note = format!(
        "the cheapest fixed-point variant within 1 LSB is {} ({} instructions/pixel); the cheapest fixed-point \
         variant of all is {} ({} instructions/pixel, max {} LSB on smooth pixels)",
        best_fixed.unwrap_or("-"),
        fmt(best_fixed.and_then(row).and_then(|r| r.instructions_per_pixel_m3)),
        fastest_fixed.unwrap_or("-"),
        fmt(fastest_fixed.and_then(row).and_then(|r| r.instructions_per_pixel_m3)),
        fastest_fixed
            .map(|n| rows.iter().filter(|r| r.variant == n).map(|r| r.max_abs_lsb_smooth).max().unwrap_or(0))
            .unwrap_or(0),
    );
    if let Some(v) = cheapest(rows, scenes, |r| r.instructions_per_pixel_m3, false) {
        out.push(Recommendation {
            target: "M3".into(),
            reason: format!(
                "fewest M3 instructions per pixel ({}) of all variants within 1 LSB on smooth pixels on every sweep \
                 scene; {fixed_note}",
                fmt(row(&v).and_then(|r| r.instructions_per_pixel_m3))
            ),
            variant: v.clone(),
        });
        out.push(Recommendation {
            target: "M0".into(),
            reason: "the sweep does not run on the M0 (`host-sim hil --board microbit` measures the planned \
                     renderer there): the M3's choice, since the M0 has no FPU either; without a \
                     32 × 32 → 64-bit multiply each fixed-point product takes four 16 × 16 ones there, and \
                     soft-float costs it more as well"
                .into(),
            variant: v,
        });
    }
    if let Some(v) = cheapest(rows, scenes, |r| r.instructions_per_pixel_m4f, false) {
        let m4f = |n: &str| row(n).and_then(|r| r.instructions_per_pixel_m4f);
        let f32_best = cheapest(
            &rows
                .iter()
                .filter(|r| r.scalar == "f32")
                .cloned()
                .collect::<Vec<_>>(),
            scenes,
            |r| r.instructions_per_pixel_m4f,
            false,
        );
        let verdict = if row(&v).is_some_and(|r| r.scalar == "f32") {
            "hardware f32 wins there".to_string()
        } else {
            format!(
                "fixed point beats the FPU there: the best f32 variant, {}, needs {}",
                f32_best.as_deref().unwrap_or("-"),
                fmt(f32_best.as_deref().and_then(m4f))
            )
        };
        out.push(Recommendation {
            target: "M4F".into(),
            reason: format!(
                "fewest M4F instructions per pixel ({}) of all variants within 1 LSB on smooth pixels on every \
                 sweep scene; {verdict}",
                fmt(m4f(&v))
            ),
            variant: v,
        });
    }
    let host_fast = cheapest(rows, scenes, |r| Some(r.host_ns_per_pixel), false);
    let planned_ns = row(&Variant::PLANNED.name()).map(|r| r.host_ns_per_pixel);
    out.push(Recommendation {
        target: "host".into(),
        variant: Variant::PLANNED.name(),
        reason: format!(
            "the default: the planner's choice ({} ns/pixel on one core here; `host-sim render` renders lines on \
             every core), whose error it predicts and bounds (1/256 px, 1 LSB) and which the firmware renders \
             byte for byte; the fastest variant within 1 LSB on the sweep scenes is {} ({} ns/pixel)",
            fmt(planned_ns),
            host_fast.as_deref().unwrap_or("-"),
            fmt(host_fast.as_deref().and_then(row).map(|r| r.host_ns_per_pixel)),
        ),
    });
    out
}

fn opt(v: Option<f64>, prec: usize) -> String {
    v.map_or("-".into(), |v| format!("{v:.prec$}"))
}

/// `tradeoff.md`.
pub fn markdown(r: &Report) -> String {
    let mut s = String::new();
    s.push_str(
        "| scene | variant | max geom px | rms geom px | max LSB | max LSB smooth | rms LSB | PSNR dB | PSNR smooth dB | exact | edge differing | samples | sampling err rms DN | M3 instr/px | M4F instr/px | bit-exact M3/M4F | host ns/px | table B | flash M3 B |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    let psnr = |p: Option<f64>| p.map_or("identical".into(), |p| format!("{p:.1}"));
    let be = |b: Option<bool>| b.map_or("-".into(), |b| if b { "yes".into() } else { "NO".to_string() });
    for v in &r.variants {
        s.push_str(&format!(
            "| {} | {} | {:.2e} | {:.2e} | {} | {} | {:.3} | {} | {} | {:.4} | {} | {}x{} | {} | {} | {} | {}/{} | {:.0} | {} | {} |\n",
            v.scene,
            v.variant,
            v.max_geom_err_px,
            v.rms_geom_err_px,
            v.max_abs_lsb,
            v.max_abs_lsb_smooth,
            v.rms_lsb,
            psnr(v.psnr_db),
            psnr(v.psnr_db_smooth),
            v.exact_fraction,
            v.edge_pixels_differing,
            v.samples,
            v.samples,
            opt(v.sampling_rms_dn, 3),
            opt(v.instructions_per_pixel_m3, 0),
            opt(v.instructions_per_pixel_m4f, 0),
            be(v.bit_exact_m3),
            be(v.bit_exact_m4f),
            v.host_ns_per_pixel,
            v.table_bytes,
            v.flash_bytes_m3.map_or("-".into(), |f| f.to_string()),
        ));
    }
    s.push_str(&format!(
        "\nCheapest f32 variant's instructions per pixel / {}'s (the cheapest fixed-point variant within 1 LSB on \
         smooth pixels): M3 (soft-float) {}, M4F (hardware f32) {}. The same on the M3 for the cheapest fixed-point \
         variant whatever its error: {}.\n",
        r.best_fixed_m3.as_deref().unwrap_or("-"),
        opt(r.m3_fixed_speedup_over_f32, 2),
        opt(r.m4f_fixed_speedup_over_f32, 2),
        opt(r.m3_fastest_fixed_speedup_over_f32, 2)
    ));
    for g in &r.growth {
        s.push_str(&format!(
            "\n**Growth, {}** (least-squares slopes): {} instructions per extra pixel on the M3, {} on the M4F; {} \
             per extra primitive per 160x120 frame on the M3 ({} per pixel), {} on the M4F\n\n| scene | pixels | \
             primitives | M3 instructions | M4F instructions |\n|---|---|---|---|---|\n",
            g.variant,
            opt(g.per_pixel_slope_m3, 0),
            opt(g.per_pixel_slope_m4f, 0),
            opt(g.per_primitive_slope_m3, 0),
            opt(g.per_primitive_slope_m3.map(|v| v / 19200.0), 0),
            opt(g.per_primitive_slope_m4f, 0)
        ));
        for p in g.resolution.iter().chain(&g.primitives) {
            s.push_str(&format!(
                "| {} | {} | {} | {} | {} |\n",
                p.scene,
                p.pixels,
                p.primitives,
                p.instructions_m3.map_or("-".into(), |v| v.to_string()),
                p.instructions_m4f.map_or("-".into(), |v| v.to_string())
            ));
        }
    }
    if !r.pruning.is_empty() {
        s.push_str(
            "\n**Pruning** (planned vs planned-all-stages: the same arithmetic, nothing pruned)\n\n| scene | dropped by the planner | M3 planned | M3 all stages | M4F planned | M4F all stages | host ns planned | host ns all | max LSB between |\n|---|---|---|---|---|---|---|---|---|\n",
        );
        for p in &r.pruning {
            s.push_str(&format!(
                "| {} | {} | {} | {} | {} | {} | {:.0} | {:.0} | {} |\n",
                p.scene,
                if p.dropped.is_empty() {
                    "nothing".into()
                } else {
                    p.dropped.join(", ")
                },
                opt(p.planned_m3, 0),
                opt(p.all_stages_m3, 0),
                opt(p.planned_m4f, 0),
                opt(p.all_stages_m4f, 0),
                p.planned_host_ns,
                p.all_stages_host_ns,
                p.max_abs_lsb_between
            ));
        }
    }
    s.push_str("\n**Recommendations**\n\n");
    for rec in &r.recommendations {
        s.push_str(&format!("- {}: `{}` — {}\n", rec.target, rec.variant, rec.reason));
    }
    s
}
