//! Pixel-area integration (camera-model.md §7): the sample pattern and the
//! planner's rule for its size.
//!
//! A pixel `(i, j)` covers `[i − ½, i + ½] × [j − ½, j + ½]` (pixel
//! coordinates). Its samples are an `n×n` stratified grid, the cell centres:
//! sample `(a, b)` at `(i + s_a, j + s_b)`, `s_a = (2a + 1 − n) / (2n)`,
//! `a, b = 0 … n − 1`, `n` ∈ {1, 2, 4, 8, 16} (n = 1: the centre alone).
//! The pixel's irradiance is the samples' mean. An `n×n` grid places a
//! straight edge within `1/(2n)` px (the worst case is an edge parallel to
//! the grid's rows: each row counts its samples on either side).
//!
//! **Adaptive rule** (when the scene asks for it): the renderer first looks
//! at the pixel's four corners `(i ± ½, j ± ½)` and its centre. If all five
//! are in the lens field and see the same primitive (or all see nothing)
//! and, on a textured primitive, the same texture cell, the pixel's value is
//! its centre sample; otherwise it is the grid's mean. Content that fits
//! between a pixel's corners without touching them is missed by the test
//! (docs/sensor.md). A pixel any of whose samples lies beyond the lens
//! field's fold is flagged outside the field and valued 0, as a centre
//! sample beyond it is.

/// The largest grid side.
pub(crate) const MAX_GRID: u8 = 16;

/// The smallest grid side `n` ∈ {1, 2, 4, 8, 16} whose edge-placement error
/// `1/(2n)` is within `edge_error_px` (16 if none is).
pub fn grid_for(edge_error_px: f64) -> u8 {
    let mut n = 1u8;
    while n < MAX_GRID && edge_error(n) > edge_error_px {
        n *= 2;
    }
    n
}

/// The grid's spread error: the disc diameter fitted to an edge blurred
/// over `b` px and integrated over each pixel by an `n×n` grid (the disc's
/// edge-spread function averaged over the pixel square as the model) is
/// off by up to `GRID_SPREAD / (n b)²` — measured by host-sim's
/// `defocus::area_integrated_edges_spread_over_the_blur_circle`: 4×4 at
/// 0.5 px −14.5 %, at 1 px −3.6 %; 8×8 at 0.5 px −3.6 %, at 1 px −0.75 %;
/// 16×16 at 0.5 px −0.8 %.
pub const GRID_SPREAD: f64 = 0.58;

/// The smallest grid side `n` ∈ {1, 2, 4, 8, 16} whose spread error
/// ([`GRID_SPREAD`]) at a blur of `blur_px` is within `budget` (16 if
/// none is): through the aperture, what the planner raises the edge
/// budget's grid to. Out of line, as the planner that calls it.
#[inline(never)]
pub fn grid_for_blur(blur_px: f64, budget: f64) -> u8 {
    let mut n = 1u8;
    while n < MAX_GRID && GRID_SPREAD > budget * (f64::from(n) * blur_px) * (f64::from(n) * blur_px) {
        n *= 2;
    }
    n
}

/// The edge-placement error of an `n×n` grid, pixels: `1/(2n)` (½ for the
/// centre alone).
pub fn edge_error(n: u8) -> f64 {
    0.5 / f64::from(n.max(1))
}

/// `step · s_a` for `a = 0 … n − 1` (entries beyond `n` are 0), in the
/// caller's fixed-point units (`step` is the pixel step, I64F64 raw):
/// `step (2a + 1 − n)` shifted right by `log2 n + 1` (rounded toward −∞,
/// the same on every target; saturating).
#[inline(never)]
#[cfg_attr(not(feature = "sensor"), allow(dead_code))]
pub(crate) fn scaled_offsets(step: i128, n: u8) -> [i128; MAX_GRID as usize] {
    let n = n.clamp(1, MAX_GRID);
    let shift = log2(n) + 1;
    let mut out = [0i128; MAX_GRID as usize];
    let mut k = 1 - i128::from(n);
    for o in out.iter_mut().take(n as usize) {
        *o = step.saturating_mul(k) >> shift;
        k += 2;
    }
    out
}

