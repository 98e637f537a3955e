//! The cost model: M3 instructions a pixel, linear in the scene's
//! features, with coefficients fitted to QEMU counts (`host-sim costfit`).

use super::closed_mean::closed_mean_skipped;
use super::error_model::edge_fraction;
use super::geometry::Geometry;
use crate::render::{Arithmetic, ClosedMean, DistortionEval, Options};
use crate::scene::{Light, Scene, Shape};
use crate::Model;

/// The scene's features a cost prediction is linear in.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Features {
    /// Primitives by kind: planes, spheres, discs, rectangles.
    pub planes: f64,
    /// Spheres.
    pub spheres: f64,
    /// Discs.
    pub discs: f64,
    /// Rectangles.
    pub rects: f64,
    /// Textured (checkered) primitives.
    pub checkers: f64,
    /// Point lights.
    pub point_lights: f64,
    /// Directional lights.
    pub dir_lights: f64,
    /// 1 if distortion is evaluated by the polynomial.
    pub poly: f64,
    /// 1 if by a table.
    pub table: f64,
    /// 1 if any material has a specular lobe (the lobe's code in the
    /// loop).
    pub specular: f64,
    /// Fraction of the sensor whose rays first meet a primitive with a
    /// lobe (sampled, as `coverage`): the pixels that evaluate it.
    pub lobe_area: f64,
    /// Colour channels beyond the first (2 for RGB565).
    pub extra_channels: f64,
    /// 1 for parallel rays.
    pub parallel: f64,
    /// Fraction of the sensor that sees a primitive (a sampled estimate):
    /// the lights', textures' and lobe's terms are per shaded pixel, so
    /// they are scaled by it.
    pub coverage: f64,
    /// Sum over the bounded primitives of the fraction of the sensor each
    /// covers (sampled): where a primitive is tested for every pixel, not
    /// culled by its screen bound.
    pub bounded_area: f64,
    /// Channels that draw sensor noise (the scene's channels if it has
    /// noise, else 0): the noise stage runs on every pixel in the field.
    pub noise_channels: f64,
    /// Fraction of the sensor shaded in closed form (the fast arithmetic's
    /// one-sample loop: a plane's pixels that see nothing else; a sampled
    /// estimate), alone and times [`Features::closed_lights`].
    pub closed: f64,
    /// Point lights on the side of that plane the camera sees: the closed
    /// form's terms (`mix32::Closed`'s lights; with none, its sum is one
    /// constant, `Mix32::closed_flat`). 0 without such a plane.
    pub closed_lights: f64,
    /// Sum over the flat primitives facing the camera of the fraction of
    /// the sensor whose rays hit each (sampled): their rays take one plane
    /// `t` a chunk (`mix32::flat_pass`), not a reciprocal each — but the
    /// plane shaded in closed form where [`Features::closed`] counts.
    pub facing_area: f64,
    /// [`Features::closed`] times the share of its light terms the
    /// interpolation (`Options::closed_mean`) leaves out, in units of the
    /// pairs' share (`closed_mean_skipped`): 0 without it (or without
    /// exactly one light on the plane's side, [`Features::closed_lights`],
    /// the only case it runs), 1 with `Pairs`, 22/15 with `Quads`, 25/15
    /// with `Octs`.
    pub closed_mean: f64,
    /// Fraction of the sensor whose rays first meet a flat primitive
    /// without a lobe, in a scene lit by directional lights alone (sampled):
    /// its shading is kept from hit to hit (`Mix32::shade_flat`) — but
    /// the plane shaded in closed form where [`Features::closed`] counts.
    pub flat_area: f64,
    /// 1 where a fast loop makes every ray of a line: the sampled and
    /// aperture loops always, the one-sample loop where the principal
    /// point is off the sensor's centre across
    /// ([`crate::geom::intrinsics::Intrinsics::is_centred_x`]), so no column's
    /// rays are another's mirrored (the right half's rays, distorted, are
    /// otherwise the left half's). Alone and times [`Features::poly`]: a
    /// sample's cost is one sample's ([`SampleCost`]) as the loop that
    /// mirrors nothing pays it.
    pub unmirrored: f64,
    /// 1 for an orthographic camera: parallel rays without the `cos⁴α`
    /// stage (weak perspective keeps it).
    pub orthographic: f64,
}

