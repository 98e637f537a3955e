//! The fast arithmetic's pixel-area sampling (camera-model.md §7): the
//! sampled line loop (`line_s`) over rows of rays (`trace_row`) — the
//! adaptive rule's corners and what each sees (`key`), the centres, and
//! the `n×n` grid of each pixel that needs it (`grid`).

use super::arith::{copy3, wmul};
use super::expose::{chunks, noisy_dn, put, vignette_q, word};
use super::intersect::{MixPrim, MixShape};
use super::rays::{Key, Ray, Rays, AWAY, CHUNK, KEEP_C4_SAMPLED, NO_HIT};
use super::shade::KCache;
use super::{chans, Mix32};
use crate::render::sensor::sampling::Corners;
use crate::render::{Lines, FLAG_OUTSIDE_FIELD};
use crate::scene::Q;

impl Mix32 {
    /// [`Mix32::line_s`] with the corner carry if `L` builds it in (one
    /// copy of the loop either way: the other branch is not compiled).
    #[inline(always)]
    pub(super) fn sampled<L: Lines, const C: usize, const PERSP: bool>(
        &self,
        j: u16,
        pixels: &mut [u8],
        flags: &mut [u8],
        corners: &mut Corners,
    ) {
        if L::CARRY_CORNERS {
            self.line_s::<L, C, PERSP, true>(j, pixels, flags, corners)
        } else {
            self.line_s::<L, C, PERSP, false>(j, pixels, flags, corners)
        }
    }

    /// The rays ([`Mix32::rays`]) and passes ([`Mix32::passes`]) of a row: ray `q` at `x̂_d = x − q·step` (S58)
    /// and `(ŷ_d, ŷ_d²)` (S26, S52). Out of line: one copy serves every row
    /// of rays of the sampled loop (pixel centres, corners, grid rows).
    #[cfg_attr(hilcam_loops_out_of_line, inline(never))]
    #[cfg_attr(not(hilcam_loops_out_of_line), inline(always))]
    fn trace_row<const PERSP: bool>(
        &self,
        rays: &mut [Ray],
        x: i64,
        step: i64,
        (yd, yd2): (i32, i64),
        (keep_c4, ra): (bool, bool),
    ) {
        let mut acc = x;
        let xd = || {
            let xd = (acc >> 32) as i32;
            acc -= step;
            xd
        };
        let (ys, outside) = self.rays::<PERSP>(rays, xd, (yd, yd2), (keep_c4, ra));
        let _ = self.passes::<PERSP, false>(rays, ys, outside, None);
    }

    /// [`Mix32::radiance`] out of line: one copy of the shading serves the
    /// sampled loop's centres (whose [`Key`] is known: a checker's cell is
    /// not found twice) and grids.
    #[cfg_attr(hilcam_loops_out_of_line, inline(never))]
    #[cfg_attr(not(hilcam_loops_out_of_line), inline(always))]
    fn radiance_s<L: Lines, const C: usize, const PERSP: bool>(
        &self,
        r: &Ray,
        k: &mut KCache,
        key: Option<Key>,
    ) -> ([u64; 3], u32) {
        self.radiance::<L, C, PERSP, KEEP_C4_SAMPLED>(r, k, key)
    }

    /// What a traced ray sees, for the adaptive rule: the primitive and its
    /// texture cell, [`Key::NOTHING`], or [`Key::OUTSIDE`].
    #[inline(always)]
    fn key<const PERSP: bool>(&self, r: &Ray) -> Key {
        if r.t == 0 {
            return Key::OUTSIDE;
        }
        if r.t == NO_HIT {
            return Key::NOTHING;
        }
        let prim = r.hit & !AWAY;
        let cell = match self.prims.get(prim as usize) {
            Some(MixPrim {
                checker: Some(k),
                shape,
                ..
            }) => k.cells_of::<PERSP>(r, shape.bounded()),
            _ => (0, 0),
        };
        let key = Key::new(cell.0, cell.1, prim, 0);
        // (Without a shadow test in the frame, no call and no lights' bits.)
        if self.any_shadow_test() {
            key.shaded(self.shade_key::<PERSP>(r))
        } else {
            key
        }
    }

