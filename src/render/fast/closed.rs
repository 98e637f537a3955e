//! The fast arithmetic's plane in closed form ([`Closed`]): which plane
//! a frame shades so (`closed_plane`), its test on the rays another
//! primitive hits (`closed_keep`), and the runs of rays that see it or
//! nothing (`closed_run`, `closed_lit`: its terms from a ray's slopes, no
//! hit point; `closed_flat`: a constant sum where no point light is on
//! its side).

use super::arith::{copy3, zip3, Pf, SUM_CAP};
use super::intersect::MixShape;
use super::rays::{unhit, Ray, AWAY, CHUNK, KEEP_Q2, NO_HIT};
use super::shade::{closed_term, closed_w, directional_w, mean, mean_into};
use super::{chans, each, Closed, ClosedLight, Mix32, MixLight};
use crate::render::{ClosedMean, FLAG_OUTSIDE_FIELD};
use crate::scene::Q;

impl Mix32 {
    /// The frame's first plane that [`Mix32::closed_run`] can shade: no
    /// checker, no lobe, perspective rays, the camera off it by 2⁻¹⁰ U or
    /// more (so that `t = dist/w` never rounds to 0: where `w` has the sign
    /// of `dist` the plane's pass keeps a hit), and a constant `n·l`
    /// ([`MixPrim::nl`]) towards every point light. Out of line: once a
    /// frame.
    #[inline(never)]
    pub(super) fn closed_plane(&self, mean: ClosedMean) -> Option<Closed> {
        if self.parallel.is_some() {
            return None;
        }
        let (index, p) = self.prims.iter().enumerate().find(|(i, p)| {
            matches!(p.shape, MixShape::Plane { dist, .. } if dist.unsigned_abs() >= 1 << 14)
                // (Not one that takes a shadow test: shaded point by point.)
                && self.shadow_tests(*i) == 0
                // (Not one behind the view, whose bounds are empty.)
                && p.bounds.is_none()
                && p.checker.is_none()
                && self.lobe.get(p.material as usize).is_some_and(Option::is_none)
                && (self.lights.iter().zip(&p.nl))
                    .all(|(l, h)| matches!(l, MixLight::Directional { .. }) || *h != 0)
        })?;
        let MixShape::Plane { n, dist, .. } = p.shape else {
            return None;
        };
        let m = p.material as usize;
        let (kd, ka) = (self.kd.get(m)?, self.ka.get(m)?);
        // The side the rays see: hits face away where dist > 0 (`plane_t`).
        let away = dist > 0;
        let nt = if away { n.map(i32::saturating_neg) } else { n };
        let mut c = Closed {
            index: u8::try_from(index).ok()?,
            mean,
            n,
            dist,
            ndist: dist.saturating_neg(),
            ndist50: -((dist as i64) << 26),
            beyond: Ray::beyond_limit(dist),
            flat: *ka,
            lights: heapless::Vec::new(),
        };
        for (l, &h) in self.lights.iter().zip(&p.nl) {
            match l {
                // Added and capped as `shade` adds them: the terms are never
                // negative, so their order does not change the capped sum.
                MixLight::Directional { l, e } => {
                    if let Some(w) = directional_w(nt, *l) {
                        for ((s, d), e) in c.flat.iter_mut().zip(kd).zip(e) {
                            *s = (*s + (*d * *e).mul_to_sum(w, 15)).min(SUM_CAP);
                        }
                    }
                }
                MixLight::Point { p, i } => {
                    // |P_L| ≤ 8 U: S26 holds it.
                    if p.iter().any(|v| v.unsigned_abs() > 1 << 21) {
                        return None;
                    }
                    // On the side the rays see (n·l > 0 there, as `shade`
                    // takes it: h facing the viewer, −h facing away).
                    if (h > 0) != away {
                        let hk = Pf::new(h.unsigned_abs(), -48);
                        let _ = c.lights.push(ClosedLight {
                            p26: p.map(|v| v << 8),
                            k: zip3(*kd, *i, |d, i| d * i * hk),
                        });
                    }
                }
            }
        }
        Some(c)
    }