impl Features {
    /// The features of `scene` rendered with `opts` (what the cost model's
    /// calibration measures: `host-sim costfit`).
    pub fn of_options(scene: &Scene, opts: &Options) -> Features {
        let distortion =
            (!scene.distortion.is_none() || opts.keep_all_stages).then_some(opts.distortion_eval);
        let fast = opts.arithmetic == Arithmetic::Fast;
        let closed = fast && opts.samples <= 1 && opts.aperture == 0;
        let g = Geometry::of(scene, opts.model);
        let mean = if closed { opts.closed_mean } else { ClosedMean::Off };
        Features::of(scene, &g, distortion, fast, closed, mean)
    }

    /// The features of `scene` rendered with `distortion` and `g`'s rays,
    /// in the `fast` arithmetic or not, the plane in `closed` form (with
    /// its `mean`: the fast one-sample loop).
    // Out of line: planning runs once a frame; keeping it small saves flash.
    #[inline(never)]
    pub(super) fn of(
        scene: &Scene,
        g: &Geometry,
        distortion: Option<DistortionEval>,
        fast: bool,
        closed: bool,
        mean: ClosedMean,
    ) -> Features {
        let mut f = Features::default();
        for (p, q) in scene.primitives.iter().zip(&g.prims) {
            // A primitive no ray can meet is tested on no chunk.
            if q.unseen {
                continue;
            }
            match p.shape {
                Shape::Plane { .. } => f.planes += 1.0,
                Shape::Sphere { .. } => f.spheres += 1.0,
                Shape::Disc { .. } => f.discs += 1.0,
                Shape::Rectangle { .. } => f.rects += 1.0,
            }
            if p.checker.is_some() {
                f.checkers += 1.0;
            }
        }
        for l in &scene.lights {
            match l {
                Light::Point { .. } => f.point_lights += 1.0,
                Light::Directional { .. } => f.dir_lights += 1.0,
            }
        }
        match distortion {
            Some(DistortionEval::Polynomial) => f.poly = 1.0,
            Some(_) => f.table = 1.0,
            None => {}
        }
        f.specular = if scene.has_specular() { 1.0 } else { 0.0 };
        f.lobe_area = g.lobe_area;
        f.extra_channels = (scene.format.channels() - 1) as f64;
        f.parallel = if g.origin_scale.is_some() { 1.0 } else { 0.0 };
        f.coverage = g.coverage;
        f.bounded_area = g.bounded_area;
        f.noise_channels = if scene.noise.is_some() {
            scene.format.channels() as f64
        } else {
            0.0
        };
        f.closed = if closed { g.closed_area } else { 0.0 };
        f.closed_lights = g.closed_lights() as f64;
        // The mean is taken under one light on the plane's side alone
        // (`Mix32::closed_run`).
        f.closed_mean = if f.closed_lights == 1.0 {
            f.closed * closed_mean_skipped(mean)
        } else {
            0.0
        };
        // The plane shaded in closed form takes no `t` where it is.
        f.facing_area = g.facing_area + if closed { 0.0 } else { g.closed_facing_area };
        f.flat_area = g.flat_area + if closed { 0.0 } else { g.closed_flat_area };
        // (The loop that mirrors is the one that shades the plane in
        // closed form, `closed`; the fast sampled and aperture loops make
        // every ray.)
        f.unmirrored = if fast && !(closed && scene.camera.intrinsics.is_centred_x()) {
            1.0
        } else {
            0.0
        };
        f.orthographic = if matches!(scene.camera.model, Model::Orthographic { .. }) {
            1.0
        } else {
            0.0
        };
        f
    }

