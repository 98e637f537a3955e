//! The wide arithmetic: every per-pixel quantity in one [`Scalar`] (I32F32
//! for the planner's fallback, `f32` for comparison), one ray per sample.

use crate::geom::distortion::{Lut, MAX_LUT};
use crate::num::from_acc;
use crate::num::scalar::Scalar;
use crate::render::options::{
    DistortionEval, Lines, Options, RenderError, Stages, FLAG_OUTSIDE_FIELD, MAX_SLOPE,
};
use crate::render::prepare::{
    cam_prim, lens_blur, shading_light, undistort_poly, CamPrim, CamShape, Poly, Prepared,
};
use crate::render::shading::{axpy, dot, dot_k, from_q3, scale3, sub3, Brdf, ShadingLight, V3};
use crate::render::shadows::Occluders;
use crate::render::vignetting;
use crate::scene::{PixelFormat, Scene, Q};

/// The wide arithmetic's per-frame state.
#[derive(Clone, Debug)]
pub(crate) struct WideFrame<S: Scalar, const T: usize> {
    pub(crate) width: u16,
    pub(crate) height: u16,
    pub(crate) format: PixelFormat,
    pub(crate) stages: Stages,
    /// `x̂_d` of column 0 and its step per column, I64F64 raw.
    pub(crate) x0: i128,
    pub(crate) dx: i128,
    /// `ŷ_d` of line 0 and its step per line, I64F64 raw.
    pub(crate) y0: i128,
    pub(crate) dy: i128,
    /// `g` at the table's nodes, i32 entries converted per lookup (a shift
    /// in fixed point): one table serves every scalar type.
    pub(crate) lut: Option<Lut<T>>,
    /// [`Lut::scale`] in `S`.
    pub(crate) lut_scale: S,
    /// `k1`, `k2`: [`DistortionEval::Polynomial`]'s, and the relative
    /// illumination's under any evaluation.
    pub(crate) poly: [S; 2],
    /// `u = r_d²` beyond which a pixel is outside the lens field.
    pub(crate) limit: S,
    /// A calibrated lens, solved per sample in place of the polynomial.
    #[cfg(feature = "calibrated")]
    pub(crate) calibrated: Option<crate::geom::calibrated::Model<S>>,
    /// Parallel-ray origin scale: `Z̄` or `f/m`.
    pub(crate) k_origin: S,
    pub(crate) prims: heapless::Vec<CamPrim<S>, { crate::scene::MAX_PRIMITIVES }>,
    pub(crate) lights: heapless::Vec<ShadingLight<S>, { crate::scene::MAX_LIGHTS }>,
    /// The shadow tests each surface takes under each light.
    pub(crate) occluders: Occluders,
    pub(crate) materials: [Brdf<S>; crate::scene::MAX_MATERIALS],
    pub(crate) background: V3<S>,
    /// `K π/4 (d/f)²` per channel (with the channel's full-scale factor):
    /// DN per unit radiance on the axis.
    pub(crate) gain: V3<S>,
    /// Sample grid offsets from the pixel centre, `x̂_d` and `ŷ_d` (I64F64
    /// raw), and the half pixel steps (the corners).
    #[cfg_attr(not(feature = "sensor"), allow(dead_code))]
    pub(crate) sub_x: [i128; crate::render::sensor::sampling::MAX_GRID as usize],
    #[cfg_attr(not(feature = "sensor"), allow(dead_code))]
    pub(crate) sub_y: [i128; crate::render::sensor::sampling::MAX_GRID as usize],
    pub(crate) half: (i128, i128),
    /// `1/n²`.
    #[cfg_attr(not(feature = "sensor"), allow(dead_code))]
    pub(crate) inv_n2: S,
    /// Defocus: the aperture radius `d/2` and `d/(2 Z̃)` (a
    /// [`crate::render::sensor::defocus::SPIRAL`] entry shifted left by `ap_shift` is a
    /// point of the `m`-point pattern on the unit disc in I32F32 bits:
    /// times these, an aperture point's `a` and `a/Z̃`), and `1/m`.
    #[cfg_attr(not(feature = "sensor"), allow(dead_code))]
    pub(crate) ap_r: S,
    #[cfg_attr(not(feature = "sensor"), allow(dead_code))]
    pub(crate) ap_rz: S,
    #[cfg_attr(not(feature = "sensor"), allow(dead_code))]
    pub(crate) ap_shift: u32,
    #[cfg_attr(not(feature = "sensor"), allow(dead_code))]
    pub(crate) inv_m: S,
    /// The scene's noise and the stage made of it for [`Frame::set_frame_id`].
    pub(crate) noise_spec: Option<crate::scene::Noise>,
    pub(crate) noise: Option<crate::render::sensor::noise::Stage<S>>,
}

