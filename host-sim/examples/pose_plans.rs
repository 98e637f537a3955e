//! The planner's choice for each shipped scene at its own pose and at the
//! 40 poses about it whose plans `tests/golden.rs` pins
//! (`host_sim::trajectory::poses_about`, one generator state through the
//! scenes in turn): per scene, how many plans take each arithmetic and ray
//! model, and their mean predicted M3 instructions a pixel; with `-v`,
//! every plan's options.
//!
//! `cargo run --release -p host-sim --example pose_plans [-- -v]`

use hilcam::planner::{plan, Budget};
use host_sim::trajectory::{poses_about, PINNED_POSES, POSES_SEED};
use std::collections::BTreeMap;

fn main() -> Result<(), String> {
    let verbose = std::env::args().any(|a| a == "-v");
    let budget = Budget::default();
    let mut state = POSES_SEED;
    for path in host_sim::qemu::shipped_scenes()? {
        let r = host_sim::scene_file::load(&path)?;
        let scene = r.core_scene()?;
        let pose = host_sim::drive_cmd::scene_pose(&r)?;
        let mut plans = vec![plan(&scene, &budget)];
        for (k, p) in poses_about(&pose, PINNED_POSES, &mut state).iter().enumerate() {
            let mut at = scene.clone();
            hilcam::geom::extrinsics::Extrinsics::from_matrix(p.rotation, p.translation)
                .map_err(|e| format!("{}: pose {k}: {e:?}", r.desc.name))
                .and_then(|e| {
                    at.set_pose(e)
                        .map_err(|e| format!("{}: pose {k}: {e:?}", r.desc.name))
                })?;
            plans.push(plan(&at, &budget));
        }
        let mut kinds: BTreeMap<String, usize> = BTreeMap::new();
        for (k, p) in plans.iter().enumerate() {
            let kind = format!("{:?} {:?}", p.options.arithmetic, p.options.model);
            *kinds.entry(kind).or_default() += 1;
            if verbose {
                println!(
                    "{} {} {:?} {:.1}",
                    r.desc.name,
                    k as i64 - 1,
                    p.options,
                    p.predicted_m3_instructions_per_pixel
                );
            }
        }
        let mean = plans
            .iter()
            .map(|p| p.predicted_m3_instructions_per_pixel)
            .sum::<f64>()
            / plans.len() as f64;
        println!(
            "{:<20} {} plans, {:?}, mean predicted {:.1} M3 instructions/pixel",
            r.desc.name,
            plans.len(),
            kinds,
            mean
        );
    }
    Ok(())
}
