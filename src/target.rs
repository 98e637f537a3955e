//! The build variants, in one place. The target and the features choose
//! between forms of the same computation (the same bytes out); nothing
//! else in the core tests the target.
//!
//! - `cfg(hilcam_m0)` (set by `build.rs`): the Cortex-M0 (ARMv6-M). It
//!   has only a 32 × 32 → 32 multiply: the compiler's 64-bit products
//!   there are 64 × 64 library calls, which the fast path and the noise
//!   generator replace with 16 × 16-bit products, and a few helpers are
//!   kept out of line where a copy per caller costs more flash than the
//!   call costs time.
//! - `cfg(hilcam_loops_out_of_line)` (set by `build.rs`): every target but
//!   the x86-64 host keeps each per-pixel loop out of line, one copy; the
//!   host inlines them into its entry points (and their x86-64-v3 and v4
//!   builds).
//! - `feature = "compact"`: small code over speed where the two part (the
//!   driven camera's build, bound by flash): one copy of each fast line
//!   loop for one and three channels, hash words kept as loops.

/// The Cortex-M0 (`cfg(hilcam_m0)`).
pub(crate) const M0: bool = cfg!(hilcam_m0);

/// Small code over speed (`feature = "compact"`).
#[cfg_attr(not(feature = "mix32"), allow(dead_code))]
pub(crate) const COMPACT: bool = cfg!(feature = "compact");

/// The M0's driven camera (a `compact` build for ARMv6-M, at opt-level
/// "z"): where its flash, not speed, decides a form (the rays' y-range,
/// the inner region's pass, `copy3!`, the exposure's channels).
#[cfg_attr(not(feature = "mix32"), allow(dead_code))]
pub(crate) const M0_COMPACT: bool = M0 && COMPACT;