impl<S: Scalar, const T: usize> WideFrame<S, T> {
    /// A frame of no pixels. A function, not a constant: a constant this
    /// size is copied from flash (7 KB of it), a function's value is built
    /// by stores.
    #[inline(always)]
    pub(crate) fn empty() -> WideFrame<S, T> {
        WideFrame {
            width: 0,
            height: 0,
            format: PixelFormat::Gray8,
            stages: Stages::NONE,
            x0: 0,
            dx: 0,
            y0: 0,
            dy: 0,
            lut: None,
            lut_scale: S::ZERO,
            poly: [S::ZERO; 2],
            limit: S::MAX,
            #[cfg(feature = "calibrated")]
            calibrated: None,
            k_origin: S::ZERO,
            prims: heapless::Vec::new(),
            lights: heapless::Vec::new(),
            occluders: Occluders::NONE,
            materials: [Brdf::ZERO; crate::scene::MAX_MATERIALS],
            background: [S::ZERO; 3],
            gain: [S::ZERO; 3],
            sub_x: [0; crate::render::sensor::sampling::MAX_GRID as usize],
            sub_y: [0; crate::render::sensor::sampling::MAX_GRID as usize],
            half: (0, 0),
            inv_n2: S::ONE,
            ap_r: S::ZERO,
            ap_rz: S::ZERO,
            ap_shift: 0,
            inv_m: S::ONE,
            noise_spec: None,
            noise: None,
        }
    }

    /// Fills the wide arithmetic's state from the frame's preparation
    /// `p`: the sample grid's and the aperture's constants, the distortion
    /// table or polynomial in `S`, and the scene's materials, primitives and
    /// lights in the camera frame.
    #[inline(never)]
    pub(crate) fn fill(
        &mut self,
        (p, occ): (&Prepared, &Occluders),
        scene: &Scene,
        opts: &Options,
    ) -> Result<(), RenderError> {
        (self.width, self.height, self.format, self.stages) = (p.width, p.height, scene.format, p.stages);
        (self.x0, self.dx, self.y0, self.dy) = (p.x0, p.dx, p.y0, p.dy);
        #[cfg(feature = "sensor")]
        self.sensor_constants(scene, opts)?;
        let (w, h) = (self.width, self.height);
        self.noise_spec = scene.noise;
        self.noise = crate::render::sensor::noise::Stage::for_frame(scene.noise, scene.format, 0);
        self.background = from_q3(scene.background);
        // What only some frames set, reset from the previous frame; every
        // other field is set below for every frame.
        self.lut = None;
        self.lut_scale = S::ZERO;
        self.poly = [S::ZERO; 2];
        self.limit = S::MAX;
        #[cfg(feature = "calibrated")]
        {
            self.calibrated = scene.calibrated().map(|c| c.to());
        }
        self.prims.clear();
        self.lights.clear();
        self.materials = [Brdf::ZERO; crate::scene::MAX_MATERIALS];
        if let Some(d) = &p.distortion {
            self.distortion(d, scene, opts)?;
        }
        // The widest undistorted corner must stay within MAX_SLOPE (by the
        // table, where there is one: the polynomial's, `Prepared::new`).
        for (i, j) in [(0, 0), (w - 1, 0), (0, h - 1), (w - 1, h - 1)]
            .into_iter()
            .filter(|_| self.lut.is_some())
        {
            if let Some((x, y)) = self.undistorted(i, j) {
                let lim = S::from_int(MAX_SLOPE);
                if x.abs() > lim || y.abs() > lim {
                    return Err(RenderError::FieldTooWide);
                }
            }
        }
        self.occluders = *occ;
        self.k_origin = p.origin_scale.map_or(S::ZERO, S::from_q);
        self.gain = from_q3(p.gain);
        self.wide_scene(scene, opts, p.origin_scale);
        Ok(())
    }

    /// The sample grid's offsets and the aperture pattern's constants.
    #[cfg(feature = "sensor")]
    #[inline(always)]
    fn sensor_constants(&mut self, scene: &Scene, opts: &Options) -> Result<(), RenderError> {
        use core::ops::Mul as _;
        let (dx, dy) = (self.dx, self.dy);
        let n = self.stages.samples;
        self.sub_x = crate::render::sensor::sampling::scaled_offsets(dx, n);
        self.sub_y = crate::render::sensor::sampling::scaled_offsets(dy, n);
        // Half a pixel step (the corners), rounded toward −∞.
        self.half = (dx >> 1, dy >> 1);
        self.inv_n2 = S::from_q(Q::from_bits(
            1i64 << (32 - 2 * crate::render::sensor::sampling::log2(n)),
        ));
        // Defocus: the aperture radius, and it over Z̃.
        let m = opts.aperture.max(1);
        let lens = &scene.camera.lens;
        let r = crate::num::Wide::of(lens.diameter()).mul(crate::num::Wide::of(Q::from_bits(1 << 31)));
        let rz = r
            .checked_div(crate::num::Wide::of(lens.focus_distance()))
            .ok_or(RenderError::Degenerate)?;
        self.ap_r = S::from_q(crate::render::prepare::q(r));
        self.ap_rz = S::from_q(crate::render::prepare::q(rz));
        self.ap_shift = crate::render::sensor::defocus::shift(m);
        self.inv_m = S::from_q(Q::from_bits(1i64 << (32 - m.trailing_zeros())));
        Ok(())
    }