    /// [`Mix32::line_f`] with pixel-area sampling (camera-model.md §7,
    /// [`crate::render::sensor::sampling`]): a pixel is the mean of its `n×n` grid, or with
    /// the adaptive rule its centre sample where its four corners and centre
    /// see the same. Per chunk: the corners' keys (top, then bottom), the
    /// centres, then the grids of the pixels that need one, each in the
    /// chunk's passes. A grid's mean is exact (`n²` is a power of two), then
    /// rounded once.
    #[cfg_attr(hilcam_loops_out_of_line, inline(never))]
    #[cfg_attr(not(hilcam_loops_out_of_line), inline(always))]
    fn line_s<L: Lines, const C: usize, const PERSP: bool, const CARRY: bool>(
        &self,
        j: u16,
        pixels: &mut [u8],
        flags: &mut [u8],
        carry: &mut Corners,
    ) {
        let w = self.width as usize;
        let b = self.format.bytes_per_pixel();
        let (Some(pixels), Some(flags)) = (pixels.get_mut(..w * b), flags.get_mut(..w)) else {
            return;
        };
        let n = self.samples;
        let nch = self.nch();
        let log_n = crate::render::sensor::sampling::log2(n);
        let yc = self.y0 - self.dy * j as i128;
        let yd_of = |y: i128| -> (i32, i64) {
            let yd = (y >> 38) as i32;
            (yd, wmul(yd, yd))
        };
        // Half a pixel step (the corners), rounded toward −∞ (the top
        // corners a full step above the bottom ones, so that a line's bottom
        // corners are the next line's top corners exactly).
        let hx = self.dx >> 1;
        let (top, bottom) = (yd_of(yc + (self.dy - (self.dy >> 1))), yd_of(yc - (self.dy >> 1)));
        // The top corners' keys carried from line j − 1, and where this
        // line's bottom ones go (column c: the corner left of pixel c).
        let (carried, keys) = if CARRY && self.adaptive {
            carry.for_line(j, w)
        } else {
            (false, None)
        };
        let stored = keys.is_some();
        // The corners' rays are not shaded: on the M0, their `1/a` only
        // where a sphere's pass reads it ([`fill_rays`]).
        let ra = !crate::target::M0
            || self
                .prims
                .iter()
                .any(|p| matches!(p.shape, MixShape::Sphere { .. }));
        // Column 0's key, and the chunks' right columns (as many as pixels,
        // chunked as they are).
        let (key0, mut key_chunks) = match keys {
            Some([k0, rest @ ..]) => (Some(k0), Some(rest.chunks_mut(CHUNK))),
            _ => (None, None),
        };
        let mut k = KCache::EMPTY;
        let dn_max = [0, 1, 2].map(|c| self.format.dn_max(c) as u64);
        let noise = self.noise.as_ref();
        // Its own (the carried ones cost calibration-board 8 M3
        // instructions a pixel more: registers).
        let mut rays = Rays::default();
        let mut words = [0u16; CHUNK];
        // Per pixel of the chunk, the key its right corners share (adaptive
        // rule), then the key all four share ([`Key::OUTSIDE`]: none).
        let mut corners = [Key::OUTSIDE; CHUNK];
        // The key the left corners of the chunk's first pixel share.
        let mut left = Key::OUTSIDE;
        if self.adaptive {
            if let Some(r) = rays.first(1) {
                let t = match (carried, key0.as_deref()) {
                    (true, Some(k)) => Key(*k),
                    _ => {
                        self.trace_row::<PERSP>(r, self.x0 + hx, self.dx, top, (false, ra));
                        r.first().map_or(Key::OUTSIDE, |r| self.key::<PERSP>(r))
                    }
                };
                self.trace_row::<PERSP>(r, self.x0 + hx, self.dx, bottom, (false, ra));
                let b = r.first().map_or(Key::OUTSIDE, |r| self.key::<PERSP>(r));
                if let Some(k) = key0 {
                    *k = b.0;
                }
                left = if t == b { t } else { Key::OUTSIDE };
            }
        }
        let mut x = self.x0;
        let mut index = j as u32 * self.width as u32;
        for (pixels, flags) in chunks(pixels, flags, b) {
            let Some(rays) = rays.first(flags.len()) else {
                return;
            };
            // Pixels that take the grid.
            let mut grid = u32::MAX;
            if self.adaptive {
                // Right corners, top line (carried, or traced) then bottom
                // line (kept for the next line).
                let chunk_keys = key_chunks.as_mut().and_then(Iterator::next);
                // (Carried, the top keys are read where the bottom ones go,
                // below: copied out first, they cost calibration-board 6.5
                // M3 instructions a pixel.)
                let read = carried && chunk_keys.is_some();
                if !read {
                    self.trace_row::<PERSP>(rays, x - hx, self.dx, top, (false, ra));
                    for (c, r) in corners.iter_mut().zip(rays.iter()) {
                        *c = self.key::<PERSP>(r);
                    }
                }
                self.trace_row::<PERSP>(rays, x - hx, self.dx, bottom, (false, ra));
                // (Two loops, not one storing where it has a buffer: a test a
                // ray cost calibration-board 10 M3 instructions a pixel.)
                // A pixel's corners agree if its top and bottom right ones
                // do (`b`, the bottom one) and so do its left ones (`left`,
                // the column before's right ones, in the same pass).
                let agree = |c: &mut Key, b: Key, left: &mut Key| {
                    let right = if *c == b { b } else { Key::OUTSIDE };
                    *c = if *left == right { right } else { Key::OUTSIDE };
                    *left = right;
                };
                match chunk_keys {
                    Some(k) => {
                        for ((c, r), k) in corners.iter_mut().zip(rays.iter()).zip(k.iter_mut()) {
                            let b = self.key::<PERSP>(r);
                            if read {
                                *c = Key(*k);
                            }
                            *k = b.0;
                            agree(c, b, &mut left);
                        }
                    }
                    None => {
                        for (c, r) in corners.iter_mut().zip(rays.iter()) {
                            agree(c, self.key::<PERSP>(r), &mut left);
                        }
                    }
                }
                // Centres: their own sample where the corners agree with it.
                grid &= self.centre_words::<L, C, PERSP>(
                    (rays, &corners),
                    (x, yd_of(yc)),
                    (&mut words, flags),
                    (noise, index, nch, dn_max),
                    &mut k,
                );
            }
            self.grid_words::<L, C, PERSP>(
                (rays, grid),
                (x, yc, n, log_n),
                (&mut words, flags),
                (noise, index, nch, dn_max),
                &mut k,
            );
            put(&words, false, b, pixels);
            x -= self.dx * rays.len() as i64;
            index = index.wrapping_add(rays.len() as u32);
        }
        if stored {
            carry.carried(j);
        }
    }

