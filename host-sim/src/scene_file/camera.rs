//! `[camera]` of a scene file: the sensor, the lens and the pose as a
//! file gives them.

use super::exact;
use hilcam::scene::data::LensData;
use serde::Deserialize;

/// `[camera]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraDesc {
    /// Sensor width, pixels.
    pub width: u16,
    /// Sensor height, pixels.
    pub height: u16,
    /// Focal length, metres.
    pub focal_length: f64,
    /// Pixel pitch, metres: one number, or `[s_x, s_y]`.
    pub pitch: Pair,
    /// Principal point, pixels (default: the sensor centre).
    #[serde(default, deserialize_with = "exact::opt")]
    pub principal_point: Option<[f64; 2]>,
    /// `perspective` (default) or `orthographic`.
    #[serde(default = "perspective")]
    pub model: String,
    /// `m` for an orthographic camera.
    pub orthographic_scale: Option<f64>,
    /// F-number (or give `aperture`).
    pub f_number: Option<f64>,
    /// Aperture diameter, metres (or give `f_number`).
    pub aperture: Option<f64>,
    /// Focus distance, metres.
    pub focus_distance: f64,
    /// Tolerable blur diameter, metres.
    pub tolerable_blur: f64,
    /// `[k1, k2]` (default none).
    #[serde(default, deserialize_with = "exact::opt")]
    pub distortion: Option<[f64; 2]>,
    /// OpenCV's standard model's coefficients ([`crate::calibration::lens`]).
    #[serde(default)]
    pub opencv_distortion: Option<Vec<f64>>,
    #[serde(default, deserialize_with = "exact::opt")] // fisheye [k1, k2, k3, k4]
    pub fisheye_distortion: Option<[f64; 4]>,
    /// The pose.
    pub pose: PoseDesc,
}

impl CameraDesc {
    /// The camera's calibrated lens, if any, as the core takes it.
    pub fn lens(&self) -> Result<Option<LensData>, String> {
        crate::calibration::lens(
            self.distortion.is_some(),
            &self.opencv_distortion,
            &self.fisheye_distortion,
        )
    }
}

fn perspective() -> String {
    "perspective".into()
}

/// A number or a pair.
#[derive(Clone, Copy, Debug)]
pub enum Pair {
    /// The same for both.
    One(f64),
    /// `[a, b]`.
    Two([f64; 2]),
}

impl Pair {
    /// `(a, b)`, a number standing for both.
    pub fn get(self) -> (f64, f64) {
        match self {
            Pair::One(v) => (v, v),
            Pair::Two([a, b]) => (a, b),
        }
    }
}

/// `[camera.pose]`: exactly one of look-at (`eye`, `target`, `up`),
/// `position` with `yaw_pitch_roll` (radians), or `position` with `rotation`
/// (rows = camera axes in world coordinates).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PoseDesc {
    /// Look-at eye.
    #[serde(default, deserialize_with = "exact::opt")]
    pub eye: Option<[f64; 3]>,
    /// Look-at target.
    #[serde(default, deserialize_with = "exact::opt")]
    pub target: Option<[f64; 3]>,
    /// Look-at up.
    #[serde(default, deserialize_with = "exact::opt")]
    pub up: Option<[f64; 3]>,
    /// Centre of projection.
    #[serde(default, deserialize_with = "exact::opt")]
    pub position: Option<[f64; 3]>,
    /// Yaw, pitch, roll, radians.
    #[serde(default, deserialize_with = "exact::opt")]
    pub yaw_pitch_roll: Option<[f64; 3]>,
    /// Rotation matrix rows.
    #[serde(default, deserialize_with = "exact::opt_matrix")]
    pub rotation: Option<[[f64; 3]; 3]>,
}

/// The pose, resolved.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Pose {
    /// Look-at.
    LookAt {
        /// Eye.
        eye: [f64; 3],
        /// Target.
        target: [f64; 3],
        /// Up.
        up: [f64; 3],
    },
    /// Yaw, pitch, roll.
    Ypr {
        /// Position.
        position: [f64; 3],
        /// Angles, radians.
        angles: [f64; 3],
    },
    /// Matrix.
    Matrix {
        /// Position.
        position: [f64; 3],
        /// Rows.
        rotation: [[f64; 3]; 3],
    },
}

impl Pose {
    /// `R` and `T` as the core makes them of this pose (what scene data
    /// carries). Errors name the scene file's key.
    pub fn matrix(&self) -> Result<([[f64; 3]; 3], [f64; 3]), String> {
        use hilcam::geom::extrinsics::{look_at_matrix, yaw_pitch_roll_matrix};
        let key = |e: hilcam::Error| {
            let k = match (self, e.field()) {
                (_, hilcam::Field::Target) => "camera.pose.target",
                (_, hilcam::Field::Up) => "camera.pose.up",
                (_, hilcam::Field::Translation) => "camera.pose.eye",
                _ => "camera.pose.yaw_pitch_roll",
            };
            let text = e.to_string();
            let why = text.split_once(": ").map_or(text.as_str(), |(_, w)| w);
            format!("{k}: {why}")
        };
        match *self {
            Pose::LookAt { eye, target, up } => Ok((look_at_matrix(eye, target, up).map_err(key)?, eye)),
            Pose::Ypr { position, angles } => Ok((
                yaw_pitch_roll_matrix(angles[0], angles[1], angles[2]).map_err(key)?,
                position,
            )),
            Pose::Matrix { position, rotation } => Ok((rotation, position)),
        }
    }
}

impl<'de> Deserialize<'de> for Pair {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        Ok(match exact::one_or::<D, 2>(d, "a number or [a, b]")? {
            Ok(v) => Pair::One(v),
            Err(a) => Pair::Two(a),
        })
    }
}