    /// The distortion polynomial `d` in `S`, or its table (`opts`' entries
    /// over `[0, u_max]`).
    #[inline(always)]
    fn distortion(&mut self, d: &Poly, scene: &Scene, opts: &Options) -> Result<(), RenderError> {
        self.limit = S::from_q(d.limit);
        self.poly = d.k.map(S::from_q);
        if opts.distortion_eval != DistortionEval::Polynomial && scene.calibrated().is_none() {
            if opts.lut_entries.clamp(2, MAX_LUT) > T {
                return Err(RenderError::TableTooLarge);
            }
            // Filled where it is used: no copy of the table on the stack.
            let lut = self.lut.get_or_insert_with(Lut::empty);
            if scene.distortion.fill_lut(d.u_max, opts.lut_entries, lut) {
                self.lut = None;
                return Err(RenderError::DistortionOutOfRange);
            }
            self.lut_scale = S::from_q(lut.scale());
            self.stages.distortion_lut = Some(lut.len());
        }
        Ok(())
    }

    /// The wide arithmetic's materials, primitives and lights, in the
    /// camera frame and its scalar.
    #[inline(always)]
    fn wide_scene(&mut self, scene: &Scene, opts: &Options, origin_scale: Option<Q>) {
        let aperture = opts.aperture > 0;
        for (m, dst) in scene.materials.iter().zip(self.materials.iter_mut()) {
            *dst = Brdf::new(m, scene.ambient).to();
        }
        let cull = !opts.keep_all_stages;
        let blur = aperture.then(|| lens_blur(scene));
        for p in &scene.primitives {
            let _ = self.prims.push(cam_prim(scene, p, origin_scale, cull, blur).to());
        }
        for l in &scene.lights {
            let _ = self.lights.push(shading_light(scene, l).to());
        }
    }

    #[inline(always)]
    fn xd_q(&self, i: u16) -> Q {
        from_acc(self.x0 - self.dx * i as i128)
    }

    #[inline(always)]
    fn yd_q(&self, j: u16) -> Q {
        from_acc(self.y0 - self.dy * j as i128)
    }

    /// The undistorted normalized point `(x̂, ŷ)` the renderer uses for
    /// pixel `(i, j)`, or `None` outside the lens field — the same code path
    /// as the pixel loop.
    pub(crate) fn undistorted(&self, i: u16, j: u16) -> Option<(S, S)> {
        let (xd, yd) = (S::from_q(self.xd_q(i)), S::from_q(self.yd_q(j)));
        match self.stages.distortion {
            Some(_) => self.undistort(xd, yd).map(|(x, y, _)| (x, y)),
            None => Some((xd, yd)),
        }
    }

    /// `(x̂_d, ŷ_d) g(u)`, or `None` beyond the fold; with a calibrated
    /// lens, its solve, and its area factor `J` (else 1: the polynomial's
    /// is [`vignetting::area_factor`]).
    #[inline(always)]
    fn undistort(&self, xd: S, yd: S) -> Option<(S, S, S)> {
        #[cfg(feature = "calibrated")]
        if let Some(m) = &self.calibrated {
            return m.undistort(xd, yd);
        }
        let with_one = |(x, y)| (x, y, S::ONE);
        if self.stages.distortion == Some(DistortionEval::Polynomial) {
            return undistort_poly(xd, yd, self.poly, self.limit).map(with_one);
        }
        let u = xd.mul(xd).add(yd.mul(yd));
        if u > self.limit {
            return None;
        }
        let g = match self.stages.distortion {
            Some(DistortionEval::Nearest) => {
                self.lut.as_ref().map_or(S::ONE, |l| l.nearest(u, self.lut_scale))
            }
            _ => self.lut.as_ref().map_or(S::ONE, |l| l.linear(u, self.lut_scale)),
        };
        Some((xd.mul(g), yd.mul(g), S::ONE))
    }

    /// Whether a calibrated lens is solved per sample.
    #[inline(always)]
    fn is_calibrated(&self) -> bool {
        #[cfg(feature = "calibrated")]
        return self.calibrated.is_some();
        #[cfg(not(feature = "calibrated"))]
        false
    }

