//! The fast arithmetic's one-sample line loop: a line in chunks of 32
//! rays, each in passes (rays, one pass a primitive, shading), and the
//! per-pixel stages the other loops share.

use super::arith::{
    copy3, cos_over_r3, map3, rsqrt_fine, rsqrt_norm, rsqrt_refine, sar64, sar64_low, sar64_low_lt32, sat32,
    smul_u, wmul, wmul_px, wsq, zip3, SUM_CAP,
};
use super::expose::{noisy, store, vignette_dn, vignette_dn_lo, word};
use super::intersect::{fine_normal, moved_point, MixPrim, MixShape};
#[cfg(target_arch = "x86_64")]
use super::rays::fill_lanes;
use super::rays::{cos4, fill_rays, undistort_k, undistort_kj, ChunkBufs, Key, Ray, AWAY, CHUNK, NO_HIT};
use super::shade::{directional_w, dot30, lobe_pf, KCache};
use super::{chans, each, lobe_built, Carry, Hit, Mix32, MixLight};
use crate::render::{LineLoop, Lines, FLAG_OUTSIDE_FIELD};
use crate::scene::{PixelFormat, Q};
use crate::target::{M0, M0_COMPACT};

impl Mix32 {
    /// Renders line `j`: `pixels` holds `width × bytes_per_pixel` bytes.
    /// Only `L`'s loops are compiled in; a line of another is left as it
    /// is ([`crate::render::Frame::render_with`] refuses such a frame first).
    ///
    /// On x86-64 the loops the Cortex-M builds keep out of line are
    /// inlined here and into [`Mix32::line_v3`] and [`Mix32::line_v4`]:
    /// three copies of them, two built for newer processors.
    #[cfg_attr(not(hilcam_loops_out_of_line), inline(never))]
    pub(crate) fn line<L: Lines>(&self, j: u16, pixels: &mut [u8], flags: &mut [u8], carry: &mut Carry) {
        self.line_any::<L, false>(j, pixels, flags, carry)
    }

    /// [`Mix32::line`] built for x86-64-v3 processors (AVX2, BMI1, BMI2,
    /// FMA, LZCNT, MOVBE, POPCNT): variable shifts and leading-zero counts
    /// are one instruction each there, and perspective rays are made in
    /// vector lanes (`fill_lanes`). The same bytes. (The closed plane's
    /// pixels in lanes too, every ray's terms where the scalar run takes
    /// one in two to eight, measured slower and went: 1080p standard
    /// 55.7–55.8 frames/s against 68.9–69.7 on 2 threads, `host-sim
    /// throughput`.)
    ///
    /// # Safety
    ///
    /// Call only on a processor with those features.
    #[cfg(all(target_arch = "x86_64", feature = "x86-levels"))]
    #[target_feature(enable = "bmi1,bmi2,lzcnt,avx2,fma,movbe,popcnt")]
    pub(crate) fn line_v3<L: Lines>(&self, j: u16, pixels: &mut [u8], flags: &mut [u8], carry: &mut Carry) {
        self.line_any::<L, true>(j, pixels, flags, carry)
    }