    /// The [`Closed`] plane's test on a ray another primitive hit: kept as
    /// its own pass in scene order would keep it (nearer, or as near and
    /// first). Perspective rays. In [`Mix32::closed_run`]'s loop (a pass of
    /// its own over the chunk's rays cost the M3's standard scene 15
    /// instructions a pixel).
    #[inline(always)]
    pub(super) fn closed_keep(c: &Closed, r: &mut Ray) {
        // Most of these rays meet the other primitive before the plane,
        // which no reciprocal then needs to show (`Ray::plane_beyond`).
        if Ray::plane_beyond(r.n_dot_d(c.n), c.dist, r.t, c.beyond) {
            return;
        }
        // (The rest, rare, takes `n·d` again: one copy of `plane_t`.)
        if let Some((t, away)) = r.plane_t::<true>(c.n, c.dist, (0, 0)) {
            if t < r.t || (t == r.t && c.index < r.hit & !AWAY) {
                r.t = t;
                r.hit = c.index | if away { AWAY } else { 0 };
            }
        }
    }

    /// The words and flags of a chunk's rays that see the [`Closed`] plane
    /// or nothing (no other primitive's hit; `t` is [`NO_HIT`]) and of
    /// those outside the field; the others, a bit each in the mask
    /// returned, are left to the general path, the plane tested on them
    /// ([`Mix32::closed_keep`]). The
    /// pixel's sum is the plane's ambient and directional terms and, for
    /// each point light on the side it faces, `kd I h (|w| / |q|)³`: `w`
    /// (S24) as [`Ray::plane_t`] takes it, `q` exact in S42 U, then S22 U,
    /// `1/|q|` from [`rsqrt_norm`]. The [`chans`] channels are summed, and
    /// packed in RGB565 if three, else one. `met`: whether any ray may have
    /// been hit or lies outside the field (else every `t` is [`NO_HIT`]: a
    /// pass ran on none, [`Mix32::passes`]). Out of line: its own
    /// registers.
    #[cfg_attr(hilcam_loops_out_of_line, inline(never))]
    #[cfg_attr(not(hilcam_loops_out_of_line), inline(always))]
    #[allow(clippy::too_many_arguments)]
    pub(super) fn closed_run<const C: usize>(
        &self,
        c: &Closed,
        (rays, ys, met): (&mut [Ray], [i32; 2], bool),
        (words, even3): (&mut [u16], &mut [[u64; 3]; CHUNK / 2 + 1]),
        fl: &mut [u8],
        dn_max: [u64; 3],
        (noise, index, step): (Option<&crate::render::sensor::noise::Stage<Q>>, u32, u32),
    ) -> u32 {
        let n = c.n;
        let nch = self.nch();
        let mut left = 0;
        // With n_x = 0 a ray and its mirror share w, q_y and q_z, and the
        // two products of q_x (`closed_term`, [`KEEP_Q2`]): the chunk's
        // rays keep their mirrors' |q|², the mirrored chunk's take it.
        let keep = KEEP_Q2 && n[0] == 0 && self.mirror;
        // (`step` is 1 for an unmirrored chunk, −1 for a mirrored one.)
        let store = keep && step == 1;
        // A compile-time constant but in a `compact` build (one copy).
        let rgb = chans::<C>(nch) == 3;
        // A chunk whose rays all see the plane, in a frame with one point
        // light on the plane's side: its even rays'
        // terms (with `Quads`, those of every fourth and of the last even
        // ray, and the other even rays' sums the mean of theirs 2 apart),
        // and its odd rays' sums the mean of their neighbours' (the last
        // ray, if odd, its own).
        if let (true, [l]) = (c.mean.on(), c.lights.as_slice()) {
            let len = rays.len().min(words.len()).min(fl.len());
            // Every ray unhit, and every ray's `w` ahead ([`all_ahead`]);
            // `w` is taken again below for the rays shaded (with `Quads` a
            // third of them).
            let mut lit = len >= 3 && (!met || unhit(rays));
            if lit {
                lit = all_ahead(c, rays, ys);
            }
            if lit {
                // Without noise, a copy of the loops without its test (a
                // branch a ray: the M3's standard scene 207.8 against 205.9
                // instructions a pixel, for 2 KB of flash; the M3 camera's,
                // a `compact` build, 228.9 against 225.6 for 1.3 KB; not in
                // the M0's `compact` build, 885.4 against 875.9 for 2.1 KB).
                // (The two calls: through one closure the compiler kept a
                // single copy, with the test — 204.8 a pixel.)
                match noise {
                    #[cfg(not(all(feature = "compact", hilcam_m0)))]
                    None => self.closed_lit::<C>(
                        c,
                        l,
                        (rays, len),
                        (words, even3),
                        dn_max,
                        (keep, store),
                        (None, index, step),
                    ),
                    _ => self.closed_lit::<C>(
                        c,
                        l,
                        (rays, len),
                        (words, even3),
                        dn_max,
                        (keep, store),
                        (noise, index, step),
                    ),
                }
                fl.iter_mut().for_each(|f| *f = 0);
                return 0;
            }
        }
        // A chunk whose rays all see the plane, in a frame without a point
        // light on the plane's side (directional lights alone): every
        // ray's sum is `flat`.
        // (On the M0 the test inline and the words out of line: its
        // standard scene, which has a point light, measured 587.93 against
        // 586.69 with the test out of line — past 3× the M3's 195.88.
        // Elsewhere out of line: inline, the M3's measured 196.35, and the
        // x86-64 host's 1080p standard 65.0–69.4 frames/s where the build
        // before `closed_flat` ran 69.8–72.3, interleaved.)
        if c.lights.is_empty()
            && self.closed_flat(c, rgb, (rays, ys, met), (words, fl), dn_max, (noise, index, step))
        {
            return 0;
        }
        // Without noise, a copy of the loop without its test (not in a
        // `compact` build), as `closed_lit` has.
        let mut each = |noise: Option<&crate::render::sensor::noise::Stage<Q>>| {
            for (q, ((r, word), flag)) in rays
                .iter_mut()
                .zip(words.iter_mut())
                .zip(fl.iter_mut())
                .enumerate()
            {
                // The pixel's noise key (computed where the noise draws).
                let k = index.wrapping_add((q as u32).wrapping_mul(step));
                if r.t == 0 {
                    (*word, *flag) = (0, FLAG_OUTSIDE_FIELD);
                    continue;
                }
                if r.t != NO_HIT {
                    Self::closed_keep(c, r);
                    left |= 1 << q;
                    continue;
                }
                *flag = 0;
                let w = closed_w(n, r);
                let sum = if c.ahead(w) {
                    let mut sum = copy3!(c.flat);
                    // One light (the common case) without the loop's overhead.
                    match c.lights.as_slice() {
                        [l] => closed_term::<C>(nch, c, l, r, w, (keep, store), &mut sum),
                        ls => ls
                            .iter()
                            .for_each(|l| closed_term::<C>(nch, c, l, r, w, (false, false), &mut sum)),
                    }
                    sum
                } else {
                    self.bg
                };
                *word = self.closed_word(rgb, copy3!(sum), r, copy3!(dn_max), (noise, k));
            }
            left
        };
        match noise {
            #[cfg(not(feature = "compact"))]
            None => each(None),
            _ => each(noise),
        }
    }