    /// Sets the frame id the noise is keyed by.
    pub(crate) fn set_frame_id(&mut self, id: u32) {
        self.noise = crate::render::sensor::noise::Stage::for_frame(self.noise_spec, self.format, id);
    }

    #[inline(never)]
    #[cfg_attr(not(feature = "sensor"), allow(unused_variables, unused_mut))]
    pub(crate) fn line<L: Lines, const R: u8>(&self, j: u16, pixels: &mut [u8], flags: &mut [u8]) {
        let bpp = self.format.bytes_per_pixel();
        let channels = self.format.channels();
        let dn_max = [0, 1, 2].map(|c| self.format.dn_max(c));
        let yc = self.y0 - self.dy * j as i128;
        let n = self.stages.samples;
        let corners = L::WIDE_SAMPLED && n > 1 && self.stages.adaptive;
        let (hx, hy) = self.half;
        let (top, bottom) = (yc + hy, yc - hy);
        // The keys of the current pixel's left corners (adaptive rule).
        #[cfg(feature = "sensor")]
        let mut left = if corners {
            [
                self.key::<R>(self.x0 + hx, top),
                self.key::<R>(self.x0 + hx, bottom),
            ]
        } else {
            [None, None]
        };
        let mut acc = self.x0;
        let row = u32::from(j) * u32::from(self.width);
        // (Not `chunks_exact_mut(bpp)`: where the compiler keeps its
        // iterator out of line, it divides by `bpp` there, a panic path.)
        for (i, flag) in flags.iter_mut().take(self.width as usize).enumerate() {
            let Some(out) = pixels.get_mut(i * bpp..(i + 1) * bpp) else {
                break;
            };
            let xc = acc;
            acc -= self.dx;
            #[cfg(feature = "sensor")]
            let value = if !L::WIDE_SAMPLED || n <= 1 {
                self.sample_inline::<L, R>(xc, yc).map(|(v, _)| v)
            } else {
                self.area_value::<L, R>(xc, yc, (top, bottom), &mut left)
            };
            #[cfg(not(feature = "sensor"))]
            let value = self.sample_inline::<L, R>(xc, yc).map(|(v, _)| v);
            let Some(value) = value else {
                *flag = FLAG_OUTSIDE_FIELD;
                out.iter_mut().for_each(|b| *b = 0);
                continue;
            };
            *flag = 0;
            let mut dn = [0u32; 3];
            #[cfg(feature = "sensor")]
            if let Some(z) = &self.noise {
                let p = row + i as u32;
                for (c, ((dst, v), max)) in dn.iter_mut().zip(value).zip(dn_max).take(channels).enumerate() {
                    *dst = z.apply(v, p, c, max);
                }
                self.format.pack(dn, out);
                continue;
            }
            for ((dst, v), max) in dn.iter_mut().zip(value).zip(dn_max).take(channels) {
                *dst = vignetting::round_dn(v, max);
            }
            self.format.pack(dn, out);
        }
    }

    /// The value of the pixel centred at `(xc, yc)` (I64F64 raw) under the
    /// sample pattern: with the adaptive rule, its centre sample if its
    /// corners (`left` from the previous pixel, the right ones looked at
    /// here on the lines `top`, `bottom`) and centre see the same; else the
    /// grid's mean. Out of line: the one-sample loop stays lean.
    #[cfg(feature = "sensor")]
    #[inline(never)]
    fn area_value<L: Lines, const R: u8>(
        &self,
        xc: i128,
        yc: i128,
        (top, bottom): (i128, i128),
        left: &mut [Option<Key>; 2],
    ) -> Option<V3<S>> {
        if !self.stages.adaptive {
            return self.grid::<L, R>(xc, yc);
        }
        let hx = self.half.0;
        let right = [self.key::<R>(xc - hx, top), self.key::<R>(xc - hx, bottom)];
        let centre = self.sample::<L, R>(xc, yc);
        let uniform = match centre {
            Some((_, k)) => k != Key::MIXED && left.iter().chain(right.iter()).all(|c| *c == Some(k)),
            None => false,
        };
        *left = right;
        match centre {
            Some((v, _)) if uniform => Some(v),
            _ => self.grid::<L, R>(xc, yc),
        }
    }

