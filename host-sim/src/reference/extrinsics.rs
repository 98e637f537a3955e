//! Reference pose: `P_c = R (P_w − T)`, rows of `R` = camera axes in world
//! coordinates (camera-model.md §1).

use super::{cross, dot, unit, V3};

/// A camera pose in f64.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    /// Rows: the camera's x (left), y (up), z (forward) axes in world
    /// coordinates.
    pub r: [V3; 3],
    /// Centre of projection in world coordinates, metres.
    pub t: V3,
}

impl Pose {
    /// From the convention documented in the core's `extrinsics` module: with
    /// zero angles the camera looks along world +z with +y up; positive yaw
    /// turns the optic axis towards +x, positive pitch tilts it up, positive
    /// roll turns the camera's x axis towards its y axis. Built here from the
    /// axis vectors directly.
    pub fn from_yaw_pitch_roll(yaw: f64, pitch: f64, roll: f64, t: V3) -> Pose {
        let (sy, cy) = yaw.sin_cos();
        let (sp, cp) = pitch.sin_cos();
        let (sr, cr) = roll.sin_cos();
        let forward = [sy * cp, sp, cy * cp];
        // Before roll: left is horizontal, up completes the frame.
        let left0 = [cy, 0.0, -sy];
        let up0 = cross(forward, left0);
        let left = [
            cr * left0[0] + sr * up0[0],
            cr * left0[1] + sr * up0[1],
            cr * left0[2] + sr * up0[2],
        ];
        let up = [
            -sr * left0[0] + cr * up0[0],
            -sr * left0[1] + cr * up0[1],
            -sr * left0[2] + cr * up0[2],
        ];
        Pose {
            r: [left, up, forward],
            t,
        }
    }

    /// Camera at `eye` looking at `target`, `up` the image's up direction.
    pub fn look_at(eye: V3, target: V3, up: V3) -> Pose {
        let z = unit([target[0] - eye[0], target[1] - eye[1], target[2] - eye[2]]);
        let x = unit(cross(up, z));
        let y = cross(z, x);
        Pose { r: [x, y, z], t: eye }
    }

    /// World → camera.
    pub fn world_to_camera(&self, p: V3) -> V3 {
        let d = [p[0] - self.t[0], p[1] - self.t[1], p[2] - self.t[2]];
        [dot(self.r[0], d), dot(self.r[1], d), dot(self.r[2], d)]
    }

    /// Camera → world: `P_w = Rᵀ P_c + T`.
    pub fn camera_to_world(&self, p: V3) -> V3 {
        let mut w = self.t;
        for (row, c) in self.r.iter().zip(p) {
            for k in 0..3 {
                w[k] += row[k] * c;
            }
        }
        w
    }
}