    /// As a vector, in [`CostModel::coef`]'s order (the constant first).
    pub fn to_array(&self) -> [f64; COST_TERMS] {
        let c = self.coverage;
        [
            1.0,
            self.planes,
            self.spheres,
            self.discs,
            self.rects,
            self.checkers * c,
            self.point_lights * c,
            self.dir_lights * c,
            self.poly,
            self.table,
            self.specular,
            self.extra_channels,
            self.parallel,
            c,
            self.bounded_area,
            self.bounded_area * self.parallel,
            self.noise_channels,
            self.closed,
            self.closed * self.closed_lights,
            self.lobe_area,
            self.facing_area,
            self.closed_mean,
            self.flat_area,
            self.unmirrored,
            self.unmirrored * self.poly,
            self.orthographic,
        ]
    }
}

/// Terms of the cost model.
pub const COST_TERMS: usize = 26;

/// M3 instructions a pixel as a linear function of [`Features`] (one
/// sample a pixel), times what the pixel's samples cost ([`SampleCost`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CostModel {
    /// Coefficients, in [`Features::to_array`]'s order.
    pub coef: [f64; COST_TERMS],
    /// A pixel's samples, as a multiple of one sample.
    pub samples: SampleCost,
}

/// What a pixel takes beyond one sample at its centre: the terms of
/// [`SampleCost`].
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Samples {
    /// Samples of the pixel's area: 1 for one sample; `n²` for an `n×n`
    /// grid on every pixel; with the adaptive rule 1 (the centre) plus `n²`
    /// times the estimated fraction of pixels an edge crosses.
    pub grid: f64,
    /// 1 where the adaptive rule looks at the pixel's corners, else 0.
    pub corners: f64,
    /// Aperture points each sample is lit through (0: the chief ray).
    pub aperture: f64,
    /// Through the aperture, the share of the pixels whose rays are traced
    /// through every primitive at every point (1 in the wide arithmetic;
    /// in the fast one, from its frame: `mix32::Mix32::aperture_classes`)...
    #[serde(default = "all")]
    pub traced: f64,
    /// ... and of those tested against one rectangle alone (the fast
    /// loop's). The rest take their chief ray's sum.
    #[serde(default)]
    pub only: f64,
    /// The primitives some ray can meet (those [`Features`] counts) where
    /// a pixel takes more than one sample: what a sample may test.
    #[serde(default)]
    pub prims: f64,
}

/// [`Samples::traced`] where a calibration file has none (written before
/// it): every pixel traced.
pub(super) fn all() -> f64 {
    1.0
}

impl Samples {
    /// One sample at the pixel's centre, through the pinhole.
    pub const ONE: Samples = Samples {
        grid: 1.0,
        corners: 0.0,
        aperture: 0.0,
        traced: 1.0,
        only: 0.0,
        prims: 0.0,
    };

    /// These terms for `arithmetic`, with the fast loop's aperture
    /// `shares` (the wide loop traces every ray).
    pub(super) fn with(self, arithmetic: Arithmetic, shares: Shares) -> Samples {
        let s = match arithmetic {
            Arithmetic::Fast if self.aperture > 0.0 => shares,
            _ => Shares::TRACED,
        };
        Samples {
            traced: s.traced,
            only: s.only,
            ..self
        }
    }

    /// The terms of `scene` rendered with `opts` (what `host-sim costfit`
    /// records with each measurement).
    pub fn of_options(scene: &Scene, opts: &Options) -> Samples {
        let g = Geometry::of(scene, opts.model);
        let blur_px = if opts.aperture > 0 {
            let edge_budget = scene
                .sampling
                .map_or(0.5, |s| crate::num::FixedF64::f64(s.edge_error_px));
            super::error_model::defocus(scene, &g, edge_budget).blur_px
        } else {
            0.0
        };
        let s = Samples::of(scene, &g, (opts.samples, opts.adaptive), (opts.aperture, blur_px));
        let shares = match opts.arithmetic {
            Arithmetic::Fast => fast_shares(scene, opts),
            Arithmetic::Wide => Shares::TRACED,
        };
        s.with(opts.arithmetic, shares)
    }