    /// [`Mix32::closed_run`]'s chunk, in a frame without a point light on
    /// the plane's side: if its rays all see the plane ([`all_ahead`]),
    /// each ray's word from the plane's constant sum `flat`, no `w` a ray
    /// (a wall under a directional light), and `true`; else nothing.
    /// Out of line, the test with it: the run's loops keep their
    /// registers and size ([`Mix32::closed_run`] says what each form
    /// measured); on the M0 inlined, its words out of line.
    #[cfg_attr(hilcam_m0, inline(always))]
    #[cfg_attr(not(hilcam_m0), inline(never))]
    fn closed_flat(
        &self,
        c: &Closed,
        rgb: bool,
        (rays, ys, met): (&[Ray], [i32; 2], bool),
        (words, fl): (&mut [u16], &mut [u8]),
        dn_max: [u64; 3],
        (noise, index, step): (Option<&crate::render::sensor::noise::Stage<Q>>, u32, u32),
    ) -> bool {
        if !((!met || unhit(rays)) && all_ahead(c, rays, ys)) {
            return false;
        }
        // Without noise, a copy of the words without its test, as
        // `closed_lit` has: in a firmware that also holds a scene with
        // noise, a scene without paid noise's test a ray. Not on the M0,
        // where `flat_words` is a call and a second one cost its other
        // scenes.
        match noise {
            #[cfg(not(hilcam_m0))]
            None => self.flat_words(c, rgb, rays, words, dn_max, (None, index, step)),
            _ => self.flat_words(c, rgb, rays, words, dn_max, (noise, index, step)),
        }
        fl.iter_mut().for_each(|f| *f = 0);
        true
    }

