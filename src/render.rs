//! The line renderer (camera-model.md §3, §5, §6, §7).
//!
//! One ray per pixel centre, fixed point end to end, one scanline at a time
//! into a caller-provided line buffer, handed to a [`LineSink`]: RAM is
//! O(width), whatever the height.
//!
//! A [`Frame`] is prepared once per frame: the scene is moved into the camera
//! frame, the distortion table built, constants folded. Then every line runs
//! one of 16 monomorphized pixel loops, chosen per frame by which stages the
//! scene needs (distortion, vignetting, specular, perspective vs parallel
//! rays): a stage the scene does not need costs nothing, and no pixel
//! branches on configuration.
//!
//! Per-pixel values are I32F32 ([`Q`]) with saturating arithmetic: nothing
//! wraps, and a value that saturates ends as a saturated pixel. Scene ranges
//! ([`crate::scene`]) keep valid scenes clear of saturation except where the
//! physics says so (over-exposure).

use crate::distortion::Lut;
use crate::num::{quotient, Len, Norm, Wide};
use crate::scene::{Light, PixelFormat, Primitive, Scene, Shape, Q};
use crate::vignetting;
use core::ops::{Add as _, Mul as _, Sub as _};
use fixed::types::I64F64;

/// Flag bit: the pixel lies beyond the fold radius, outside the lens field
/// (its value is 0).
pub const FLAG_OUTSIDE_FIELD: u8 = 1;

/// The largest `|x̂|, |ŷ|` (undistorted) the renderer supports: 16, a
/// half-angle of 86.4°.
pub const MAX_SLOPE: i32 = 16;

/// Receives rendered lines.
pub trait LineSink {
    /// The sink's error.
    type Error;
    /// Line `y`: `pixels` holds `width × bytes_per_pixel` bytes, `flags` one
    /// byte of `FLAG_*` bits a pixel.
    fn line(&mut self, y: u16, pixels: &[u8], flags: &[u8]) -> Result<(), Self::Error>;
}

/// How the renderer forms rays (chosen by the planner; may approximate the
/// camera's model).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RenderModel {
    /// Rays from the centre of projection.
    Perspective,
    /// Parallel rays from `(x̂ Z̄, ŷ Z̄, 0)`.
    WeakPerspective {
        /// `Z̄`, metres.
        mean_depth: Len,
    },
    /// Parallel rays from `(x/m, y/m, 0)`.
    Orthographic {
        /// `m`.
        scale: Norm,
    },
}

impl RenderModel {
    /// Stage name.
    pub const fn name(&self) -> &'static str {
        match self {
            RenderModel::Perspective => "rays:perspective",
            RenderModel::WeakPerspective { .. } => "rays:weak-perspective",
            RenderModel::Orthographic { .. } => "rays:orthographic",
        }
    }
}

/// What the renderer is told to do (the planner's choice).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Options {
    /// Ray model.
    pub model: RenderModel,
    /// Distortion table entries (ignored without distortion).
    pub lut_entries: usize,
}

/// Why a frame cannot be rendered.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum RenderError {
    /// The line or flag buffer is shorter than a line.
    BufferTooSmall,
    /// An undistorted sensor corner lies beyond [`MAX_SLOPE`].
    FieldTooWide,
    /// A primitive lies at the centre of projection, or a ray model
    /// parameter is degenerate.
    Degenerate,
    /// The distortion factor `g` exceeds ±32 768 over the sensor.
    DistortionOutOfRange,
}

/// The error of [`Frame::render`]: the renderer's or the sink's.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameError<E> {
    /// Rendering failed.
    Render(RenderError),
    /// The sink failed.
    Sink(E),
}

/// Which stages a frame runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Stages {
    /// Ray model.
    pub model: RenderModel,
    /// Distortion table entries, if distortion is modelled.
    pub distortion_lut: Option<usize>,
    /// cos⁴ fall-off.
    pub vignetting: bool,
    /// Specular lobe.
    pub specular: bool,
    /// Output format.
    pub format: PixelFormat,
}