    /// The ray of the distorted slopes `(x̂_d, ŷ_d)` (I64F64 raw): origin,
    /// direction, `d·d`, and the undistorted slopes; `None` beyond the fold.
    #[inline(always)]
    fn ray<const R: u8>(&self, xacc: i128, yacc: i128) -> Option<PixelRay<S>> {
        let (xd, yd) = (S::from_q(from_acc(xacc)), S::from_q(from_acc(yacc)));
        let (x, y, j) = if self.stages.distortion.is_some() {
            self.undistort(xd, yd)?
        } else {
            (xd, yd, S::ONE)
        };
        // Pinhole rays are also the chief rays of aperture samples.
        let (o, d) = if R != PARALLEL {
            ([S::ZERO; 3], [x, y, S::ONE])
        } else {
            (
                [x.mul(self.k_origin), y.mul(self.k_origin), S::ZERO],
                [S::ZERO, S::ZERO, S::ONE],
            )
        };
        // d·d (1 for parallel rays); for perspective rays also the
        // 1 + x̂² + ŷ² of cos⁴α (equal in fixed point, where sums are exact).
        let a = if R != PARALLEL { dot(d, d) } else { S::ONE };
        Some(PixelRay {
            o,
            d,
            a,
            xy: (x, y),
            j,
        })
    }

    /// One sample at the distorted slopes `(x̂_d, ŷ_d)` (I64F64 raw): `K E`
    /// per channel in DN before rounding, and what the ray sees; `None`
    /// beyond the fold. Out of line, for the grid and the adaptive rule (one
    /// copy in flash); the one-sample loop inlines [`WideFrame::sample_inline`].
    #[cfg(feature = "sensor")]
    #[inline(never)]
    fn sample<L: Lines, const R: u8>(&self, xacc: i128, yacc: i128) -> Option<(V3<S>, Key)> {
        self.sample_inline::<L, R>(xacc, yacc)
    }

    /// [`WideFrame::sample`], inlined.
    #[inline(always)]
    fn sample_inline<L: Lines, const R: u8>(&self, xacc: i128, yacc: i128) -> Option<(V3<S>, Key)> {
        let PixelRay {
            o,
            d,
            a,
            xy: (x, y),
            j,
        } = self.ray::<R>(xacc, yacc)?;
        #[cfg(feature = "sensor")]
        let (radiance, key) = if L::WIDE_APERTURE && R == PINHOLE && self.stages.aperture > 0 {
            self.through_aperture::<L>((x, y))
        } else if L::WIDE_SPECULAR && self.stages.specular {
            self.trace::<true, R>(o, d, a, (x, y))
        } else {
            self.trace::<false, R>(o, d, a, (x, y))
        };
        #[cfg(not(feature = "sensor"))]
        let (radiance, key) = if L::WIDE_SPECULAR && self.stages.specular {
            self.trace::<true, R>(o, d, a, (x, y))
        } else {
            self.trace::<false, R>(o, d, a, (x, y))
        };
        let cos4 = match (self.stages.vignetting, R != PARALLEL) {
            (false, _) => S::ONE,
            (true, true) => vignetting::cos4_of(a),
            (true, false) => vignetting::cos4(x, y),
        };
        // Distortion spreads or gathers the light (§5): times its area
        // factor at the distorted slopes.
        let cos4 = if !self.stages.relative_illumination {
            cos4
        } else if self.is_calibrated() {
            cos4.mul(j)
        } else {
            let (xd, yd) = (S::from_q(from_acc(xacc)), S::from_q(from_acc(yacc)));
            cos4.mul(vignetting::area_factor(xd, yd, self.poly))
        };
        let mut e = [S::ZERO; 3];
        for ((dst, l), g) in e
            .iter_mut()
            .zip(radiance)
            .zip(self.gain)
            .take(self.format.channels())
        {
            *dst = vignetting::exposure(g, l, cos4);
        }
        Some((e, key))
    }

    /// The radiance of the chief ray of undistorted slopes `(x̂, ŷ)` through
    /// the aperture (camera-model.md §8): the mean
    /// over the pattern's points `A` of the radiance along the ray from `A`
    /// through `Z̃ (x̂, ŷ, 1)`; and, for the adaptive rule, what the point
    /// sees through the aperture ([`WideFrame::blurred_key`]).
    #[cfg(feature = "sensor")]
    #[inline(never)]
    fn through_aperture<L: Lines>(&self, (x, y): (S, S)) -> (V3<S>, Key) {
        let mut sum = [S::ZERO; 3];
        let channels = self.format.channels();
        for p in crate::render::sensor::defocus::SPIRAL
            .iter()
            .take(self.stages.aperture as usize)
        {
            let u = p.map(|c| i64::from(c) << self.ap_shift);
            let (l, _) = if L::WIDE_SPECULAR && self.stages.specular {
                self.aperture_trace::<true>(u, (x, y))
            } else {
                self.aperture_trace::<false>(u, (x, y))
            };
            for (s, v) in sum.iter_mut().zip(l).take(channels) {
                *s = s.add(v);
            }
        }
        let key = if L::WIDE_SAMPLED && self.stages.adaptive {
            self.blurred_key((x, y))
        } else {
            Key::NOTHING
        };
        (sum.map(|s| s.mul(self.inv_m)), key)
    }

