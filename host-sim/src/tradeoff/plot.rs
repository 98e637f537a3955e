//! `tradeoff.png`: error against cost for every variant on the first sweep
//! scene, with the Pareto front (no other variant is both cheaper and more
//! accurate) joined. Cost is M3 instructions per pixel when the firmware
//! ran, host ns per pixel otherwise.

use super::report::{Report, Row};
use crate::variant::ScalarKind;
use plotters::prelude::*;

/// A colour for every scalar kind (the match is exhaustive: a new kind
/// cannot go unplotted).
fn colour(k: ScalarKind) -> RGBColor {
    match k {
        ScalarKind::Planned => RGBColor(44, 160, 44),
        ScalarKind::I32F32 => RGBColor(31, 119, 180),
        ScalarKind::F32 => RGBColor(214, 39, 40),
        ScalarKind::Mix32 => RGBColor(255, 127, 14),
    }
}

/// Indices of the rows on the Pareto front of (cost, error), by cost.
fn pareto(points: &[(f64, f64)]) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..points.len()).collect();
    idx.sort_by(|a, b| {
        points[*a]
            .0
            .total_cmp(&points[*b].0)
            .then(points[*a].1.total_cmp(&points[*b].1))
    });
    let mut front = Vec::new();
    let mut best = f64::INFINITY;
    for i in idx {
        if points[i].1 < best {
            best = points[i].1;
            front.push(i);
        }
    }
    front
}

fn panel(
    area: &DrawingArea<BitMapBackend<'_>, plotters::coord::Shift>,
    rows: &[&Row],
    cost: &dyn Fn(&Row) -> Option<f64>,
    cost_label: &str,
    err: &dyn Fn(&Row) -> f64,
    err_label: &str,
    floor: f64,
) -> Result<(), String> {
    let pts: Vec<(f64, f64, &Row)> = rows
        .iter()
        .filter_map(|r| cost(r).map(|c| (c, err(r).max(floor), *r)))
        .collect();
    if pts.is_empty() {
        return Ok(());
    }
    let (xmin, xmax) = pts
        .iter()
        .fold((f64::INFINITY, 0f64), |(a, b), p| (a.min(p.0), b.max(p.0)));
    let (ymin, ymax) = pts
        .iter()
        .fold((f64::INFINITY, 0f64), |(a, b), p| (a.min(p.1), b.max(p.1)));
    let e = |x: String| x;
    let mut chart = ChartBuilder::on(area)
        .caption(format!("{err_label} vs {cost_label}"), ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(
            (xmin / 1.5..xmax * 1.5).log_scale(),
            (ymin / 3.0..ymax * 3.0).log_scale(),
        )
        .map_err(|x| e(x.to_string()))?;
    chart
        .configure_mesh()
        .x_desc(cost_label)
        .y_desc(err_label)
        .x_labels(8)
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .x_label_formatter(&|v| format!("{v:.0}"))
        .draw()
        .map_err(|x| e(x.to_string()))?;
    let xy: Vec<(f64, f64)> = pts.iter().map(|p| (p.0, p.1)).collect();
    let front: Vec<(f64, f64)> = pareto(&xy).into_iter().map(|i| xy[i]).collect();
    chart
        .draw_series(LineSeries::new(front, BLACK.stroke_width(1)))
        .map_err(|x| e(x.to_string()))?;
    for k in ScalarKind::ALL {
        let (s, c) = (k.name(), colour(k));
        let mine: Vec<&(f64, f64, &Row)> = pts.iter().filter(|p| p.2.scalar == s).collect();
        if mine.is_empty() {
            continue;
        }
        chart
            .draw_series(mine.iter().map(|p| {
                EmptyElement::at((p.0, p.1))
                    + Circle::new((0, 0), 4, c.filled())
                    + Text::new(
                        p.2.variant
                            .trim_start_matches(s)
                            .trim_start_matches('-')
                            .to_string(),
                        (6, -4),
                        ("sans-serif", 10),
                    )
            }))
            .map_err(|x| e(x.to_string()))?
            .label(s)
            .legend(move |(x, y)| Circle::new((x, y), 4, c.filled()));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::LowerLeft)
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(|x| e(x.to_string()))?;
    Ok(())
}

/// Renders the plot as PNG bytes.
pub fn plot(r: &Report) -> Result<Vec<u8>, String> {
    // The font is registered once per process; a second registration fails
    // harmlessly.
    let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular());
    let scene = r.variants.first().map(|v| v.scene.clone()).unwrap_or_default();
    let rows: Vec<&Row> = r
        .variants
        .iter()
        .filter(|v| v.scene == scene && v.scalar != "f64")
        .collect();
    let on_m3 = rows.iter().any(|r| r.instructions_per_pixel_m3.is_some());
    let cost = move |r: &Row| {
        if on_m3 {
            r.instructions_per_pixel_m3
        } else {
            Some(r.host_ns_per_pixel)
        }
    };
    let label = if on_m3 {
        "M3 instructions/pixel"
    } else {
        "host ns/pixel"
    };
    let (w, h) = (1400u32, 560u32);
    let mut buf = vec![0u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let root = root
            .titled(
                &format!("hilcam speed/accuracy trade, scene {scene}"),
                ("sans-serif", 22),
            )
            .map_err(|e| e.to_string())?;
        let (left, right) = root.split_horizontally(w / 2);
        panel(
            &left,
            &rows,
            &cost,
            label,
            &|r| r.max_geom_err_px,
            "max geometric error, px",
            1e-9,
        )?;
        panel(
            &right,
            &rows,
            &cost,
            label,
            &|r| r.rms_lsb,
            "RMS error, LSB (0 drawn at 1e-4)",
            1e-4,
        )?;
        root.present().map_err(|e| e.to_string())?;
    }
    crate::frame_png::encode_rgb8(w as usize, h as usize, &buf)
}

#[cfg(test)]
mod tests {
    #[test]
    fn pareto_front_keeps_only_undominated_points() {
        let p = [(10.0, 1.0), (5.0, 2.0), (20.0, 0.5), (7.0, 3.0), (30.0, 0.6)];
        assert_eq!(super::pareto(&p), vec![1, 0, 2]);
    }
}
