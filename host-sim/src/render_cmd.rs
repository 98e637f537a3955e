//! `host-sim render`: renders a scene with the core and with the f64
//! reference ([`crate::harness`]), compares them, and streams `frame.png`,
//! `reference.png`, `diff.png` and `metrics.json` into the output
//! directory; the plan and the summary as text.

use crate::frame_png::{diff_row, png_row, png_stream};
use crate::harness::{metrics, plan_report, prepare, run_lines, Metrics, PlanReport, StageErrors};
use crate::reference::render::RefScene;
use crate::scene_file::Resolved;
use hilcam::planner::Budget;

/// `host-sim render`: plans (refusing a scene no candidate meets the budget
/// for, unless `allow_over_budget`, before anything is written), then
/// checks that `dir` takes files, renders with both a band of lines at a
/// time and streams `frame.png`, `reference.png`, `diff.png` and
/// `metrics.json` into `dir`, committed together ([`crate::output`]). Memory is O(width), whatever the height.
pub fn render_to(
    dir: &std::path::Path,
    r: &Resolved,
    budget: &Budget,
    allow_over_budget: bool,
) -> Result<Metrics, String> {
    let (scene, plan, frame) = prepare::<hilcam::num::scalar::I32F32>(r, budget, |p| p.options)?;
    if !plan.meets_budget && !allow_over_budget {
        let report = plan_report(&plan, budget, &frame);
        return Err(format!(
            "refused: {}\n{}nothing written (--allow-over-budget renders it anyway)",
            report.why,
            plan_text(&report)
        ));
    }
    let mut out = crate::output::Outputs::prepare(dir)?;
    let rs = RefScene::new(r);
    let (w, h) = frame.size();
    let (w, h) = (w as usize, h as usize);
    let format = scene.format();
    let mut pngs = [
        png_stream(out.create("frame.png")?, w, h, Some(format))?,
        png_stream(out.create("reference.png")?, w, h, Some(format))?,
        png_stream(out.create("diff.png")?, w, h, None)?,
    ];
    let names = ["frame.png", "reference.png", "diff.png"];
    let io = |k: usize, e: &dyn std::fmt::Display| format!("{}: {e}", out.dir().join(names[k]).display());
    let mut row = Vec::new();
    let t = run_lines(&frame, &rs, StageErrors::Measured, &mut |l| {
        use std::io::Write;
        png_row(format, &l.core_dn, &mut row);
        pngs[0].write_all(&row).map_err(|e| io(0, &e))?;
        png_row(format, &l.reference.dn, &mut row);
        pngs[1].write_all(&row).map_err(|e| io(1, &e))?;
        diff_row(format, &l.core_dn, l.reference.row(0), &mut row);
        pngs[2].write_all(&row).map_err(|e| io(2, &e))
    })?;
    for (k, p) in pngs.into_iter().enumerate() {
        p.finish().map_err(|e| io(k, &e))?;
    }
    let m = metrics(r, &plan, budget, &frame, &t, StageErrors::Measured);
    out.write(
        "metrics.json",
        &serde_json::to_vec_pretty(&m).map_err(|e| format!("metrics: {e}"))?,
    )?;
    out.commit()?;
    Ok(m)
}

/// The plan as text: the choice, why, and every candidate.
pub fn plan_text(p: &PlanReport) -> String {
    let mut s = format!("  plan: {} — {}\n", p.chosen, p.why);
    for c in &p.candidates {
        s.push_str(&format!(
            "    {:<18} geom {:.2e} px  {:>9.4} LSB  edges {:>7.4} %  {:>7.0} M3 instr/px  {}\n",
            c.name,
            c.geom_err_px,
            c.lsb,
            100.0 * c.edge_differing,
            c.m3_instructions_per_pixel,
            match (&c.unfit, c.meets_budget) {
                (Some(why), _) => format!("unfit: {why}"),
                (None, true) => "within budget".to_string(),
                (None, false) => "over budget".to_string(),
            }
        ));
    }
    if p.samples > 1 {
        s.push_str(&format!(
            "  sampling: {n}x{n}{} — predicted edge error {:.4} px, {:.2} samples a pixel\n",
            if p.adaptive { " adaptive" } else { " on every pixel" },
            p.predicted_edge_err_px,
            p.predicted_samples_per_pixel,
            n = p.samples
        ));
    }
    if p.predicted_shadow_tests > 0.0 {
        s.push_str(&format!(
            "  shadows: {:.2} tests a sample ({:.3} exact), {:.0} M3 instructions a pixel of the cost (predicted)\n",
            p.predicted_shadow_tests, p.predicted_shadow_exact, p.predicted_shadow_m3
        ));
    }
    if p.samples > 1 || p.aperture_points > 0 {
        s.push_str(&format!(
            "  a pixel's samples cost {:.2}x one sample's (the fitted SampleCost, in the costs above)\n",
            p.predicted_sample_factor
        ));
    }
    if p.aperture_points > 0 {
        s.push_str(&format!(
            "  defocus: {} aperture points — content outside the depth of field, largest blur {:.2} px, \
             predicted placement error {:.3} px\n",
            p.aperture_points, p.blur_px, p.predicted_defocus_err_px
        ));
        if let Some(spared) = p.aperture_spared {
            s.push_str(&format!(
                "  pixels whose aperture rays are not traced (one sum, the chief ray's): {:.1} %\n",
                100.0 * spared
            ));
        }
        if let Some([traced, only]) = p.aperture_shares {
            s.push_str(&format!(
                "  predicted cost's shares: {:.1} % of the pixels traced, {:.1} % tested against one rectangle \
                 (every {}th row and column)\n",
                100.0 * traced,
                100.0 * only,
                hilcam::planner::APERTURE_STRIDE
            ));
        }
    } else {
        s.push_str(&format!(
            "  defocus: none — {}, largest blur {:.3} px left out\n",
            if p.outside_dof {
                "content outside the depth of field, but the camera is not perspective"
            } else {
                "all content within the depth of field"
            },
            p.blur_px
        ));
    }
    s
}

/// A one-line summary.
pub fn summary(m: &Metrics) -> String {
    let psnr = |p: Option<f64>| p.map_or("identical".to_string(), |p| format!("{p:.1} dB"));
    format!(
        "{:<18} {}x{} {:<7} {:<4} model={:<16} lut={:<4} geom={:.2e}px max_lsb={} smooth: max_lsb={} psnr={} \
         exact={:.4} edges={} differing={} ({:.3}%)",
        m.scene,
        m.width,
        m.height,
        m.format,
        m.plan.arithmetic,
        m.plan.model,
        m.plan.lut_entries,
        m.max_geom_err_px,
        m.max_abs_lsb,
        m.max_abs_lsb_smooth,
        psnr(m.psnr_db_smooth),
        m.exact_fraction,
        m.edge_pixels,
        m.edge_pixels_differing,
        100.0 * m.edge_pixels_differing_fraction
    ) + &m.sampling_error.map_or(String::new(), |e| {
        format!(
            "\n{:<18} sampling error vs 16x16: rms={:.3} DN max={:.2} DN ({} pixels took the grid)",
            "", e.rms_dn, e.max_dn, e.grid_pixels
        )
    }) + &m.defocus_error.map_or(String::new(), |e| {
        format!(
            "\n{:<18} defocus error vs {} aperture points: rms={:.3} DN max={:.2} DN",
            "", e.converged_points, e.rms_dn, e.max_dn
        )
    }) + &m.beyond_prediction().map_or(String::new(), |e| {
        format!("\n{:<18} BEYOND THE PLAN'S PREDICTION: {e}", "")
    })
}