    /// What the ray at the distorted slopes `(x̂_d, ŷ_d)` (I64F64 raw) sees
    /// (through the aperture: [`WideFrame::blurred_key`]); `None` beyond
    /// the fold.
    #[cfg(feature = "sensor")]
    #[inline(never)]
    fn key<const R: u8>(&self, xacc: i128, yacc: i128) -> Option<Key> {
        let PixelRay { o, d, a, xy, .. } = self.ray::<R>(xacc, yacc)?;
        if R == PINHOLE && self.stages.aperture > 0 {
            return Some(self.blurred_key(xy));
        }
        Some(self.look::<R>(o, d, a, xy).map_or(Key::NOTHING, |s| Key {
            shade: self.shadowed(&s),
            ..s.key
        }))
    }

    /// What the point of undistorted slopes `(x̂, ŷ)` sees through the
    /// aperture, for the adaptive rule: its chief ray's
    /// key if the rays from the aperture's rim ([`RIM`]) through the same
    /// point in focus see the same, else [`Key::MIXED`]. The rim's rays
    /// bound the blur circle at every depth, so the rule follows the
    /// blurred extent of content, not its sharp edge (camera-model.md §7).
    #[cfg(feature = "sensor")]
    #[inline(never)]
    fn blurred_key(&self, (x, y): (S, S)) -> Key {
        // (Traced as the aperture's rays are, shading and all, the chief
        // ray as the one from the aperture's centre: a look of their own
        // would be another copy of the primitives' passes in flash.)
        let chief = self.aperture_trace::<false>([0, 0], (x, y)).1;
        if RIM
            .iter()
            .any(|u| self.aperture_trace::<false>(*u, (x, y)).1 != chief)
        {
            return Key::MIXED;
        }
        chief
    }

    /// What the ray from aperture point `u d/2` (`u` on the unit disc,
    /// I32F32 bits) through the focused point of undistorted slopes
    /// `(x̂, ŷ)` sees: its radiance and key (camera-model.md §8).
    #[cfg(feature = "sensor")]
    #[inline(never)]
    fn aperture_trace<const SPEC: bool>(&self, u: [i64; 2], (x, y): (S, S)) -> (V3<S>, Key) {
        let [ux, uy] = u.map(|c| S::from_q(Q::from_bits(c)));
        let o = [ux.mul(self.ap_r), uy.mul(self.ap_r), S::ZERO];
        let d = [x.sub(ux.mul(self.ap_rz)), y.sub(uy.mul(self.ap_rz)), S::ONE];
        self.trace::<SPEC, APERTURE>(o, d, dot(d, d), (x, y))
    }

    /// The mean of the `n×n` grid of the pixel centred at `(xc, yc)`
    /// (I64F64 raw); `None` if any sample lies beyond the fold.
    #[cfg(feature = "sensor")]
    #[inline(never)]
    fn grid<L: Lines, const R: u8>(&self, xc: i128, yc: i128) -> Option<V3<S>> {
        let n = self.stages.samples as usize;
        let mut sum = [S::ZERO; 3];
        for oy in self.sub_y.iter().take(n) {
            for ox in self.sub_x.iter().take(n) {
                // Pixel coordinates grow as x̂_d, ŷ_d fall.
                let (e, _) = self.sample::<L, R>(xc - ox, yc - oy)?;
                for (s, v) in sum.iter_mut().zip(e) {
                    *s = s.add(v);
                }
            }
        }
        Some(sum.map(|s| s.mul(self.inv_n2)))
    }

    /// The nearest primitive the ray `o + t d` meets (`a = d·d`, `(x̂, ŷ)`
    /// its undistorted slopes), with the material at the hit.
    #[inline(always)]
    fn look<const R: u8>(&self, o: V3<S>, d: V3<S>, a: S, (x, y): (S, S)) -> Option<Seen<S>> {
        let mut nearest: Option<(usize, &CamPrim<S>, Hit<S>)> = None;
        for (i, p) in self.prims.iter().enumerate() {
            if let Some(b) = &p.bounds {
                if x < b[0] || x > b[1] || y < b[2] || y > b[3] {
                    continue;
                }
            }
            if let Some(h) = intersect::<S, R>(&p.shape, o, d, a) {
                if h.t < nearest.as_ref().map_or(S::MAX, |(_, _, b)| b.t) {
                    nearest = Some((i, p, h));
                }
            }
        }
        let (i, p, hit) = nearest?;
        // The point and the texture of the nearest hit only.
        let point = hit.point.unwrap_or_else(|| axpy(hit.t, d, o));
        let mut m = p.material as usize;
        let mut cell = (0, 0);
        if let Some(ch) = &p.checker {
            let rel = sub3(point, ch.origin);
            let cu = dot_k(ch.u, rel).mul(ch.inv_cell).floor_int();
            let cv = dot_k(ch.v, rel).mul(ch.inv_cell).floor_int();
            if (cu + cv) & 1 != 0 {
                m = ch.material as usize;
            }
            cell = (cu, cv);
        }
        Some(Seen {
            hit,
            point,
            material: m,
            key: Key {
                prim: i as u8,
                cell,
                shade: 0,
            },
        })
    }