impl Stages {
    /// Stage names, in pipeline order.
    pub fn names(&self) -> heapless::Vec<&'static str, 8> {
        let mut v = heapless::Vec::new();
        let _ = v.push("pixel-to-normalized");
        if self.distortion_lut.is_some() {
            let _ = v.push("distortion-lut");
        }
        let _ = v.push(self.model.name());
        let _ = v.push("intersect");
        let _ = v.push("shade:lambertian");
        if self.specular {
            let _ = v.push("shade:specular");
        }
        if self.vignetting {
            let _ = v.push("vignetting:cos4");
        }
        let _ = v.push(match self.format {
            PixelFormat::Gray8 => "quantize:gray8",
            PixelFormat::Gray16 { .. } => "quantize:gray16",
            PixelFormat::Rgb565 => "quantize:rgb565",
        });
        v
    }
}

use crate::shading::{add, axpy, dot, mul, scale3, sub, sub3, Brdf, ShadingLight, V3};

/// A primitive in the camera frame.
#[derive(Clone, Copy, Debug)]
enum CamShape {
    /// `n̂·P = dist`.
    Plane {
        n: V3,
        dist: Q,
    },
    Sphere {
        c: V3,
        r2: Q,
        inv_r: Q,
    },
    Disc {
        n: V3,
        dist: Q,
        c: V3,
        r2: Q,
    },
    Rect {
        n: V3,
        dist: Q,
        c: V3,
        u: V3,
        v: V3,
        hu: Q,
        hv: Q,
    },
}

#[derive(Clone, Copy, Debug)]
struct CamChecker {
    origin: V3,
    u: V3,
    v: V3,
    inv_cell: Q,
    material: u8,
}

#[derive(Clone, Copy, Debug)]
struct CamPrim {
    shape: CamShape,
    material: u8,
    checker: Option<CamChecker>,
}

/// A frame prepared for rendering.
#[derive(Clone, Debug)]
pub struct Frame {
    width: u16,
    height: u16,
    format: PixelFormat,
    stages: Stages,
    /// `x̂_d` of column 0 and its step per column, I64F64 raw.
    x0: i128,
    dx: i128,
    /// `o_y / f_y` and `1 / f_y` as wide values, for `ŷ_d` per line.
    oy: Wide,
    fy: Wide,
    lut: Option<(Lut, Q)>,
    /// Parallel-ray origin scale: `Z̄` or `f/m`.
    k_origin: Q,
    prims: heapless::Vec<CamPrim, { crate::scene::MAX_PRIMITIVES }>,
    lights: heapless::Vec<ShadingLight, { crate::scene::MAX_LIGHTS }>,
    materials: [Brdf; crate::scene::MAX_MATERIALS],
    background: V3,
    /// `K π/4 (d/f)²` per channel (with the channel's full-scale factor):
    /// DN per unit radiance on the axis.
    gain: V3,
}

fn q(w: Wide) -> Q {
    w.narrow::<Q>().value
}

fn v3_world_to_cam(scene: &Scene, p: crate::frame::WorldPoint) -> V3 {
    let c = scene.camera.extrinsics.world_to_camera(p).value;
    [Q::from_num(c.x), Q::from_num(c.y), Q::from_num(c.z)]
}

/// Rotates a world direction into the camera frame (`R d`).
fn dir_to_cam(scene: &Scene, d: [Norm; 3]) -> V3 {
    let r = scene.camera.extrinsics.rotation();
    r.map(|row| {
        q(Wide::of(row[0])
            .mul(Wide::of(d[0]))
            .add(Wide::of(row[1]).mul(Wide::of(d[1])))
            .add(Wide::of(row[2]).mul(Wide::of(d[2]))))
    })
}

