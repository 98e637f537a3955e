//! What interpolating a sphere's shading along a row would err, measured on
//! the f64 reference: for each odd pixel whose row runs on the same sphere
//! at least `MARGIN` pixels either side, and whose pixels `i − 3 … i + 3`
//! are lit by the same lights (`n̂·l̂ > 0`), the error of the mean of its
//! two neighbours and of the 4-tap cubic at the midpoint, `(9 (v₋₁ + v₊₁)
//! − v₋₃ − v₊₃) / 16`, against its own value (DN before rounding, every
//! channel), and how many would round differently. A measurement for a
//! possible sphere mean (not rendered anywhere). Perspective scenes (a
//! defocused one's values are the aperture's means, its lit test the
//! chief ray's):
//!
//! `cargo run --release -p host-sim --example sphere_midpoints -- scenes/standard.toml`

use hilcam::scene::data::LightData;
use hilcam::scene::ShapeSpec;
use host_sim::reference::dot;
use host_sim::reference::render::{RefModel, RefScene};
use host_sim::scene_file::load;

const MARGIN: usize = 5;

fn main() -> Result<(), String> {
    let paths: Vec<String> = std::env::args().skip(1).collect();
    if paths.is_empty() {
        return Err("usage: sphere_midpoints SCENE.toml...".into());
    }
    for path in paths {
        let r = load(std::path::Path::new(&path))?;
        let s = RefScene::new(&r);
        // (The hit point below is `z (x̂, ŷ, 1)`: a perspective ray's.)
        if s.model != RefModel::Perspective {
            return Err(format!(
                "{path}: camera.model: only perspective scenes are measured"
            ));
        }
        let (w, h) = (s.sensor.width as usize, s.sensor.height as usize);
        let channels = r.format.channels();
        // Per pixel: the sphere hit (index), the lights that light it (bits)
        // and the values before rounding.
        let mut cell = vec![(None::<usize>, 0u32, [0.0f64; 3]); w * h];
        for j in 0..h {
            for i in 0..w {
                let (x, y) = (i as f64, j as f64);
                let (Some(p), Some(z), Some((xu, yu)), Some(v)) = (
                    s.key(x, y).prim,
                    s.depth(x, y),
                    s.undistorted(x, y),
                    s.sample(x, y),
                ) else {
                    continue;
                };
                let Some(ShapeSpec::Sphere { centre, radius }) = r.primitives.get(p).map(|q| &q.shape) else {
                    continue;
                };
                let q = s.pose().camera_to_world([xu * z, yu * z, z]);
                let n = [0, 1, 2].map(|a| (q[a] - centre[a]) / radius);
                let mut lit = 0u32;
                for (k, l) in r.lights.iter().enumerate() {
                    let to = match l {
                        LightData::Point { position, .. } => [0, 1, 2].map(|a| position[a] - q[a]),
                        LightData::Directional { direction, .. } => *direction,
                    };
                    if dot(n, to) > 0.0 {
                        lit |= 1 << k;
                    }
                }
                cell[j * w + i] = (Some(p), lit, v);
            }
        }
        let sphere_pixels = cell.iter().filter(|c| c.0.is_some()).count();
        let (mut n, mut max2, mut max4, mut round2, mut round4) = (0usize, 0f64, 0f64, 0usize, 0usize);
        for j in 0..h {
            for i in (MARGIN..w.saturating_sub(MARGIN)).filter(|i| i % 2 == 1) {
                let row = &cell[j * w..(j + 1) * w];
                let (p, lit, v) = row[i];
                if p.is_none()
                    || !row[i - MARGIN..=i + MARGIN].iter().all(|c| c.0 == p)
                    || !row[i - 3..=i + 3].iter().all(|c| c.1 == lit)
                {
                    continue;
                }
                n += 1;
                for (c, &own) in v.iter().enumerate().take(channels) {
                    let t = |d: isize| row[(i as isize + d) as usize].2[c];
                    let m2 = (t(-1) + t(1)) / 2.0;
                    let m4 = (9.0 * (t(-1) + t(1)) - t(-3) - t(3)) / 16.0;
                    max2 = max2.max((m2 - own).abs());
                    max4 = max4.max((m4 - own).abs());
                    let rounded = |x: f64| (x + 0.5).floor();
                    round2 += usize::from(rounded(m2) != rounded(own));
                    round4 += usize::from(rounded(m4) != rounded(own));
                }
            }
        }
        println!(
            "{path}: {sphere_pixels} sphere pixels of {}; {n} odd ones interpolable (same sphere ±{MARGIN} px, same lights ±3 px); \
             pair mean max {max2:.4} DN, {round2} values rounded differently; 4-tap cubic max {max4:.4} DN, {round4} rounded differently",
            w * h
        );
    }
    Ok(())
}