    /// Radiance (per channel) seen along the ray `o + t d`, `a = d·d`, of
    /// the undistorted slopes `(x̂, ŷ)`, and what it sees.
    #[inline]
    fn trace<const SPEC: bool, const R: u8>(&self, o: V3<S>, d: V3<S>, a: S, xy: (S, S)) -> (V3<S>, Key) {
        let Some(seen) = self.look::<R>(o, d, a, xy) else {
            return (self.background, Key::NOTHING);
        };
        let Some(mat) = self.materials.get(seen.material) else {
            return (self.background, seen.key);
        };
        let shade = self.shadowed(&seen);
        let hit = seen.hit;
        let normal = hit.facing();
        let view = if SPEC {
            if R != PARALLEL {
                let len = a.sqrt().unwrap_or(S::ONE);
                let inv = S::ONE.div(len).unwrap_or(S::ZERO);
                scale3(inv.neg(), d)
            } else {
                [S::ZERO, S::ZERO, S::ONE.neg()]
            }
        } else {
            [S::ZERO; 3]
        };
        let l = crate::render::shading::radiance::<S, SPEC>(
            mat,
            &self.lights,
            seen.point,
            normal,
            view,
            self.format.channels(),
            shade,
        );
        (l, Key { shade, ..seen.key })
    }

    /// The lights a seen point does not receive (bit `i`: light `i`), by
    /// the frame's shadow tests ([`crate::render::shadows`]).
    #[inline(always)]
    fn shadowed(&self, seen: &Seen<S>) -> u8 {
        if cfg!(not(feature = "shadows")) || !self.stages.shadows {
            return 0;
        }
        crate::render::shadows::shadowed(
            &self.prims,
            &self.lights,
            &self.occluders.for_surface(seen.key.prim as usize),
            seen.point,
            seen.hit.facing(),
        )
    }
}

/// Rays from the centre of projection, `o = 0`, `d = (x̂, ŷ, 1)`: the
/// const parameter `R` of the per-sample functions.
pub(crate) const PINHOLE: u8 = 0;
/// Parallel rays, `o = (k x̂, k ŷ, 0)`, `d = (0, 0, 1)`.
pub(crate) const PARALLEL: u8 = 1;
/// Rays through the aperture (camera-model.md §8): `o = (a_x, a_y, 0)`,
/// `d = (x̂ − a_x/Z̃, ŷ − a_y/Z̃, 1)`; a sample's chief ray is a pinhole ray
/// (the pixel loop runs as [`PINHOLE`]).
#[cfg_attr(not(feature = "sensor"), allow(dead_code))]
const APERTURE: u8 = 2;

/// A sample's ray: origin, direction, `d·d`, the undistorted slopes, and
/// a calibrated lens's area factor there (1 otherwise).
struct PixelRay<S> {
    o: V3<S>,
    d: V3<S>,
    a: S,
    xy: (S, S),
    j: S,
}

/// What a ray sees, for the adaptive sampling rule: the primitive (255:
/// none), on a textured one the texture cell, and the lights shadowed there.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Key {
    prim: u8,
    cell: (i64, i64),
    shade: u8,
}

impl Key {
    const NOTHING: Key = Key {
        prim: u8::MAX,
        cell: (0, 0),
        shade: 0,
    };
    /// Through the aperture, a point whose rim rays see something else
    /// than its chief ray ([`WideFrame::blurred_key`]): never uniform. (No
    /// primitive has index 254: scenes hold at most
    /// [`crate::scene::MAX_PRIMITIVES`].)
    #[cfg_attr(not(feature = "sensor"), allow(dead_code))]
    const MIXED: Key = Key {
        prim: u8::MAX - 1,
        cell: (0, 0),
        shade: 0,
    };
}

/// The aperture's rim at the angles `kπ/4`, `k = 0…7`, on the unit circle
/// (I32F32 bits; `√½` rounded): the rays the adaptive rule traces through
/// the aperture ([`WideFrame::blurred_key`]; docs/sensor.md).
#[cfg_attr(not(feature = "sensor"), allow(dead_code))]
const RIM: [[i64; 2]; 8] = {
    const ONE: i64 = 1 << 32;
    const H: i64 = 3_037_000_500;
    [
        [ONE, 0],
        [H, H],
        [0, ONE],
        [-H, H],
        [-ONE, 0],
        [-H, -H],
        [0, -ONE],
        [H, -H],
    ]
};