    /// [`Mix32::line_s`]'s centres (the chunk's rays traced at `x`, row
    /// `yd`): a pixel whose corners agree (`corners`, [`Key::OUTSIDE`]
    /// where they do not) and whose centre sees what they see is one
    /// sample, its word and flag written; the others' bits are left set in
    /// the mask returned (they take the grid).
    #[inline(always)]
    fn centre_words<L: Lines, const C: usize, const PERSP: bool>(
        &self,
        (rays, corners): (&mut [Ray], &[Key; CHUNK]),
        (x, yd): (i64, (i32, i64)),
        (words, flags): (&mut [u16; CHUNK], &mut [u8]),
        (noise, index, nch, dn_max): (
            Option<&crate::render::sensor::noise::Stage<Q>>,
            u32,
            usize,
            [u64; 3],
        ),
        k: &mut KCache,
    ) -> u32 {
        let mut grid = u32::MAX;
        self.trace_row::<PERSP>(
            rays,
            x,
            self.dx,
            yd,
            (KEEP_C4_SAMPLED || self.area.is_some(), true),
        );
        for (q, ((r, c), (out, flag))) in rays
            .iter()
            .zip(corners)
            .zip(words.iter_mut().zip(flags.iter_mut()))
            .enumerate()
        {
            if *c != Key::OUTSIDE && *c == self.key::<PERSP>(r) {
                // In the field: its corners are.
                let (sum, c4) = self.radiance_s::<L, C, PERSP>(r, k, Some(*c));
                *out = Self::dn_word::<C>(
                    nch,
                    copy3!(sum),
                    c4,
                    copy3!(dn_max),
                    (noise, index.wrapping_add(q as u32)),
                );
                *flag = 0;
                grid &= !(1 << q);
            }
        }
        grid
    }