impl Frame {
    /// Prepares `scene` for rendering with `opts`.
    pub fn new(scene: &Scene, opts: &Options) -> Result<Frame, RenderError> {
        let intr = &scene.camera.intrinsics;
        let (w, h) = intr.size();
        let (fx, fy) = intr.focal_px();
        let (ox, oy) = intr.principal_point();
        let one = Wide::int(1);
        let inv_fx = one.checked_div(Wide::of(fx)).ok_or(RenderError::Degenerate)?;
        let x0 = Wide::of(ox).mul(inv_fx).narrow::<I64F64>().value.to_bits();
        let dx = inv_fx.narrow::<I64F64>().value.to_bits();
        let mut frame = Frame {
            width: w,
            height: h,
            format: scene.format,
            stages: Stages {
                model: opts.model,
                distortion_lut: None,
                vignetting: !matches!(opts.model, RenderModel::Orthographic { .. }),
                specular: scene.has_specular(),
                format: scene.format,
            },
            x0,
            dx,
            oy: Wide::of(oy),
            fy: Wide::of(fy),
            lut: None,
            k_origin: Q::ZERO,
            prims: heapless::Vec::new(),
            lights: heapless::Vec::new(),
            materials: [Brdf::default(); crate::scene::MAX_MATERIALS],
            background: scene.background,
            gain: [Q::ZERO; 3],
        };
        // Distortion: table over [0, u_max], u_max = min(fold, corner maximum).
        if !scene.distortion.is_none() {
            let mut u_corner = Q::ZERO;
            for (i, j) in [(0, 0), (w - 1, 0), (0, h - 1), (w - 1, h - 1)] {
                let (xd, yd) = (frame.xd(i), frame.yd(j));
                u_corner = u_corner.max(add(mul(xd, xd), mul(yd, yd)));
            }
            let fold = scene.distortion.fold_u().map(Q::saturating_from_num);
            let (u_max, limit) = match fold {
                Some(f) if f < u_corner => (f, f),
                _ => (u_corner, Q::MAX),
            };
            let lut = scene.distortion.lut(u_max, opts.lut_entries);
            if lut.saturated {
                return Err(RenderError::DistortionOutOfRange);
            }
            let lut = lut.value;
            frame.stages.distortion_lut = Some(lut.len());
            frame.lut = Some((lut, limit));
        }
        // The widest undistorted corner must stay within MAX_SLOPE.
        for (i, j) in [(0, 0), (w - 1, 0), (0, h - 1), (w - 1, h - 1)] {
            if let Some((x, y)) = frame.undistorted(i, j) {
                let lim = Q::from_num(MAX_SLOPE);
                if x.abs() > lim || y.abs() > lim {
                    return Err(RenderError::FieldTooWide);
                }
            }
        }
        frame.k_origin = match opts.model {
            RenderModel::Perspective => Q::ZERO,
            RenderModel::WeakPerspective { mean_depth } => Q::from_num(mean_depth),
            RenderModel::Orthographic { scale } => q(Wide::of(intr.focal_length())
                .checked_div(Wide::of(scale))
                .ok_or(RenderError::Degenerate)?),
        };
        // Constants: gain = K π/4 (d/f)².
        let lens = &scene.camera.lens;
        let dof = Wide::of(lens.diameter())
            .checked_div(Wide::of(lens.focal_length()))
            .ok_or(RenderError::Degenerate)?;
        for (c, g) in frame.gain.iter_mut().enumerate() {
            *g = vignetting::gain(scene.exposure, dof, scene.format.channel_scale(c));
        }
        for (m, dst) in scene.materials.iter().zip(frame.materials.iter_mut()) {
            *dst = Brdf::new(m, scene.ambient);
        }
        for p in &scene.primitives {
            let _ = frame.prims.push(cam_prim(scene, p));
        }
        for l in &scene.lights {
            let _ = frame.lights.push(match *l {
                Light::Point { position, intensity } => ShadingLight::Point {
                    p: v3_world_to_cam(scene, position),
                    i: intensity,
                },
                Light::Directional { towards, irradiance } => ShadingLight::Directional {
                    l: dir_to_cam(scene, towards),
                    e: irradiance,
                },
            });
        }
        Ok(frame)
    }

    /// The stages this frame runs.
    pub fn stages(&self) -> Stages {
        self.stages
    }

    /// Sensor size.
    pub fn size(&self) -> (u16, u16) {
        (self.width, self.height)
    }

    /// Bytes a line occupies.
    pub fn line_bytes(&self) -> usize {
        self.width as usize * self.format.bytes_per_pixel()
    }

    /// Fractional bits of the distortion table's i32 entries, if any.
    pub fn table_frac_bits(&self) -> Option<u32> {
        self.lut.as_ref().map(|(l, _)| l.entry_frac_bits())
    }

