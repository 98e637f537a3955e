//! Reference shadows (camera-model.md §6): a light reaches a point unless
//! a primitive meets the way to it farther than `ε` from the point.

use super::{dot, V3};

/// `ε`, metres (docs/scenes.md, "Shadows").
pub const EPSILON: f64 = 1.0 / 4096.0;

/// Whether a primitive meets the line `p + t d` at `t` in `(ε/|d|,
/// t_max)`, given where each meets it (`meets`: up to two `t` each): the
/// segment to a point light (`d` to it, `t_max = 1`) or the ray towards a
/// directional one (`t_max = ∞`). Every primitive is tested, the point's
/// own as well (`ε` keeps it from shadowing itself).
pub(super) fn blocked(mut meets: impl Iterator<Item = [Option<f64>; 2]>, d: V3, t_max: f64) -> bool {
    let lo = EPSILON / dot(d, d).sqrt();
    meets.any(|ts| ts.into_iter().flatten().any(|t| t > lo && t < t_max))
}