    /// The terms of an `n×n` grid (`adaptive`: under the adaptive rule)
    /// with `aperture` points, content blurred by up to `blur_px`: through
    /// the aperture the rule takes the grid wherever the blur circle
    /// reaches an edge, a band `1 + blur_px` pixels wide along it. Out of
    /// line: planning runs once a frame; keeping it small saves flash.
    #[inline(never)]
    pub(super) fn of(
        scene: &Scene,
        g: &Geometry,
        (n, adaptive): (u8, bool),
        (aperture, blur_px): (u16, f64),
    ) -> Samples {
        let n2 = f64::from(n) * f64::from(n);
        let widen = if aperture > 0 { 1.0 + blur_px.min(1e6) } else { 1.0 };
        let (grid, corners) = match (n, adaptive) {
            (0 | 1, _) => (1.0, 0.0),
            (_, false) => (n2, 0.0),
            (_, true) => (1.0 + n2 * (edge_fraction(scene, g, false) * widen).min(1.0), 1.0),
        };
        // (Not for one sample through the pinhole, whose cost is the
        // features' alone.)
        let prims = if grid == 1.0 && corners == 0.0 && aperture == 0 {
            0.0
        } else {
            g.prims.iter().filter(|p| !p.unseen).count() as f64
        };
        Samples {
            grid,
            corners,
            aperture: f64::from(aperture),
            prims,
            ..Samples::ONE
        }
    }

    /// As arrays, in [`SampleCost`]'s order: the grid's terms (1 on every
    /// pixel, 1 with the adaptive rule, samples — times one sample's cost
    /// —, samples, and samples times primitives) and the aperture's (1 and
    /// points times the share traced, which multiply the grid's cost;
    /// points times the share tested against one rectangle, and points).
    pub fn terms(&self) -> ([f64; 5], [f64; 4]) {
        let m = self.aperture;
        (
            [
                1.0 - self.corners,
                self.corners,
                self.grid,
                self.grid,
                self.grid * self.prims,
            ],
            [1.0, m * self.traced, m * self.only, m],
        )
    }
}

/// What a pixel's [`Samples`] cost, given one sample's cost `one`
/// ([`CostModel::predict`] of the scene's features): a grid on every pixel
/// `grid[0] + samples · (grid[2] · one + grid[3] + grid[4] · prims)`, with
/// the adaptive rule `grid[1] + samples · (…)` (the constants, in
/// instructions: the sampled loop's own work a pixel and the corner looks,
/// much the same whatever the scene; per sample, the scene's cost in a
/// loop that neither mirrors rays nor shades a plane in closed form, a
/// sample's own work, and its tests of the primitives, which a background
/// sample makes too), times the aperture's
/// `aperture[0] + aperture[1] · points · traced`, plus `points ·
/// (aperture[2] · only + aperture[3])` instructions a sample (`traced`,
/// `only`: the shares of the pixels whose rays are traced through every
/// primitive, and tested against one rectangle alone, [`Samples`]; a
/// traced ray costs as the scene's content, a ray against one rectangle
/// and a point's own work the same whatever the scene); `one` for one
/// sample through the pinhole. Fitted per arithmetic by `host-sim
/// costfit` to QEMU counts of calibration scenes rendered with sample
/// grids and aperture points.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SampleCost {
    /// The grid's constant on every pixel and with the adaptive rule (M3
    /// instructions a pixel), and its cost per sample: times one sample's,
    /// in instructions, and in instructions a primitive.
    pub grid: [f64; 5],
    /// The aperture's constant and per point of a pixel traced (times the
    /// grid's cost); per point of a pixel tested against one rectangle,
    /// and per point of every pixel (M3 instructions a sample).
    pub aperture: [f64; 4],
}

impl SampleCost {
    /// No overhead, each grid sample at one sample's cost, the aperture
    /// free: the stand-in of a model of the features alone (`host-sim
    /// costfit`'s first step, which predicts one sample only).
    pub const ONE: SampleCost = SampleCost {
        grid: [0.0, 0.0, 1.0, 0.0, 0.0],
        aperture: [1.0, 0.0, 0.0, 0.0],
    };

    /// The cost of `s`, M3 instructions a pixel, for one sample's `one`.
    pub fn cost(&self, one: f64, s: &Samples) -> f64 {
        let (fixed, per_one) = self.affine(s);
        fixed + per_one * one
    }

