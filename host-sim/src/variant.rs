//! Rendering variants for the speed/accuracy trade: an arithmetic and a
//! departure from the plan. Named as `host-sim tradeoff` reports them and
//! as the firmware's `HILCAM_VARIANTS` takes them, e.g. `planned` (what
//! the planner picks: the default), `mix32-poly`, `i32f32-lut256-linear`,
//! `f32-poly`.

use crate::harness::{collect, Collect};
use crate::scene_file::Resolved;
use hilcam::num::scalar::{Scalar, I32F32};
use hilcam::planner::{Budget, Plan};
use hilcam::render::{Arithmetic, DistortionEval, Frame, Options, Override};

/// The per-pixel arithmetic of a variant. (I16F16 and I12F20, measured in
/// earlier sweeps, were dominated on every scene — slower than `mix32` and
/// 42–240 LSB off — and are gone.)
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ScalarKind {
    /// Whatever the planner picks (the default: the fast arithmetic where
    /// its formats hold the scene within budget, else I32F32).
    Planned,
    /// The wide arithmetic in I32F32.
    I32F32,
    /// The wide arithmetic in IEEE single precision.
    F32,
    /// The fast arithmetic: 32-bit fixed point, a format per quantity
    /// ([`hilcam::render::fast`]).
    Mix32,
}

impl ScalarKind {
    /// All of them.
    pub const ALL: [ScalarKind; 4] = [
        ScalarKind::Planned,
        ScalarKind::I32F32,
        ScalarKind::F32,
        ScalarKind::Mix32,
    ];

    /// Name as in variant names.
    pub fn name(self) -> &'static str {
        match self {
            ScalarKind::Planned => "planned",
            ScalarKind::I32F32 => I32F32::NAME,
            ScalarKind::F32 => f32::NAME,
            ScalarKind::Mix32 => "mix32",
        }
    }

    /// The Rust type of the frame's wide scalar, as firmware code names it.
    pub fn type_path(self) -> &'static str {
        match self {
            ScalarKind::Planned | ScalarKind::I32F32 | ScalarKind::Mix32 => "hilcam::num::scalar::I32F32",
            ScalarKind::F32 => "f32",
        }
    }

    /// The arithmetic it forces (`None`: the plan's).
    pub fn arithmetic(self) -> Option<Arithmetic> {
        match self {
            ScalarKind::Planned => None,
            ScalarKind::I32F32 | ScalarKind::F32 => Some(Arithmetic::Wide),
            ScalarKind::Mix32 => Some(Arithmetic::Fast),
        }
    }
}

/// Something to do with a scalar type chosen at run time.
pub trait WithScalar {
    /// The result.
    type Out;
    /// Does it in `S`.
    fn run<S: Scalar>(self) -> Self::Out;
}

impl ScalarKind {
    /// Runs `w` with this type.
    pub fn dispatch<W: WithScalar>(self, w: W) -> W::Out {
        match self {
            ScalarKind::Planned | ScalarKind::I32F32 | ScalarKind::Mix32 => w.run::<I32F32>(),
            ScalarKind::F32 => w.run::<f32>(),
        }
    }
}

/// A scalar type and a departure from the plan.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Variant {
    /// Per-pixel type.
    pub scalar: ScalarKind,
    /// What changes from the plan.
    pub over: Override,
}

impl Variant {
    /// The planned renderer: the plan as it is (the default everywhere).
    pub const PLANNED: Variant = Variant {
        scalar: ScalarKind::Planned,
        over: Override::Planned,
    };

    /// `planned`, or `ARITH-planned`, `ARITH-lutN-linear`,
    /// `ARITH-lutN-nearest`, `ARITH-poly`, `ARITH-all-stages`, `ARITH-sN`
    /// (an N×N sample grid on every pixel), `ARITH-sN-adaptive`, `ARITH-apN`
    /// (the aperture sampled with N points; 0: not at all), `ARITH-nomean`
    /// (the closed plane without its mean), `ARITH-persp` (perspective rays
    /// where the plan has weak-perspective ones), `ARITH-weak`
    /// (weak-perspective rays, at the planner's mean depth, where the plan
    /// has perspective ones and weak perspective holds).
    pub fn name(&self) -> String {
        let s = self.scalar.name();
        match self.over {
            Override::Planned if self.scalar == ScalarKind::Planned => s.to_string(),
            Override::Planned => format!("{s}-planned"),
            Override::Table { entries, eval } => format!(
                "{s}-lut{entries}-{}",
                if eval == DistortionEval::Nearest {
                    "nearest"
                } else {
                    "linear"
                }
            ),
            Override::Polynomial => format!("{s}-poly"),
            Override::AllStages => format!("{s}-all-stages"),
            Override::Samples { n, adaptive: false } => format!("{s}-s{n}"),
            Override::Samples { n, adaptive: true } => format!("{s}-s{n}-adaptive"),
            Override::Aperture { points } => format!("{s}-ap{points}"),
            Override::NoMean => format!("{s}-nomean"),
            Override::Perspective => format!("{s}-persp"),
            Override::Weak { .. } => format!("{s}-weak"),
        }
    }