    /// [`Mix32::closed_flat`]'s words: each ray's from the plane's
    /// constant sum `flat`. Out of line on the M0 (where `closed_flat`,
    /// the chunk's test, is inlined in the run), inlined in `closed_flat`
    /// elsewhere.
    #[cfg_attr(hilcam_m0, inline(never))]
    #[cfg_attr(not(hilcam_m0), inline(always))]
    fn flat_words(
        &self,
        c: &Closed,
        rgb: bool,
        rays: &[Ray],
        words: &mut [u16],
        dn_max: [u64; 3],
        (noise, index, step): (Option<&crate::render::sensor::noise::Stage<Q>>, u32, u32),
    ) {
        for (q, (r, word)) in rays.iter().zip(words.iter_mut()).enumerate() {
            let k = index.wrapping_add((q as u32).wrapping_mul(step));
            *word = self.closed_word(rgb, c.flat, r, dn_max, (noise, k));
        }
    }

    /// [`Mix32::closed_run`]'s chunk whose rays all see the plane under its
    /// one point light `l`: the first `len` rays' words, the even rays'
    /// sums kept in `even3` (three channels, or one in its first words;
    /// the `let … else` never returns: 51 words hold 17 of either).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn closed_lit<const C: usize>(
        &self,
        c: &Closed,
        l: &ClosedLight,
        (rays, len): (&mut [Ray], usize),
        (words, even3): (&mut [u16], &mut [[u64; 3]; CHUNK / 2 + 1]),
        dn_max: [u64; 3],
        (keep, store): (bool, bool),
        (noise, index, step): (Option<&crate::render::sensor::noise::Stage<Q>>, u32, u32),
    ) {
        let (n, nch) = (c.n, self.nch());
        let rgb = chans::<C>(nch) == 3;
        // Two loops, the even rays' sums kept between them: one with
        // the lag cost the M3's standard scene 14 instructions a pixel.
        // Ray q's at q/2 (q even; an odd one reads q/2 and q/2 + 1).
        // One slot spare: with 16, spheres-specular measured 549.1
        // against 545.7 M3 instructions a pixel (the frame's layout).
        // In the chunk buffers (`ChunkBufs::even3`, one channel's in its
        // first 17 words): every slot read is written first in the chunk.
        // (One channel's in the run's own frame, zeroed a chunk, cost the
        // M3's standard scene 1.9 instructions a pixel more.)
        let slots = even3.as_flattened_mut().as_chunks_mut::<C>().0;
        let Some(Ok(even)) = slots
            .get_mut(..CHUNK / 2 + 1)
            .map(<&mut [[u64; C]; CHUNK / 2 + 1]>::try_from)
        else {
            return;
        };
        // The last even ray (the even rays below it between the
        // shaded ones take means).
        let e = len.saturating_sub(1) & !1;
        // (A bit a ray: `next_shaded` a call a ray cost the M3 more.)
        let mut shaded = c.mean.shaded_mask(len);
        while shaded != 0 {
            let q = shaded.trailing_zeros() as usize;
            shaded &= shaded - 1;
            let (Some(r), Some(word)) = (rays.get_mut(q), words.get_mut(q)) else {
                break;
            };
            let w = closed_w(n, r);
            let mut sum = copy3!(c.flat);
            closed_term::<C>(nch, c, l, r, w, (keep, store), &mut sum);
            if let (0, Some(e)) = (q & 1, even.get_mut(q >> 1)) {
                // (The frame's channels: a `compact` build's gray
                // frame stores one, not its loop's three.)
                each::<C>(nch, |ch| {
                    if let (Some(e), Some(s)) = (e.get_mut(ch), sum.get(ch)) {
                        *e = *s;
                    }
                });
            }
            // The pixel's noise key (computed where the noise draws).
            let k = index.wrapping_add((q as u32).wrapping_mul(step));
            *word = self.closed_word(rgb, copy3!(sum), r, copy3!(dn_max), (noise, k));
        }
        // The even rays between, level by level: with `Octs` the rays
        // ≡ 4 (mod 8) from the shaded ones 4 apart (a ray whose ray 4
        // on lies past `e` was shaded: `next_shaded`), then with
        // `Quads` and `Octs` the rays ≡ 2 (mod 4) from those 2 apart.
        // A loop each: one loop for the levels cost the M3 4 a pixel,
        // and the M3 camera's (`compact`) standard scene 7.2 (236.1
        // against 228.9, for 396 B of flash).
        let (octs, quads) = (c.mean == ClosedMean::Octs, c.mean.span() >= 4);
        let mut q = 4;
        while octs && q + 4 <= e {
            if let (Some([a, _, m, _, b]), Some(r), Some(word)) = (
                even.get_mut((q >> 1) - 2..(q >> 1) + 3),
                rays.get(q),
                words.get_mut(q),
            ) {
                let sum = mean_into::<C>(nch, a, b, m);
                let k = index.wrapping_add((q as u32).wrapping_mul(step));
                *word = self.closed_word(rgb, copy3!(sum), r, copy3!(dn_max), (noise, k));
            }
            q += 8;
        }
        // Rays `4i + 2` below `e`: chunks of 4 rays and words (as the odd
        // rays below).
        if let (true, Some(rs), Some(ws)) = (quads, rays.get(..e), words.get_mut(..e)) {
            let fours = rs.as_chunks::<4>().0.iter().zip(ws.as_chunks_mut::<4>().0);
            for (i, ([_, _, r, _], [_, _, word, _])) in fours.enumerate() {
                if let Some([a, m, b]) = even.get_mut(2 * i..2 * i + 3) {
                    let sum = mean_into::<C>(nch, a, b, m);
                    let k = index.wrapping_add((4 * i as u32 + 2).wrapping_mul(step));
                    *word = self.closed_word(rgb, copy3!(sum), r, copy3!(dn_max), (noise, k));
                }
            }
        }
        // The odd rays below the last: pairs of rays and words, the odd
        // ray second (index and bounds tests a ray fewer than by index).
        let below = len.saturating_sub(1);
        let (Some(rs), Some(ws)) = (rays.get(..below), words.get_mut(..below)) else {
            return;
        };
        let pairs = rs.as_chunks::<2>().0.iter().zip(ws.as_chunks_mut::<2>().0);
        for (i, (([_, r], [_, word]), (a, b))) in pairs.zip(even.iter().zip(even.iter().skip(1))).enumerate()
        {
            let mut sum = [0u64; 3];
            each::<C>(nch, |ch| {
                if let (Some(s), Some(a), Some(b)) = (sum.get_mut(ch), a.get(ch), b.get(ch)) {
                    *s = mean(*a, *b);
                }
            });
            let k = index.wrapping_add((2 * i as u32 + 1).wrapping_mul(step));
            *word = self.closed_word(rgb, copy3!(sum), r, copy3!(dn_max), (noise, k));
        }
    }

    /// [`Mix32::closed_run`]'s [`word`] of a ray from its sum, noise key
    /// `k`: its channels packed in RGB565 if `rgb`, else one.
    #[inline(always)]
    fn closed_word(
        &self,
        rgb: bool,
        sum: [u64; 3],
        r: &Ray,
        dn_max: [u64; 3],
        (noise, k): (Option<&crate::render::sensor::noise::Stage<Q>>, u32),
    ) -> u16 {
        if rgb {
            Self::dn_word::<3>(3, sum, self.c4::<true>(r), dn_max, (noise, k))
        } else {
            Self::dn_word::<1>(1, sum, self.c4::<true>(r), dn_max, (noise, k))
        }
    }
}

/// Whether every one of a chunk's rays (unhit, in the field) meets the
/// [`Closed`] plane ahead: so do those of the box of slopes around them
/// (`x̂` from the chunk's end rays, monotone along a row within the field,
/// as [`Mix32::passes`] takes it; `ŷ` from `ys`) where its corners' do
/// (`w` is the floor of a linear form), else each ray's is tested.
#[inline(always)]
fn all_ahead(c: &Closed, rays: &[Ray], ys: [i32; 2]) -> bool {
    let n = c.n;
    let (xa, xb) = (rays.first().map_or(0, |r| r.x), rays.last().map_or(0, |r| r.x));
    // (`w` of a ray at a corner's slopes.)
    let ahead = |x: i32, y: i32| c.ahead(closed_w(n, &Ray { x, y, ..Ray::OUTSIDE }));
    (ahead(xa, ys[0]) && ahead(xa, ys[1]) && ahead(xb, ys[0]) && ahead(xb, ys[1]))
        || rays.iter().all(|r| c.ahead(closed_w(n, r)))
}