    /// [`Mix32::line`] built for x86-64-v4 processors (x86-64-v3's features
    /// and AVX-512 F, CD, VL, BW, DQ): the compiler vectorizes more of the
    /// lanes (`fill_lanes`: the count of leading zeros and the seed
    /// table's gather). The same bytes.
    ///
    /// # Safety
    ///
    /// Call only on a processor with those features.
    #[cfg(all(target_arch = "x86_64", feature = "x86-levels"))]
    #[target_feature(
        enable = "bmi1,bmi2,lzcnt,avx2,fma,movbe,popcnt,avx512f,avx512cd,avx512vl,avx512bw,avx512dq"
    )]
    pub(crate) fn line_v4<L: Lines>(&self, j: u16, pixels: &mut [u8], flags: &mut [u8], carry: &mut Carry) {
        self.line_any::<L, true>(j, pixels, flags, carry)
    }

    /// [`Mix32::line`]'s dispatch to the frame's loop.
    #[inline(always)]
    pub(super) fn line_any<L: Lines, const LANES: bool>(
        &self,
        j: u16,
        pixels: &mut [u8],
        flags: &mut [u8],
        carry: &mut Carry,
    ) {
        // (The sampled loop keeps its own chunk buffers.)
        let (corners, buf) = (&mut carry.corners, &mut carry.chunk);
        // One channel's loops: in a `compact` build, those for three, which
        // compute the frame's one channel ([`chans`]; a copy fewer of each).
        const G: usize = if crate::target::COMPACT { 3 } else { 1 };
        match self.line_loop() {
            LineLoop::FastGrayPerspective if L::FAST_GRAY_PERSPECTIVE => {
                self.line_f::<L, LANES, G, true>(j, pixels, flags, buf)
            }
            LineLoop::FastRgbPerspective if L::FAST_RGB_PERSPECTIVE => {
                self.line_f::<L, LANES, 3, true>(j, pixels, flags, buf)
            }
            LineLoop::FastGrayParallel if L::FAST_GRAY_PARALLEL => {
                self.line_f::<L, LANES, G, false>(j, pixels, flags, buf)
            }
            LineLoop::FastRgbParallel if L::FAST_RGB_PARALLEL => {
                self.line_f::<L, LANES, 3, false>(j, pixels, flags, buf)
            }
            LineLoop::FastGrayPerspectiveSampled if L::FAST_GRAY_PERSPECTIVE_SAMPLED => {
                self.sampled::<L, G, true>(j, pixels, flags, corners)
            }
            LineLoop::FastRgbPerspectiveSampled if L::FAST_RGB_PERSPECTIVE_SAMPLED => {
                self.sampled::<L, 3, true>(j, pixels, flags, corners)
            }
            LineLoop::FastGrayParallelSampled if L::FAST_GRAY_PARALLEL_SAMPLED => {
                self.sampled::<L, G, false>(j, pixels, flags, corners)
            }
            LineLoop::FastRgbParallelSampled if L::FAST_RGB_PARALLEL_SAMPLED => {
                self.sampled::<L, 3, false>(j, pixels, flags, corners)
            }
            LineLoop::FastGrayAperture if L::FAST_GRAY_APERTURE => self.line_d::<L, G>(j, pixels, flags, buf),
            LineLoop::FastRgbAperture if L::FAST_RGB_APERTURE => self.line_d::<L, 3>(j, pixels, flags, buf),
            _ => {}
        }
    }

    /// The loop this frame's lines are rendered by.
    pub fn line_loop(&self) -> LineLoop {
        let rgb = self.format == PixelFormat::Rgb565;
        if self.aperture.is_some() {
            return if rgb {
                LineLoop::FastRgbAperture
            } else {
                LineLoop::FastGrayAperture
            };
        }
        match (rgb, self.parallel.is_none(), self.samples > 1) {
            (false, true, false) => LineLoop::FastGrayPerspective,
            (true, true, false) => LineLoop::FastRgbPerspective,
            (false, false, false) => LineLoop::FastGrayParallel,
            (true, false, false) => LineLoop::FastRgbParallel,
            (false, true, true) => LineLoop::FastGrayPerspectiveSampled,
            (true, true, true) => LineLoop::FastRgbPerspectiveSampled,
            (false, false, true) => LineLoop::FastGrayParallelSampled,
            (true, false, true) => LineLoop::FastRgbParallelSampled,
        }
    }

    /// [`Mix32::line`] for `C` channels, perspective or parallel rays: the
    /// line in chunks of [`CHUNK`] pixels, each in passes — the undistorted
    /// rays, then one pass a primitive keeping the nearest hit, then
    /// shading, then the pixel bytes. A pass holds one primitive's
    /// constants in registers. With the principal point centred
    /// ([`Mix32::mirror`]) a chunk of the left half's rays, once shaded, is
    /// mirrored ([`Ray::mirror`]) into the right half's columns and run
    /// through the passes again: the right half's rays are not undistorted
    /// anew (the error of each is the mirror image of its column's).
    #[cfg_attr(hilcam_loops_out_of_line, inline(never))]
    #[cfg_attr(not(hilcam_loops_out_of_line), inline(always))]
    pub(super) fn line_f<L: Lines, const LANES: bool, const C: usize, const PERSP: bool>(
        &self,
        j: u16,
        pixels: &mut [u8],
        flags: &mut [u8],
        buf: &mut ChunkBufs,
    ) {
        let w = self.width as usize;
        let b = self.format.bytes_per_pixel();
        let (Some(pixels), Some(flags)) = (pixels.get_mut(..w * b), flags.get_mut(..w)) else {
            return;
        };
        let yd = self.yd(j);
        let yd2 = wmul(yd, yd);
        let mut acc = self.x0;
        // kd · E per light for the material of the last shaded pixel.
        let mut k = KCache::EMPTY;
        let dn_max = [0, 1, 2].map(|c| self.format.dn_max(c) as u64);
        let noise = self.noise.as_ref();
        let ChunkBufs {
            rays,
            words,
            fl,
            even3,
        } = buf;
        // The index of the line's first pixel in the frame (the noise's key).
        let line = j as u32 * self.width as u32;
        // Columns `w − half ..` take the rays of columns `.. half` mirrored.
        let half = if self.mirror { w / 2 } else { 0 };
        let direct = w - half;
        // One body for both kinds of chunk (a copy of the passes and the
        // shading each would cost flash): columns `s + q` from their
        // slopes, then, if any, the mirrored columns `w − 1 − s − q` of the
        // first `m` of those rays `q`.
        let (mut s, mut n, mut mirrored) = (0, 0, false);
        let (mut ys, mut outside) = ([0i32; 2], false);
        while s < direct {
            // (Computed twice, here and below, not kept from the chunk's
            // start: kept, it cost the M3's standard scene 6 instructions a
            // pixel, 412 against 406.)
            let m = n.min(half.saturating_sub(s));
            let (cnt, first, step) = if mirrored {
                (m, w - s - m, u32::MAX)
            } else {
                n = CHUNK.min(direct - s);
                (n, s, 1)
            };
            let (Some(rays), Some(out), Some(flags), Some(words), Some(fl)) = (
                rays.first(cnt),
                pixels.get_mut(first * b..(first + cnt) * b),
                flags.get_mut(first..first + cnt),
                words.get_mut(..cnt),
                fl.get_mut(..cnt),
            ) else {
                return;
            };
            if mirrored {
                Ray::mirror_all::<PERSP>(rays);
            } else {
                // Inlined here (not `trace_row`): the loop without sampling
                // stays as fast as it was (an out-of-line pass cost the
                // standard scene 9 M3 instructions a pixel).
                (ys, outside) = match () {
                    // Perspective rays in vector lanes in the x86-64-v3 and
                    // v4 builds.
                    #[cfg(target_arch = "x86_64")]
                    () if LANES && PERSP => {
                        let u = (self.k, self.limit);
                        fill_lanes(
                            rays,
                            &mut acc,
                            self.dx,
                            (yd, yd2),
                            u,
                            (self.vignetting, self.area),
                        )
                    }
                    () => self.rays::<PERSP>(
                        rays,
                        || {
                            let xd = (acc >> 32) as i32;
                            acc -= self.dx;
                            xd
                        },
                        (yd, yd2),
                        (true, true),
                    ),
                };
            }
            // The closed plane, if any: tested only where another primitive
            // was hit; the rays no other primitive hit (and those outside
            // the field) see it or nothing, shaded in closed form.
            let closed = if PERSP { self.closed.as_ref() } else { None };
            let met = self.passes::<PERSP, true>(rays, ys, outside, closed.map(|c| c.index as usize));
            // Each pixel's noise key is its index in the frame: the mirrored
            // rays' columns run right to left (`step` is −1 modulo 2³²).
            let index = line.wrapping_add(if mirrored { w - 1 - s } else { s } as u32);
            // The rays left to shade here, a bit each: those the run left
            // (another primitive's hits), else all.
            let mut left = match closed {
                Some(c) => self.closed_run::<C>(
                    c,
                    (rays, ys, met || outside),
                    (words, &mut *even3),
                    fl,
                    dn_max,
                    (noise, index, step),
                ),
                // (1 to 32 rays: a shift of 0 to 31. None gives a mask
                // whose rays `get` does not find.)
                None => u32::MAX.wrapping_shr(CHUNK.saturating_sub(rays.len()) as u32),
            };
            while left != 0 {
                let q = left.trailing_zeros();
                left &= left - 1;
                let key = index.wrapping_add(q.wrapping_mul(step));
                let q = q as usize;
                if let (Some(r), Some(word), Some(flag)) = (rays.get(q), words.get_mut(q), fl.get_mut(q)) {
                    *word = self.pixel::<L, C, PERSP>(r, copy3!(dn_max), flag, &mut k, (noise, key));
                }
            }
            store(words, fl, mirrored, b, out, flags);
            if !mirrored && n.min(half.saturating_sub(s)) > 0 {
                mirrored = true;
            } else {
                (s, mirrored) = (s + n, false);
            }
        }
    }

    /// [`fill_rays`] of a row of slopes (`ŷ_d` fixed) with this frame's
    /// undistortion (a frame without distortion has a loop without its
    /// test). With `keep_c4`, each ray's `cos⁴α` times the distortion's
    /// area factor ([`Ray::c4`], for [`Mix32::c4`]; a distorted frame's
    /// shaded rays keep it in every loop); without `ra`, on the M0, perspective rays without
    /// their `1/a` ([`Ray::flat`]: rays that are not shaded, in a frame
    /// without a sphere).
    #[inline(always)]
    pub(super) fn rays<const PERSP: bool>(
        &self,
        rays: &mut [Ray],
        xd: impl FnMut() -> i32,
        row: (i32, i64),
        (keep_c4, ra): (bool, bool),
    ) -> ([i32; 2], bool) {
        let korigin = self.parallel.unwrap_or(0);
        let vignette = keep_c4 && self.vignetting;
        let area = self.area.filter(|_| keep_c4);
        // (Not in the M0's `compact` build: the flash it takes there is worth
        // more than the little it saves.)
        let mono = !M0_COMPACT;
        match self.k {
            // `ŷ = ŷ_d g(u)` is monotone in `u` (so in `|x̂_d|`) where `g` is,
            // as each of its floors is: `k1`, `k2 ≥ 0` (u ≥ 0).
            Some(k) => fill_rays::<PERSP>(
                rays,
                korigin,
                xd,
                row,
                |xd, yd, yd2| undistort_kj(k, self.limit, (xd, yd, yd2), area),
                (
                    vignette,
                    area.is_some(),
                    ra,
                    mono && k[0] >= 0 && k[1] >= 0,
                    || undistort_k(k, self.limit, 0, row.0, row.1).map(|(_, y)| y),
                ),
            ),
            None => fill_rays::<PERSP>(
                rays,
                korigin,
                xd,
                row,
                |xd, yd, _| Some((xd, yd, 1 << 31)),
                (vignette, false, ra, mono, || Some(row.0)),
            ),
        }
    }

    /// Every primitive's pass over `rays`, given their `[ŷ_lo, ŷ_hi]`
    /// ([`fill_rays`]; rays outside the field count as 0: a larger box,
    /// never a skipped hit) and whether any is outside the field. Out of line in a `compact` build: one copy
    /// serves the loops for one and three channels (flash).
    /// Primitive `skip` (the frame's [`Closed`] plane in the one-sample
    /// loop) has no pass: [`Mix32::closed_keep`] tests it on the rays
    /// another primitive hits, [`Mix32::closed_run`] shades the others.
    /// Whether any pass ran (else every ray's `t` is as it was).
    #[cfg_attr(feature = "compact", inline(never))]
    #[cfg_attr(not(feature = "compact"), inline(always))]
    pub(super) fn passes<const PERSP: bool, const TRIM: bool>(
        &self,
        rays: &mut [Ray],
        [y0, y1]: [i32; 2],
        outside: bool,
        skip: Option<usize>,
    ) -> bool {
        // Along a row (`ŷ_d` fixed) `x̂` is monotone in `x̂_d` within the
        // field: ∂x̂/∂x̂_d = g + 2 x̂_d² g'(u) ≥ g + 2u g'(u) ≥ 0 before the
        // fold (x̂_d² ≤ u). So the ends bound the rest, to twice
        // `undistort`'s rounding (`box_margin`). A chunk with rays outside
        // the field takes them all.
        let m = self.box_margin;
        let (mut x0, mut x1) = match (rays.first(), rays.last()) {
            (Some(a), Some(b)) if !outside => {
                (a.x.min(b.x).saturating_sub(m), a.x.max(b.x).saturating_add(m))
            }
            _ => (i32::MAX, i32::MIN),
        };
        if outside {
            for r in rays.iter() {
                (x0, x1) = (x0.min(r.x), x1.max(r.x));
            }
        }
        let mut met = false;
        for (i, p) in self.prims.iter().enumerate() {
            if skip == Some(i) {
                continue;
            }
            let (mut lo, mut hi) = (0, rays.len());
            if let Some(b) = p.bounds {
                if x1 < b[0] || x0 > b[1] || y1 < b[2] || y0 > b[3] {
                    continue;
                }
                // The chunk's test, ray by ray, from each end: the pass
                // runs over the rays from the first to the last that lie
                // within the bounds.
                let out = |r: &Ray| r.x < b[0] || r.x > b[1] || r.y < b[2] || r.y > b[3];
                while TRIM && rays.get(lo).is_some_and(out) {
                    lo += 1;
                }
                while TRIM && hi > lo && rays.get(hi - 1).is_some_and(out) {
                    hi -= 1;
                }
            }
            let Some(rays) = rays.get_mut(lo..hi) else {
                continue;
            };
            met = true;
            p.shape
                .nearest::<PERSP, false>(i as u8, rays, (self.inner.as_ref(), [x0, x1, y0, y1]));
        }
        met
    }

    /// Shades one pixel of a chunk whose nearest hits are known; returns
    /// its [`word`].
    #[inline(always)]
    pub(super) fn pixel<L: Lines, const C: usize, const PERSP: bool>(
        &self,
        r: &Ray,
        dn_max: [u64; 3],
        flag: &mut u8,
        k: &mut KCache,
        (noise, index): (Option<&crate::render::sensor::noise::Stage<Q>>, u32),
    ) -> u16 {
        if r.t == 0 {
            *flag = FLAG_OUTSIDE_FIELD;
            return 0;
        }
        *flag = 0;
        let (sum, c4) = self.radiance::<L, C, PERSP, true>(r, k, None);
        Self::dn_word::<C>(self.nch(), sum, c4, dn_max, (noise, index))
    }

    /// A pixel's [`word`] from its sum before vignetting (S15 DN) and
    /// `cos⁴α` (S31): the noise stage's draw, or vignetted and rounded.
    /// Channels past `C` are not packed: the compiler drops them.
    #[inline(always)]
    pub(super) fn dn_word<const C: usize>(
        n: usize,
        sum: [u64; 3],
        c4: u32,
        dn_max: [u64; 3],
        (noise, index): (Option<&crate::render::sensor::noise::Stage<Q>>, u32),
    ) -> u16 {
        match noise {
            Some(z) => noisy::<C>(n, z, sum, c4, index, dn_max),
            // (A `compact` build's loop for three channels serves one-channel
            // frames too: their channel alone. The others leave the
            // compiler to drop what `word` does not pack.)
            None if crate::target::COMPACT && !M0_COMPACT => {
                let mut dn = [0u32; 3];
                each::<C>(n, |c| {
                    if let (Some(d), Some(&s), Some(&max)) = (dn.get_mut(c), sum.get(c), dn_max.get(c)) {
                        *d = vignette_dn(s, c4, max as u32);
                    }
                });
                word::<C>(n, dn)
            }
            // On the M0 each channel a value, not through a closure over
            // the arrays: at its camera's opt-level "z" that closure stayed
            // out of line and both arrays were copied to the stack a pixel,
            // two `memcpy`s of 24 B (wide-vignetting 338.2 against 193.7
            // instructions a pixel, standard 884.8 against 810.3; this form
            // measured the M3 camera's standard 231.8 against 221.1).
            None if M0_COMPACT => {
                let ([s0, s1, s2], [m0, m1, m2]) = (sum, dn_max);
                let v = |s: u64, max: u64| vignette_dn(s, c4, max as u32);
                let d0 = v(s0, m0);
                let dn = if chans::<C>(n) == 3 {
                    [d0, v(s1, m1), v(s2, m2)]
                } else {
                    [d0, 0, 0]
                };
                word::<C>(n, dn)
            }
            // Three sums below 2^32 (no channel saturated), tested once:
            // spheres-specular 4.4 M3 instructions a pixel fewer (on the
            // M0 1.7 more: not there).
            None if C == 3 && !M0 && (sum[0] | sum[1] | sum[2]) >> 32 == 0 => word::<C>(
                n,
                zip3(sum, dn_max, |s, max| vignette_dn_lo(s as u32, c4, max as u32)),
            ),
            None => word::<C>(n, zip3(sum, dn_max, |s, max| vignette_dn(s, c4, max as u32))),
        }
    }

    /// A ray's (in the field) sum before vignetting (S15 DN, capped) and
    /// its `cos⁴α` (S31; [`Mix32::c4`]).
    #[inline(always)]
    pub(super) fn radiance<L: Lines, const C: usize, const PERSP: bool, const KEPT: bool>(
        &self,
        r: &Ray,
        k: &mut KCache,
        key: Option<Key>,
    ) -> ([u64; 3], u32) {
        let c4 = self.c4::<KEPT>(r);
        let sum = match self.hit_from::<L, C, PERSP, false>(r, [[0; 2]; 2], key) {
            Some(h) => self.shade_flat::<L, C, PERSP>(r, &h, k),
            None => copy3!(self.bg),
        };
        (sum, c4)
    }

    /// The channels a loop for `C` computes for this frame ([`chans`]).
    #[inline(always)]
    pub(super) fn chans<const C: usize>(&self) -> usize {
        chans::<C>(self.nch())
    }

    /// The frame's channels where a loop takes them at run time (a
    /// `compact` build's: [`chans`]); elsewhere 0, which no loop reads (its
    /// `C` says): no code.
    #[inline(always)]
    pub(super) fn nch(&self) -> usize {
        if crate::target::COMPACT {
            self.format.channels()
        } else {
            0
        }
    }

    /// A shaded ray's `cos⁴α` (S31, times the distortion's area factor over
    /// `2^e`): if `KEPT` (always in the one-sample loop, [`KEEP_C4_SAMPLED`]
    /// in the others) or the frame is distorted, as [`fill_rays`] set it.
    #[inline(always)]
    pub(super) fn c4<const KEPT: bool>(&self, r: &Ray) -> u32 {
        if KEPT {
            r.c4
        } else if self.cos4_of_ra {
            cos4(r.ra)
        } else if self.area.is_some() {
            r.c4
        } else {
            1 << 31
        }
    }

    /// The material ray `r` sees at its hit on `p` (its point `pt`, `[0;
    /// 3]` where [`Mix32::hit_from`] takes none; the frame moved to `a` if
    /// `MOVED`): `p`'s, or its checker's on the odd cells (from `key`
    /// where the caller knows the cell).
    #[inline(always)]
    pub(super) fn material_at<const PERSP: bool, const MOVED: bool>(
        p: &MixPrim,
        r: &Ray,
        pt: [i32; 3],
        a: [i32; 2],
        key: Option<Key>,
    ) -> usize {
        let mut m = p.material as usize;
        if let Some(k) = &p.checker {
            let odd = match key {
                Some(key) => key.odd(),
                None => {
                    // (The aperture loop's rays start off the axis.)
                    let bounded = p.shape.bounded();
                    let (cu, cv) = match (PERSP, MOVED) {
                        (true, false) => k.cells_of::<PERSP>(r, bounded),
                        (true, true) => k.cells::<PERSP>(r.hit_point::<PERSP, MOVED>(a), bounded),
                        // (A parallel ray's point is its origin and `t`.)
                        (false, _) => k.cells::<PERSP>(pt, bounded),
                    };
                    // The parity of cu + cv.
                    (cu ^ cv) & 1 != 0
                }
            };
            if odd {
                m = k.material as usize;
            }
        }
        m
    }

    /// The nearest hit of a ray after every primitive's pass; if `MOVED`,
    /// for a ray traced in the frame moved to
    /// `(a_x, a_y, 0)` (`a` in S18 U, `a24` in S24 U, as
    /// [`MixShape::moved`] takes them): the hit point moved back, the rest
    /// in the camera frame. (`MOVED` a constant: `hit` as
    /// this with `a = 0` at run time cost the M4F's standard scene 7
    /// instructions a pixel.) With `key`, the ray's [`Key`] as
    /// [`Mix32::key`] found it: a checker's material from its cell's parity.
    #[inline(always)]
    pub(super) fn hit_from<L: Lines, const C: usize, const PERSP: bool, const MOVED: bool>(
        &self,
        r: &Ray,
        [a, a24]: [[i32; 2]; 2],
        key: Option<Key>,
    ) -> Option<Hit<'_>> {
        if r.t == NO_HIT {
            return None;
        }
        let prim = (r.hit & !AWAY) as usize;
        let p = self.prims.get(prim)?;
        let away = r.hit & AWAY != 0;
        // The point, where a sphere's normal or a point light's term takes
        // it: a flat primitive ([`MixPrim::flat`]: directional lights
        // alone) needs none.
        let pt = if PERSP && p.flat {
            [0; 3]
        } else {
            r.hit_point::<PERSP, MOVED>(a)
        };
        let mut view = None;
        let n = match &p.shape {
            MixShape::Plane { n, .. } | MixShape::Disc { n, .. } | MixShape::Rect { n, .. } => *n,
            // Under a specular lobe, whose exponent multiplies the normal's
            // error, from the ray and the sphere (the centre from the
            // ray's origin).
            MixShape::Sphere {
                c,
                r24,
                inv_r,
                fine: true,
                ..
            } if lobe_built::<L, C>() => {
                // The centre the pass took ([`MixShape::moved`]).
                let c = if MOVED { moved_point(*c, a24) } else { *c };
                let (n, v) = fine_normal::<PERSP, MOVED>(r, c, *r24, *inv_r, away);
                // (Not kept in a `compact` build, whose loops measured more
                // with it.)
                view = (!crate::target::COMPACT).then_some(v);
                n
            }
            // A point of the sphere: `|p − c|` is `r` within the hit's
            // error (`r` ≥ 2⁻¹⁰ U, [`recip_len`]; the point within 2⁻¹⁶ U:
            // below 1.02 r), so each component, S30, is below 2³¹ and the
            // low word of the shifted product (and `p − c`, both within
            // 8 U) needs no saturation. The same values. (`inv_r`'s shift
            // is 9 to 26: [`recip_len`] normalizes 2⁵⁴/s, s in [2¹⁴, 2³¹),
            // to 32 bits from 24 to 41.)
            MixShape::Sphere { c18, inv_r, .. } => zip3(pt, *c18, |p, c| {
                sar64_low_lt32(smul_u(p.wrapping_sub(c), inv_r.0), inv_r.1)
            }),
        };
        let m = Self::material_at::<PERSP, MOVED>(p, r, pt, a, key);
        Some(Hit {
            m,
            pt,
            n,
            away,
            nl: &p.nl,
            flat: p.flat,
            #[cfg(feature = "shadows")]
            shade: key.map(Key::shade),
            view,
        })
    }

    /// The unit direction from a ray's hit towards the viewer, S30:
    /// `−(x̂, ŷ, 1)/√a` (perspective) or `(0, 0, −1)` (parallel rays).
    #[inline(always)]
    pub(super) fn view<const PERSP: bool>(r: &Ray) -> [i32; 3] {
        if !PERSP {
            return [0, 0, -(1 << 30)];
        }
        // a S20 = m 2^-z; 1/√a = y 2^((z − 44)/2) in S30 (z ≤ 42: a ≥ 1).
        // (The shift is below 32 — a ≤ 513 in S20, so z ≥ 34 — but its
        // word form here, [`sar64_low_lt32`], measured no better.)
        let (y, z) = rsqrt_fine(r.a as u64);
        let sh = 26 + (44 - z.min(44)) / 2;
        [
            -(sar64(smul_u(r.x, y), sh) as i32),
            -(sar64(smul_u(r.y, y), sh) as i32),
            -((y >> ((44 - z.min(44)) / 2)) as i32),
        ]
    }

    /// Whether a hit's sum depends on its primitive, side and material
    /// alone ([`Mix32::shade_flat`] keeps it): a flat primitive's
    /// ([`MixPrim::flat`]) whose material `m` has no lobe rendered. (In a
    /// `compact` build too, since the aperture loop's copies of `shade`
    /// are one call, [`Mix32::shade_flat_ap`]: before, the copies cost
    /// 21 KB of the M3 camera's flash and were left out, its frames
    /// dearer — shallow-dof 13 448 against 8 303 instructions a pixel.)
    #[inline(always)]
    pub(super) fn flat_sum<L: Lines, const C: usize>(&self, flat: bool, m: usize) -> bool {
        let lobe = lobe_built::<L, C>() && self.lobe.get(m).is_none_or(Option::is_some);
        flat && !lobe
    }

    /// [`Mix32::shade`], kept for the next hit where it cannot change: on a
    /// [`MixPrim::flat`] primitive (a constant normal, every light
    /// directional), of a material without a rendered lobe, the sum depends
    /// on the primitive, its side and the material alone — [`Ray::hit`]
    /// and [`Hit::m`], the key it is kept under. The same sums.
    #[inline(always)]
    pub(super) fn shade_flat<L: Lines, const C: usize, const PERSP: bool>(
        &self,
        r: &Ray,
        h: &Hit,
        k: &mut KCache,
    ) -> [u64; 3] {
        if !self.flat_sum::<L, C>(h.flat, h.m) {
            return self.shade::<L, C, PERSP>(r, h, k);
        }
        if k.flat != (r.hit, h.m) {
            k.flat_sum = self.shade::<L, C, PERSP>(r, h, k);
            k.flat = (r.hit, h.m);
        }
        copy3!(k.flat_sum)
    }

    /// The ambient, Lambertian and (for a material with a lobe) specular
    /// terms of every light, before vignetting: S15 DN, capped at
    /// [`SUM_CAP`].
    #[inline(always)]
    pub(super) fn shade<L: Lines, const C: usize, const PERSP: bool>(
        &self,
        r: &Ray,
        h: &Hit,
        k: &mut KCache,
    ) -> [u64; 3] {
        let Hit {
            m,
            pt,
            n,
            away,
            nl: nls,
            view: kept,
            ..
        } = *h;
        let nch = self.nch();
        let channels = chans::<C>(nch);
        if k.material != m {
            let (Some(kd), Some(&ka), Some(ks), Some(&lobe)) =
                (self.kd.get(m), self.ka.get(m), self.ks.get(m), self.lobe.get(m))
            else {
                return [0; 3];
            };
            k.material = m;
            k.ka = ka;
            k.lobe = lobe;
            k.below = self.lobe_below.get(m).copied().unwrap_or(0);
            for ((kl, (ksl, top)), l) in k.k.iter_mut().zip(k.ks.iter_mut()).zip(&self.lights) {
                let e = match l {
                    MixLight::Point { i, .. } => i,
                    MixLight::Directional { e, .. } => e,
                };
                for (((kc, ksc), (d, s)), e) in kl
                    .iter_mut()
                    .zip(ksl.iter_mut())
                    .zip(kd.iter().zip(ks))
                    .zip(e)
                    .take(channels)
                {
                    *kc = *d * *e;
                    *ksc = *s * *e;
                }
                *top = ksl.iter().take(channels).map(|p| p.e).max().unwrap_or(0);
            }
        }
        // The normal turned towards the viewer, and the view direction, for
        // the lobe.
        let nt = if away { n.map(i32::saturating_neg) } else { n };
        // The lobe, if this build's loop for `C` channels has it (a frame
        // with one is refused by a build without: `Frame::line_built`).
        let lobe = if lobe_built::<L, C>() { k.lobe } else { None };
        let view = lobe.map(|_| kept.unwrap_or_else(|| Self::view::<PERSP>(r)));
        let mut sum = copy3!(k.ka);
        #[cfg(feature = "shadows")]
        let mut shadowed = match &self.shadow {
            // (The key's, where the adaptive rule found them: the same
            // point's test; its normal, coarse under a lobe, gates only
            // `n·l ≤ 0`, where the light adds nothing.)
            Some(s) => h
                .shade
                .unwrap_or_else(|| s.shadowed((r.hit & !AWAY) as usize, pt, nt)),
            None => 0,
        };
        #[cfg(not(feature = "shadows"))]
        let mut shadowed = 0u8;
        for (((l, kl), (ksl, top)), &nl) in self.lights.iter().zip(&k.k).zip(&k.ks).zip(nls) {
            // (No bit test a light where none is shadowed.)
            if shadowed != 0 {
                let lit = shadowed & 1 == 0;
                shadowed >>= 1;
                if !lit {
                    continue;
                }
            }
            let (w, ldir) = match l {
                MixLight::Point { p, .. } => {
                    let lv = zip3(*p, pt, i32::saturating_sub);
                    // n·l, S48 U: the plane's constant, or from the hit.
                    let nl = match (nl, away) {
                        (0, _) => wmul_px(nt[0], lv[0]) + wmul_px(nt[1], lv[1]) + wmul_px(nt[2], lv[2]),
                        (c, false) => c,
                        (c, true) => -c,
                    };
                    if nl <= 0 {
                        continue;
                    }
                    // r², S36 U², exact (> 0: n·l is).
                    let r2 = wsq(lv[0]) + wsq(lv[1]) + wsq(lv[2]);
                    let (_, y, z) = rsqrt_norm(r2);
                    // l̂ = l/r in S30 (only for the lobe): 1/r = y 2^((z − 28)/2)
                    // with lv in S18.
                    let ldir = view.map(|_| {
                        let (y, z) = rsqrt_refine(r2, y, z);
                        map3(lv, |c| sar64_low(smul_u(c, y), 32 - z / 2))
                    });
                    (cos_over_r3(nl as u64, y, z), ldir)
                }
                MixLight::Directional { l, .. } => {
                    let Some(w) = directional_w(nt, *l) else {
                        continue;
                    };
                    (w, Some(*l))
                }
            };
            each::<C>(nch, |c| {
                if let (Some(s), Some(k)) = (sum.get_mut(c), kl.get(c)) {
                    *s = (*s + k.mul_to_sum(w, 15)).min(SUM_CAP);
                }
            });
            if let (Some(s), Some(v), Some(ld)) = (lobe, view, ldir) {
                // r̂·v̂ = 2 (n̂·l̂)(n̂·v̂) − l̂·v̂, S30.
                let (nl, nv) = (dot30(nt, ld), dot30(nt, v));
                // (2 nl nv) >> 30 as (nl nv) >> 29: a 32 × 32-bit product
                // (as i64s, a library call on the M0).
                let rv = sat32((wmul_px(nl, nv) >> 29) - dot30(ld, v) as i64);
                // Below `below` the lobe is at most 2⁻⁶⁴ (0 at and below
                // 0), and with `ks E w` under 2⁴⁹ DN (its exponents' sum
                // at most −15: each mantissa is below 2³²) its term is
                // below 2⁻¹⁵ DN, which `mul_to_sum` floors to 0: the same
                // sum without the powers.
                if rv < k.below && *top + w.e <= -15 {
                    continue;
                }
                let f = lobe_pf(rv, s);
                each::<C>(nch, |c| {
                    if let (Some(s), Some(k)) = (sum.get_mut(c), ksl.get(c)) {
                        *s = (*s + (*k * f).mul_to_sum(w, 15)).min(SUM_CAP);
                    }
                });
            }
        }
        copy3!(sum)
    }
}