    /// [`SampleCost::cost`] over one sample's cost, from the total `cost`
    /// (`cost` is affine in one sample's, so that is recovered from it);
    /// 1 where it is not positive.
    pub fn factor(&self, cost: f64, s: &Samples) -> f64 {
        let (fixed, per_one) = self.affine(s);
        let one = (cost - fixed) / per_one;
        if one > 0.0 && one.is_finite() {
            cost / one
        } else {
            1.0
        }
    }

    /// [`SampleCost::cost`] as `fixed + per_one · one`: the grid's constant
    /// and its samples (one sample alone: 0 and 1), both times the
    /// aperture's factor (1 through the pinhole).
    pub(super) fn affine(&self, s: &Samples) -> (f64, f64) {
        let (g, a) = s.terms();
        let (fixed, per_one) = if s.grid == 1.0 && s.corners == 0.0 {
            (0.0, 1.0)
        } else {
            let [c0, c1, c2, c3, c4] = self.grid;
            (c0 * g[0] + c1 * g[1] + c3 * g[3] + c4 * g[4], c2 * g[2])
        };
        if s.aperture == 0.0 {
            return (fixed, per_one);
        }
        let [a0, a1, a2, a3] = self.aperture;
        let k = a0 * a[0] + a1 * a[1];
        (fixed * k + (a2 * a[2] + a3 * a[3]) * s.grid, per_one * k)
    }
}

/// `Σ aᵢ bᵢ` over the shorter of the two (missing terms count as 0).
pub(super) fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

impl CostModel {
    /// The fitted model of an arithmetic (`host-sim costfit` fits these to
    /// QEMU counts and reports the fit).
    pub const fn of(a: Arithmetic) -> CostModel {
        match a {
            Arithmetic::Fast => FAST_COST,
            Arithmetic::Wide => WIDE_COST,
        }
    }

    /// Predicted M3 instructions a pixel.
    pub fn predict(&self, f: &Features) -> f64 {
        self.predict_terms(&f.to_array())
    }

    /// Predicted M3 instructions a pixel from the terms themselves, in
    /// [`Features::to_array`]'s order (missing terms count as 0).
    pub fn predict_terms(&self, terms: &[f64]) -> f64 {
        dot(&self.coef, terms)
    }
}

/// The fast arithmetic's cost model (M3 instructions a pixel), fitted by
/// `host-sim costfit` to QEMU counts of the calibration scenes
/// (`docs/cost-calibration.json`; `tests/planner.rs` refits it).
pub const FAST_COST: CostModel = CostModel {
    coef: [
        90.4, 22.7, 5.5, 9.9, -1.0, 13.6, 5.8, 1.5, 33.9, 0.0, 19.0, 37.2, 23.0, 277.6, 29.2, 20.7, 144.3,
        -317.3, 100.0, 228.9, -69.3, -45.1, -158.0, 16.7, 30.3, -34.9,
    ],
    samples: SampleCost {
        grid: [591.865, 193.939, 0.786, 52.538, 4.857],
        aperture: [2.034, 0.580, 80.496, 66.363],
    },
};

/// The wide (I32F32) arithmetic's cost model (M3 instructions a pixel),
/// fitted with [`FAST_COST`].
pub const WIDE_COST: CostModel = CostModel {
    coef: [
        830.1, 334.2, 47.9, -29.1, -74.7, 119.1, 1403.1, 156.0, 623.2, 686.4, 1395.1, 225.7, 4.9, 106.3,
        952.5, -61.6, 803.0, 0.0, 0.0, 446.2, -118.2, 0.0, -1.5, 0.0, 0.0, -284.3,
    ],
    samples: SampleCost {
        grid: [274.509, 1575.457, 0.998, 0.000, 69.887],
        aperture: [0.480, 0.878, 0.000, 0.000],
    },
};

