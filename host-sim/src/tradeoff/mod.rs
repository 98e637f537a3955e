//! `host-sim tradeoff`: measures the speed/accuracy trade of the rendering
//! variants ([`crate::variant`]).
//!
//! For every variant and sweep scene: fidelity against the f64 reference
//! (the render metrics), instructions per pixel on the Cortex-M3 and M4F
//! under QEMU `-icount` (firmware built with those variants; each frame is
//! also checked byte for byte against the host render of the same variant),
//! host ns per pixel (median of repeated build + render), table bytes and the
//! firmware's flash. Then growth with resolution and primitive count, and
//! what the planner's pruning saves on every shipped scene. Writes
//! `tradeoff.json`, `tradeoff.md` and `tradeoff.png`.
//!
//! [`sweep`] runs the measurements and writes the files; [`report`] holds
//! the figures (the JSON's types), the recommendations and the markdown;
//! [`plot`] draws them. Report depends on nothing here, plot on report,
//! sweep on both.

pub mod plot;
pub mod report;
pub mod sweep;

pub use sweep::{run, Config};