    /// Parses [`Variant::name`]'s form.
    pub fn parse(name: &str) -> Result<Variant, String> {
        let bad = || {
            format!(
                "variant {name:?}: expected planned, or ARITH-planned, ARITH-lutN-linear, \
                 ARITH-lutN-nearest, ARITH-poly, ARITH-all-stages, ARITH-sN or ARITH-sN-adaptive \
                 (N 1, 2, 4, 8, 16), ARITH-apN (N 0, 16, 64, 256), ARITH-nomean, ARITH-persp, ARITH-weak, ARITH one of planned, mix32, \
                 i32f32, f32"
            )
        };
        if name == "planned" {
            return Ok(Variant::PLANNED);
        }
        let (s, rest) = name.split_once('-').ok_or_else(bad)?;
        let scalar = ScalarKind::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(bad)?;
        let over = match rest {
            "planned" => Override::Planned,
            "poly" => Override::Polynomial,
            "all-stages" => Override::AllStages,
            "nomean" => Override::NoMean,
            "persp" => Override::Perspective,
            // (The mean depth is the plan's: `Variant::options`.)
            "weak" => Override::Weak {
                mean_depth: hilcam::num::Len::ZERO,
            },
            _ if rest.starts_with("ap") => {
                let points: u16 = rest[2..].parse().map_err(|_| bad())?;
                if points != 0 && !hilcam::render::sensor::defocus::is_size(points) {
                    return Err(format!(
                        "variant {name:?}: the aperture pattern's points must be 0, 16, 64 or 256"
                    ));
                }
                Override::Aperture { points }
            }
            _ if rest.starts_with('s') => {
                let (n, adaptive) = match rest[1..].split_once('-') {
                    Some((n, "adaptive")) => (n, true),
                    Some(_) => return Err(bad()),
                    None => (&rest[1..], false),
                };
                let n: u8 = n.parse().map_err(|_| bad())?;
                if !matches!(n, 1 | 2 | 4 | 8 | 16) {
                    return Err(format!(
                        "variant {name:?}: the sample grid's side must be 1, 2, 4, 8 or 16"
                    ));
                }
                Override::Samples { n, adaptive }
            }
            _ => {
                let (n, eval) = rest
                    .strip_prefix("lut")
                    .and_then(|r| r.split_once('-'))
                    .ok_or_else(bad)?;
                let entries: usize = n.parse().map_err(|_| bad())?;
                if !(2..=hilcam::geom::distortion::MAX_LUT).contains(&entries) {
                    return Err(format!(
                        "variant {name:?}: table entries must be 2 to {}",
                        hilcam::geom::distortion::MAX_LUT
                    ));
                }
                let eval = match eval {
                    "linear" => DistortionEval::Linear,
                    "nearest" => DistortionEval::Nearest,
                    _ => return Err(bad()),
                };
                Override::Table { entries, eval }
            }
        };
        Ok(Variant { scalar, over })
    }

    /// The options this variant renders with, from `plan`'s. `ARITH-weak`
    /// takes the mean depth of the plan's weak-perspective candidate, and
    /// keeps the plan's rays where it has none (weak perspective does not
    /// hold, or the camera is telecentric).
    pub fn options(&self, plan: &Plan) -> Options {
        let over = match self.over {
            Override::Weak { .. } => plan
                .weak_mean_depth()
                .map_or(Override::Planned, |mean_depth| Override::Weak { mean_depth }),
            o => o,
        };
        let o = plan.options.with(over);
        match self.scalar.arithmetic() {
            Some(a) => o.with_arithmetic(a),
            None => o,
        }
    }

    /// Renders `r` on the host with this variant: the frame's bytes and
    /// what [`crate::harness::compare`] needs.
    pub fn render<W: FrameUser>(&self, r: &Resolved, budget: &Budget, user: W) -> Result<W::Out, String> {
        self.render_frame(r, budget, 0, user)
    }