    /// [`Mix32::line_s`]'s pixels whose corners disagree (a bit each in
    /// `grid`): each the mean of its `n×n` grid ([`Mix32::grid`]; `rays`
    /// scratch) at `x̂_d = x − q dx`, as words with their flags.
    #[inline(always)]
    fn grid_words<L: Lines, const C: usize, const PERSP: bool>(
        &self,
        (rays, grid): (&mut [Ray], u32),
        (x, yc, n, log_n): (i64, i128, u8, u32),
        (words, flags): (&mut [u16; CHUNK], &mut [u8]),
        (noise, index, nch, dn_max): (
            Option<&crate::render::sensor::noise::Stage<Q>>,
            u32,
            usize,
            [u64; 3],
        ),
        k: &mut KCache,
    ) {
        for q in 0..rays.len() {
            if grid & (1 << q) == 0 {
                continue;
            }
            let (Some(out), Some(flag)) = (words.get_mut(q), flags.get_mut(q)) else {
                break;
            };
            let value = self.grid::<L, C, PERSP>(rays, x - self.dx * q as i64, yc, n, log_n, k);
            let (dn, f) = match value {
                Some(v) => {
                    let mut dn = [0u32; 3];
                    for (c, ((d, v), max)) in dn
                        .iter_mut()
                        .zip(v)
                        .zip(copy3!(dn_max))
                        .take(chans::<C>(nch))
                        .enumerate()
                    {
                        *d = match noise {
                            Some(z) => noisy_dn(z.draw(index.wrapping_add(q as u32), c), v, max as u16),
                            None => crate::render::vignetting::round_dn(v, max as u32),
                        };
                    }
                    (dn, 0)
                }
                None => ([0; 3], FLAG_OUTSIDE_FIELD),
            };
            *out = word::<C>(nch, dn);
            *flag = f;
        }
    }

    /// The mean of the `n×n` grid (camera-model.md §7) of the pixel centred
    /// at `(x̂_d, ŷ_d)` (S58, I64F64 raw) per channel, before rounding
    /// (I32F32 DN, exact: a power-of-two mean of exact values, saturated);
    /// `None` if a sample lies beyond the fold. `rays` is scratch.
    #[cfg_attr(hilcam_loops_out_of_line, inline(never))]
    #[cfg_attr(not(hilcam_loops_out_of_line), inline(always))]
    fn grid<L: Lines, const C: usize, const PERSP: bool>(
        &self,
        rays: &mut [Ray],
        xc: i64,
        yc: i128,
        n: u8,
        log_n: u32,
        k: &mut KCache,
    ) -> Option<[Q; 3]> {
        let n = n as usize;
        // Sample a at (i + s_a), s_a = (2a + 1 − n)/(2n): the step times
        // (2a + 1 − n), shifted right by log2 n + 1 (toward −∞).
        let off_x = |a: usize| (self.dx * (2 * a as i64 + 1 - n as i64)) >> (log_n + 1);
        let off_y = |b: usize| (self.dy * (2 * b as i128 + 1 - n as i128)) >> (log_n + 1);
        let mut acc = [0i64; 3];
        // A row of samples at a time; pixel coordinates grow as x̂_d, ŷ_d
        // fall, and the samples' x̂_d are a row's step apart.
        let row = rays.get_mut(..n)?;
        // Sample a at xc − off_x(0) − a ⌊dx/n⌋: within n·2⁻⁵⁸ of the
        // pattern's xc − off_x(a), far below the slopes' 2⁻²⁶.
        let step = self.dx >> log_n;
        for b in 0..n {
            let yd = ((yc - off_y(b)) >> 38) as i32;
            self.trace_row::<PERSP>(
                row,
                xc - off_x(0),
                step,
                (yd, wmul(yd, yd)),
                (KEEP_C4_SAMPLED || self.area.is_some(), true),
            );
            for r in row.iter() {
                if r.t == 0 {
                    return None;
                }
                let (sum, c4) = self.radiance_s::<L, C, PERSP>(r, k, None);
                for (a, s) in acc.iter_mut().zip(copy3!(sum)).take(self.chans::<C>()) {
                    *a = a.saturating_add(vignette_q(s, c4).to_bits());
                }
            }
        }
        Some(acc.map(|a| Q::from_bits(a >> (2 * log_n))))
    }
}