    /// Distortion table bytes (0 without distortion).
    pub fn table_bytes(&self) -> usize {
        self.lut.as_ref().map_or(0, |(l, _)| l.bytes())
    }

    #[inline(always)]
    fn xd(&self, i: u16) -> Q {
        xd_of(self.x0 - self.dx * i as i128)
    }

    fn yd(&self, j: u16) -> Q {
        quotient::<Q>(self.oy.sub(Wide::int(j as i64)), self.fy).value
    }

    /// The undistorted normalized point `(x̂, ŷ)` the renderer uses for
    /// pixel `(i, j)`, or `None` outside the lens field — the same code path
    /// as the pixel loop.
    pub fn undistorted(&self, i: u16, j: u16) -> Option<(Q, Q)> {
        let (xd, yd) = (self.xd(i), self.yd(j));
        match &self.lut {
            Some((lut, limit)) => undistort(lut, *limit, xd, yd),
            None => Some((xd, yd)),
        }
    }

    /// Renders line `j` into `pixels` (at least [`Frame::line_bytes`]) and
    /// `flags` (at least the width).
    pub fn render_line(&self, j: u16, pixels: &mut [u8], flags: &mut [u8]) -> Result<(), RenderError> {
        if pixels.len() < self.line_bytes() || flags.len() < self.width as usize {
            return Err(RenderError::BufferTooSmall);
        }
        let persp = matches!(self.stages.model, RenderModel::Perspective);
        let d = self.lut.is_some();
        let v = self.stages.vignetting;
        let s = self.stages.specular;
        // Per-frame dispatch to one monomorphized loop.
        match (d, v, s, persp) {
            (false, false, false, false) => self.line::<false, false, false, false>(j, pixels, flags),
            (false, false, false, true) => self.line::<false, false, false, true>(j, pixels, flags),
            (false, false, true, false) => self.line::<false, false, true, false>(j, pixels, flags),
            (false, false, true, true) => self.line::<false, false, true, true>(j, pixels, flags),
            (false, true, false, false) => self.line::<false, true, false, false>(j, pixels, flags),
            (false, true, false, true) => self.line::<false, true, false, true>(j, pixels, flags),
            (false, true, true, false) => self.line::<false, true, true, false>(j, pixels, flags),
            (false, true, true, true) => self.line::<false, true, true, true>(j, pixels, flags),
            (true, false, false, false) => self.line::<true, false, false, false>(j, pixels, flags),
            (true, false, false, true) => self.line::<true, false, false, true>(j, pixels, flags),
            (true, false, true, false) => self.line::<true, false, true, false>(j, pixels, flags),
            (true, false, true, true) => self.line::<true, false, true, true>(j, pixels, flags),
            (true, true, false, false) => self.line::<true, true, false, false>(j, pixels, flags),
            (true, true, false, true) => self.line::<true, true, false, true>(j, pixels, flags),
            (true, true, true, false) => self.line::<true, true, true, false>(j, pixels, flags),
            (true, true, true, true) => self.line::<true, true, true, true>(j, pixels, flags),
        }
        Ok(())
    }

    /// Renders every line through `sink`, reusing the caller's line buffers.
    pub fn render<S: LineSink>(
        &self,
        pixels: &mut [u8],
        flags: &mut [u8],
        sink: &mut S,
    ) -> Result<(), FrameError<S::Error>> {
        for j in 0..self.height {
            self.render_line(j, pixels, flags).map_err(FrameError::Render)?;
            let n = self.line_bytes();
            let (p, f) = (pixels.get(..n), flags.get(..self.width as usize));
            if let (Some(p), Some(f)) = (p, f) {
                sink.line(j, p, f).map_err(FrameError::Sink)?;
            }
        }
        Ok(())
    }