/// The shadow stage: M3 instructions a shadow test (one occluder, one
/// light, one sample) in the wide arithmetic, or in the fast one a
/// pre-test and an exact test (the tests the pre-test leaves, the
/// planner's survey counts), and a shaded sample's overhead where
/// any surface takes one (the closed form left, the adaptive rule's keys
/// tested). Fitted by least squares to the M3 counts of the shipped
/// scenes that take tests (`host-sim hil --board lm3s6965evb`: standard,
/// spheres-specular, low-light, wide-vignetting, shallow-target; shadows
/// with `--scene`), each count less its prediction without this term,
/// over its sample factor (coverage taken as 1): not yet a term of
/// `host-sim costfit`'s fit. The exact test's constant is about three
/// times one test's cost: exact tests fall on shadow edges, where the
/// adaptive rule takes its grid, so a pixel there takes many.
pub const SHADOW_COST: [f64; 3] = [SHADOW_PRE, SHADOW_EXACT, SHADOW_PIXEL];
const SHADOW_PRE: f64 = 70.0;
const SHADOW_EXACT: f64 = 5000.0;
const SHADOW_PIXEL: f64 = 490.0;

/// [`SHADOW_COST`] of a frame's geometry `g` in the fast arithmetic (or
/// not), M3 instructions a sample.
pub(super) fn shadow_cost(g: &Geometry, fast: bool) -> f64 {
    if cfg!(feature = "shadows") && g.shadows {
        let tests = if fast {
            SHADOW_PRE * g.shadow_tests + SHADOW_EXACT * g.shadow_exact
        } else {
            SHADOW_EXACT * g.shadow_tests
        };
        tests + SHADOW_PIXEL * g.coverage
    } else {
        0.0
    }
}

/// Through the aperture, the shares of the frame's pixels whose aperture
/// rays the fast loop traces through every primitive and tests against
/// one rectangle alone ([`Samples::traced`], [`Samples::only`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Shares {
    pub(super) traced: f64,
    pub(super) only: f64,
}

impl Shares {
    /// Every pixel's rays traced: the wide arithmetic's loop, and the
    /// pinhole's.
    pub(super) const TRACED: Shares = Shares {
        traced: 1.0,
        only: 0.0,
    };
}

/// The [`Shares`] of `scene` through `opts`' aperture in the fast
/// arithmetic ([`aperture_shares`]); every pixel traced without an
/// aperture, where that frame does not prepare, and in a `compact` build
/// (the driven camera: on the M0 the classification took 548 B more of its
/// planning stack and 7 872 B of flash, a second frame type; it predicts
/// every pixel traced, the same choice at a higher predicted cost).
#[inline]
pub(super) fn fast_shares(scene: &Scene, opts: &Options) -> Shares {
    #[cfg(all(feature = "mix32", not(feature = "compact")))]
    if opts.aperture > 0 {
        if let Some(s) = aperture_shares(scene, opts) {
            return s;
        }
    }
    let _ = (scene, opts);
    Shares::TRACED
}

/// [`Shares`] of `scene` rendered with `opts` in the fast arithmetic (its
/// polynomial distortion: the table is not the frame's to choose here),
/// from the frame's own rule (`mix32::Mix32::aperture_classes`) on every
/// [`APERTURE_STRIDE`]-th row and column; `None` where that frame does
/// not prepare or has no aperture. Out of line: the frame is not on the
/// stack while the planner's geometry is.
#[cfg(all(feature = "mix32", not(feature = "compact")))]
#[inline(never)]
pub(super) fn aperture_shares(scene: &Scene, opts: &Options) -> Option<Shares> {
    let opts = Options {
        arithmetic: Arithmetic::Fast,
        distortion_eval: DistortionEval::Polynomial,
        lut_entries: 2,
        ..*opts
    };
    let mut frame = crate::render::Frame::<crate::scene::Q, 2>::empty();
    frame.prepare(scene, &opts).ok()?;
    let c = frame.aperture_classes(APERTURE_STRIDE)?;
    let n = f64::from(c.pixels.max(1));
    Some(Shares {
        traced: f64::from(c.traced) / n,
        only: f64::from(c.only) / n,
    })
}

/// Every `APERTURE_STRIDE`-th row and column of a defocused frame is
/// classified for [`Samples::traced`] and [`Samples::only`] (a 160×120
/// frame: 1 200 pixels).
pub const APERTURE_STRIDE: u16 = 4;