/// The grid side and adaptive flag a scene's `[sampling]` asks for
/// ([`grid_for`] of its edge error; `(1, false)` without it): what the
/// planner puts in its options.
pub fn of_scene(scene: &crate::scene::Scene) -> (u8, bool) {
    match scene.sampling {
        Some(s) => (grid_for(crate::num::to_f64(s.edge_error_px)), s.adaptive),
        None => (1, false),
    }
}

/// `log2 n` of a grid side (0 for 1).
pub(crate) fn log2(n: u8) -> u32 {
    n.max(1).trailing_zeros()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_meets_the_edge_error() {
        assert_eq!(grid_for(0.5), 1);
        assert_eq!(grid_for(0.25), 2);
        assert_eq!(grid_for(0.2), 4);
        assert_eq!(grid_for(0.0625), 8);
        assert_eq!(grid_for(0.01), 16);
        let o = scaled_offsets(1 << 20, 4);
        assert_eq!(&o[..4], &[-(3 << 17), -(1 << 17), 1 << 17, 3 << 17]);
    }

    #[test]
    fn grid_resolves_the_least_blur() {
        // n b at least √(0.58 / 0.02) ≈ 5.4.
        assert_eq!(grid_for_blur(0.5, 0.02), 16);
        assert_eq!(grid_for_blur(1.0, 0.02), 8);
        assert_eq!(grid_for_blur(2.0, 0.02), 4);
        assert_eq!(grid_for_blur(6.0, 0.02), 1);
        assert_eq!(grid_for_blur(0.0, 0.02), 16);
        for b in [0.3, 0.7, 1.3, 2.9, 5.0] {
            let n = f64::from(grid_for_blur(b, 0.02));
            assert!(GRID_SPREAD / (n * b).powi(2) <= 0.02 || n == 16.0, "{b}");
        }
    }
}

/// The adaptive rule's corner keys carried from one line to the next: a
/// line's bottom corners are the next line's top ones, so a caller that
/// renders a frame's lines in order (the firmware) traces each row of
/// corners once instead of twice. It holds a key for each of the `width +
/// 1` corner columns (8 bytes each); a shorter buffer, or a line other than
/// the one after the last, leaves it unused and the line traces both rows.
/// Only the fast arithmetic's sampled loop uses it.
#[derive(Debug)]
#[cfg_attr(not(feature = "mix32"), allow(dead_code))]
pub(crate) struct Corners<'a> {
    /// The keys of the last line's bottom corners, by column.
    keys: &'a mut [u64],
    /// The line whose top corners they are.
    next: Option<u16>,
}

#[cfg_attr(not(feature = "mix32"), allow(dead_code))]
impl<'a> Corners<'a> {
    /// A carry over `keys` for a new frame (nothing carried yet).
    pub fn new(keys: &'a mut [u64]) -> Corners<'a> {
        Corners { keys, next: None }
    }

    /// For line `j` of a frame `width` pixels wide: whether the buffer
    /// holds its top corners (the last line rendered was `j − 1`), and the
    /// buffer, if it is long enough, for its bottom corners. The line marks
    /// them carried ([`Corners::carried`]) once it has written them all.
    #[cfg_attr(not(feature = "mix32"), allow(dead_code))]
    pub(crate) fn for_line(&mut self, j: u16, width: usize) -> (bool, Option<&mut [u64]>) {
        let carried = self.next == Some(j);
        self.next = None;
        match self.keys.get_mut(..width + 1) {
            Some(k) => (carried, Some(k)),
            None => (false, None),
        }
    }

    /// The buffer holds line `j`'s bottom corners.
    #[cfg_attr(not(feature = "mix32"), allow(dead_code))]
    pub(crate) fn carried(&mut self, j: u16) {
        self.next = j.checked_add(1);
    }
}