    /// [`Variant::render`] as frame `frame_id` (the sensor noise's key).
    pub fn render_frame<W: FrameUser>(
        &self,
        r: &Resolved,
        budget: &Budget,
        frame_id: u32,
        user: W,
    ) -> Result<W::Out, String> {
        struct Go<'a, W> {
            r: &'a Resolved,
            budget: &'a Budget,
            variant: Variant,
            frame_id: u32,
            user: W,
        }
        impl<W: FrameUser> WithScalar for Go<'_, W> {
            type Out = Result<W::Out, String>;
            fn run<S: Scalar>(self) -> Self::Out {
                let (_, plan, mut frame) =
                    crate::harness::prepare::<S>(self.r, self.budget, |p| self.variant.options(p))?;
                frame.set_frame_id(self.frame_id);
                let core = collect(&frame).map_err(|e| format!("{}: {e}", self.r.desc.name))?;
                Ok(self.user.use_frame(&plan, &frame, core))
            }
        }
        self.scalar.dispatch(Go {
            r,
            budget,
            variant: *self,
            frame_id,
            user,
        })
    }

    /// [`Variant::render_frame`] a line at a time through `sink`, on one
    /// core as the firmware renders: memory is a line, whatever the height.
    /// Returns the plan's report and the frame's stages.
    pub fn render_frame_to<K: hilcam::render::FrameSink<Error = String>>(
        &self,
        r: &Resolved,
        budget: &Budget,
        frame_id: u32,
        sink: &mut K,
    ) -> Result<(crate::harness::PlanReport, Vec<String>), String> {
        struct Go<'a, K> {
            r: &'a Resolved,
            budget: &'a Budget,
            variant: Variant,
            frame_id: u32,
            sink: &'a mut K,
        }
        impl<K: hilcam::render::FrameSink<Error = String>> WithScalar for Go<'_, K> {
            type Out = Result<(crate::harness::PlanReport, Vec<String>), String>;
            fn run<S: Scalar>(self) -> Self::Out {
                let (_, plan, mut frame) =
                    crate::harness::prepare::<S>(self.r, self.budget, |p| self.variant.options(p))?;
                frame.set_frame_id(self.frame_id);
                let w = usize::from(frame.size().0);
                let (mut line, mut flags, mut keys) =
                    (vec![0u8; frame.line_bytes()], vec![0u8; w], vec![0u64; w + 1]);
                crate::harness::render_carried(&frame, &mut line, &mut flags, &mut keys, self.sink).map_err(
                    |e| match e {
                        hilcam::render::FrameError::Sink(e) => e,
                        e => format!("{}: {e}", self.r.desc.name),
                    },
                )?;
                let stages = frame.stages().names().iter().map(|s| s.to_string()).collect();
                Ok((crate::harness::plan_report(&plan, self.budget, &frame), stages))
            }
        }
        self.scalar.dispatch(Go {
            r,
            budget,
            variant: *self,
            frame_id,
            sink,
        })
    }

    /// The sample pattern the reference applies to compare with this
    /// variant: its own grid or aperture, or the scene's.
    pub fn pattern(&self, r: &Resolved) -> crate::reference::sampling::Pattern {
        use crate::reference::sampling::Pattern;
        let scene = Pattern::of_scene(r);
        match self.over {
            Override::Samples { n, adaptive } => Pattern { n, adaptive, ..scene },
            Override::Aperture { points } => Pattern {
                aperture: points,
                ..scene
            },
            _ => scene,
        }
    }
}

/// Takes a frame rendered in some scalar type.
pub trait FrameUser {
    /// The result.
    type Out;
    /// Uses the plan, the prepared frame and its rendered bytes.
    fn use_frame<S: Scalar>(self, plan: &Plan, frame: &Frame<S>, core: Collect) -> Self::Out;
}

/// [`crate::harness::core_render`] with per-pixel values in `S` and the options of
/// `variant`.
pub fn core_render_variant<S: Scalar>(
    r: &Resolved,
    budget: &Budget,
    variant: &Variant,
) -> Result<(hilcam::scene::Scene, Plan, Frame<S>, Collect), String> {
    let (scene, plan, frame) = crate::harness::prepare::<S>(r, budget, |p| variant.options(p))?;
    let core = collect(&frame).map_err(|e| format!("{}: {e}", r.desc.name))?;
    Ok((scene, plan, frame, core))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_bad_names_are_refused() {
        for n in [
            "planned",
            "i32f32-planned",
            "i32f32-lut256-linear",
            "mix32-lut16-nearest",
            "f32-poly",
            "i32f32-all-stages",
            "mix32-poly",
            "planned-poly",
            "i32f32-ap64",
            "i32f32-ap0",
            "mix32-weak",
            "i32f32-persp",
        ] {
            assert_eq!(Variant::parse(n).map(|v| v.name()), Ok(n.to_string()));
        }
        for n in [
            "i64f64-poly",
            "i16f16-poly",
            "f32",
            "f32-lut1-linear",
            "f32-lut2048-linear",
            "f32-lut64-cubic",
            "i32f32-ap32",
            "i32f32-ap",
        ] {
            assert!(Variant::parse(n).is_err(), "{n}");
        }
    }
}