/// A ray's nearest hit with the material there.
struct Seen<S> {
    hit: Hit<S>,
    point: V3<S>,
    material: usize,
    key: Key,
}

impl<S: Scalar> Hit<S> {
    /// The unit normal towards the viewer (surfaces are two-sided).
    #[inline(always)]
    fn facing(&self) -> V3<S> {
        if self.away {
            self.n.map(S::neg)
        } else {
            self.n
        }
    }
}

/// A ray's hit on a shape.
struct Hit<S> {
    /// Ray parameter, > 0.
    t: S,
    /// Unit normal.
    n: V3<S>,
    /// The normal faces away from the viewer (`n̂·d > 0`).
    away: bool,
    /// `o + t d`, if the test computed it.
    point: Option<V3<S>>,
}

/// Nearest hit `t > 0` of the ray with a shape. `a = d·d` (1 for parallel
/// rays), computed once per ray.
#[inline]
fn intersect<S: Scalar, const R: u8>(s: &CamShape<S>, o: V3<S>, d: V3<S>, a: S) -> Option<Hit<S>> {
    // A flat shape's hit: n̂·d is the plane's denominator.
    let flat = |n, (t, denom): (S, S), point| Hit {
        t,
        n,
        away: denom > S::ZERO,
        point,
    };
    match *s {
        CamShape::Plane { n, dist } => plane_t::<S, R>(n, dist, o, d).map(|td| flat(n, td, None)),
        CamShape::Disc { n, dist, c, r2 } => {
            let td = plane_t::<S, R>(n, dist, o, d)?;
            let p = axpy(td.0, d, o);
            let rel = sub3(p, c);
            (dot(rel, rel) <= r2).then(|| flat(n, td, Some(p)))
        }
        CamShape::Rect {
            n,
            dist,
            c,
            u,
            v,
            hu,
            hv,
        } => {
            let td = plane_t::<S, R>(n, dist, o, d)?;
            let p = axpy(td.0, d, o);
            let rel = sub3(p, c);
            (dot_k(u, rel).abs() <= hu && dot_k(v, rel).abs() <= hv).then(|| flat(n, td, Some(p)))
        }
        CamShape::Sphere { c, r2, inv_r } => {
            // |o + t d − c|² = r²: a t² − 2 b t + cc = 0 with b = d·oc,
            // cc = |oc|² − r². The discriminant b² − a cc is computed as
            // a r² − |d × oc|² (Lagrange's identity): without the
            // cancellation of b² against a |oc|², its rounding next to the
            // silhouette is r/|c| of the other form's.
            let (b, disc) = if R != PARALLEL {
                // From an aperture point, the centre relative to it.
                let c = if R == APERTURE { sub3(c, o) } else { c };
                let x = [
                    d[1].mul(c[2]).sub(d[2].mul(c[1])),
                    d[2].mul(c[0]).sub(d[0].mul(c[2])),
                    d[0].mul(c[1]).sub(d[1].mul(c[0])),
                ];
                (dot(d, c), a.mul(r2).sub(dot(x, x)))
            } else {
                // d = (0, 0, 1): b = oc_z, disc = r² − oc_x² − oc_y².
                let oc = sub3(c, o);
                (oc[2], r2.sub(oc[0].mul(oc[0])).sub(oc[1].mul(oc[1])))
            };
            if disc < S::ZERO {
                return None;
            }
            let sq = disc.sqrt()?;
            let mut t = b.sub(sq).div(a)?;
            if t <= S::ZERO {
                t = b.add(sq).div(a)?;
                if t <= S::ZERO {
                    return None;
                }
            }
            let p = axpy(t, d, o);
            let n = scale3(inv_r, sub3(p, c));
            Some(Hit {
                t,
                n,
                away: dot(n, d) > S::ZERO,
                point: Some(p),
            })
        }
    }
}

#[inline]
/// `t > 0` and `n̂·d` where the ray meets the plane `n̂·P = dist`.
fn plane_t<S: Scalar, const R: u8>(n: V3<S>, dist: S, o: V3<S>, d: V3<S>) -> Option<(S, S)> {
    let denom = if R != PARALLEL { dot_k(n, d) } else { n[2] };
    let num = if R == PINHOLE {
        dist
    } else {
        // n_x o_x + n_y o_y (o_z = 0).
        dist.sub(dot_k([n[0], n[1], S::ZERO], o))
    };
    let t = num.div(denom)?;
    (t > S::ZERO).then_some((t, denom))
}