    #[inline(never)]
    fn line<const DIST: bool, const VIG: bool, const SPEC: bool, const PERSP: bool>(
        &self,
        j: u16,
        pixels: &mut [u8],
        flags: &mut [u8],
    ) {
        let bpp = self.format.bytes_per_pixel();
        let channels = self.format.channels();
        let dn_max = [0, 1, 2].map(|c| self.format.dn_max(c));
        let yd = self.yd(j);
        let mut acc = self.x0;
        for (out, flag) in pixels
            .chunks_exact_mut(bpp)
            .zip(flags.iter_mut())
            .take(self.width as usize)
        {
            let xd = xd_of(acc);
            acc -= self.dx;
            let (x, y) = if DIST {
                match &self.lut {
                    Some((lut, limit)) => match undistort(lut, *limit, xd, yd) {
                        Some(p) => p,
                        None => {
                            *flag = FLAG_OUTSIDE_FIELD;
                            out.iter_mut().for_each(|b| *b = 0);
                            continue;
                        }
                    },
                    None => (xd, yd),
                }
            } else {
                (xd, yd)
            };
            *flag = 0;
            let (o, d) = if PERSP {
                ([Q::ZERO; 3], [x, y, Q::ONE])
            } else {
                (
                    [mul(x, self.k_origin), mul(y, self.k_origin), Q::ZERO],
                    [Q::ZERO, Q::ZERO, Q::ONE],
                )
            };
            let radiance = self.trace::<SPEC, PERSP>(o, d);
            let cos4 = if VIG { vignetting::cos4(x, y) } else { Q::ONE };
            let mut dn = [0u32; 3];
            for (((dst, l), g), max) in dn
                .iter_mut()
                .zip(radiance)
                .zip(self.gain)
                .zip(dn_max)
                .take(channels)
            {
                *dst = vignetting::quantize(g, l, cos4, max);
            }
            self.format.pack(dn, out);
        }
    }

    /// Radiance (per channel) seen along the ray `o + t d`.
    #[inline]
    fn trace<const SPEC: bool, const PERSP: bool>(&self, o: V3, d: V3) -> V3 {
        let mut best = Q::MAX;
        let mut hit: Option<(usize, V3, V3)> = None; // (material, point, normal)
        for p in &self.prims {
            if let Some((t, n)) = intersect::<PERSP>(&p.shape, o, d) {
                if t < best {
                    best = t;
                    let point = axpy(t, d, o);
                    let mut m = p.material as usize;
                    if let Some(ch) = &p.checker {
                        let rel = sub3(point, ch.origin);
                        let cu = mul(dot(rel, ch.u), ch.inv_cell).to_num::<i64>();
                        let cv = mul(dot(rel, ch.v), ch.inv_cell).to_num::<i64>();
                        if (cu + cv) & 1 != 0 {
                            m = ch.material as usize;
                        }
                    }
                    hit = Some((m, point, n));
                }
            }
        }
        let Some((m, point, normal)) = hit else {
            return self.background;
        };
        let mat = self.materials.get(m).copied().unwrap_or_default();
        // Two-sided surfaces: the normal faces the viewer.
        let normal = if dot(normal, d) > Q::ZERO {
            scale3(-Q::ONE, normal)
        } else {
            normal
        };
        let view = if SPEC {
            if PERSP {
                let len = dot(d, d).checked_sqrt().unwrap_or(Q::ONE);
                let inv = Q::ONE.checked_div(len).unwrap_or(Q::ZERO);
                scale3(-inv, d)
            } else {
                [Q::ZERO, Q::ZERO, -Q::ONE]
            }
        } else {
            [Q::ZERO; 3]
        };
        crate::shading::radiance::<SPEC>(&mat, &self.lights, point, normal, view)
    }
}

/// `x̂_d` from its I64F64 accumulator.
#[inline(always)]
fn xd_of(acc: i128) -> Q {
    Q::from_bits((acc >> 32) as i64)
}

#[inline(always)]
fn undistort(lut: &Lut, limit: Q, xd: Q, yd: Q) -> Option<(Q, Q)> {
    let u = add(mul(xd, xd), mul(yd, yd));
    if u > limit {
        return None;
    }
    let g = lut.g(u);
    Some((mul(xd, g), mul(yd, g)))
}

/// Nearest hit `t > 0` of the ray with a shape, and the (unit) normal there.
#[inline]
fn intersect<const PERSP: bool>(s: &CamShape, o: V3, d: V3) -> Option<(Q, V3)> {
    match *s {
        CamShape::Plane { n, dist } => plane_t::<PERSP>(n, dist, o, d).map(|t| (t, n)),
        CamShape::Disc { n, dist, c, r2 } => {
            let t = plane_t::<PERSP>(n, dist, o, d)?;
            let rel = sub3(axpy(t, d, o), c);
            (dot(rel, rel) <= r2).then_some((t, n))
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
            let t = plane_t::<PERSP>(n, dist, o, d)?;
            let rel = sub3(axpy(t, d, o), c);
            (dot(rel, u).abs() <= hu && dot(rel, v).abs() <= hv).then_some((t, n))
        }
        CamShape::Sphere { c, r2, inv_r } => {
            // |o + t d − c|² = r²: a t² − 2 b t + cc = 0
            let oc = sub3(c, o);
            let a = if PERSP { dot(d, d) } else { Q::ONE };
            let b = dot(d, oc);
            let cc = sub(dot(oc, oc), r2);
            let disc = sub(mul(b, b), mul(a, cc));
            if disc < Q::ZERO {
                return None;
            }
            let sq = disc.checked_sqrt()?;
            let mut t = sub(b, sq).checked_div(a)?;
            if t <= Q::ZERO {
                t = add(b, sq).checked_div(a)?;
                if t <= Q::ZERO {
                    return None;
                }
            }
            let p = axpy(t, d, o);
            Some((t, scale3(inv_r, sub3(p, c))))
        }
    }
}

#[inline]
fn plane_t<const PERSP: bool>(n: V3, dist: Q, o: V3, d: V3) -> Option<Q> {
    let denom = if PERSP { dot(n, d) } else { n[2] };
    let num = if PERSP {
        dist
    } else {
        sub(dist, add(mul(n[0], o[0]), mul(n[1], o[1])))
    };
    let t = num.checked_div(denom)?;
    (t > Q::ZERO).then_some(t)
}

fn cam_prim(scene: &Scene, p: &Primitive) -> CamPrim {
    let to_q3 = |d: [Norm; 3]| dir_to_cam(scene, d);
    let (shape, origin) = match p.shape {
        Shape::Plane { point, normal } => {
            let n = to_q3(normal);
            let pc = v3_world_to_cam(scene, point);
            (CamShape::Plane { n, dist: dot(n, pc) }, pc)
        }
        Shape::Sphere { centre, radius } => {
            let c = v3_world_to_cam(scene, centre);
            let r = Q::from_num(radius);
            (
                CamShape::Sphere {
                    c,
                    r2: q(Wide::of(radius).mul(Wide::of(radius))),
                    inv_r: Q::ONE.checked_div(r).unwrap_or(Q::MAX),
                },
                c,
            )
        }
        Shape::Disc {
            centre,
            normal,
            radius,
        } => {
            let n = to_q3(normal);
            let c = v3_world_to_cam(scene, centre);
            (
                CamShape::Disc {
                    n,
                    dist: dot(n, c),
                    c,
                    r2: q(Wide::of(radius).mul(Wide::of(radius))),
                },
                c,
            )
        }
        Shape::Rectangle {
            centre,
            u_axis,
            v_axis,
            half,
        } => {
            let u = to_q3(u_axis);
            let v = to_q3(v_axis);
            let c = v3_world_to_cam(scene, centre);
            // n = u × v
            let n = [
                sub(mul(u[1], v[2]), mul(u[2], v[1])),
                sub(mul(u[2], v[0]), mul(u[0], v[2])),
                sub(mul(u[0], v[1]), mul(u[1], v[0])),
            ];
            (
                CamShape::Rect {
                    n,
                    dist: dot(n, c),
                    c,
                    u,
                    v,
                    hu: Q::from_num(half[0]),
                    hv: Q::from_num(half[1]),
                },
                c,
            )
        }
    };
    CamPrim {
        shape,
        material: p.material,
        checker: p.checker.map(|k| CamChecker {
            origin,
            u: to_q3(k.u_axis),
            v: to_q3(k.v_axis),
            inv_cell: quotient::<Q>(Wide::int(1), Wide::of(k.cell)).value,
            material: k.material,
        }),
    }
}
