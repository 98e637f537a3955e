//! Extrinsics: the camera's pose, `P_c = R (P_w − T)` (camera-model.md §1).
//!
//! `T` is the centre of projection in world coordinates and the rows of `R`
//! are the camera's axes written in world coordinates.
//!
//! # Yaw, pitch and roll
//!
//! With all three zero the camera axes coincide with the world axes (the
//! camera looks along world `+z`, with world `+y` up). Otherwise the
//! camera-to-world rotation is `M = R_y(yaw) · R_x(−pitch) · R_z(roll)` and
//! `R = Mᵀ`, where `R_a(θ)` is the right-handed rotation by `θ` about axis
//! `a`. So a positive yaw turns the optic axis from `+z` towards `+x` (the
//! camera's left), a positive pitch tilts it up (towards `+y`), and a positive
//! roll turns the camera's `x` axis towards its `y` axis. Angles in radians.

use crate::geom::error::{to_fixed, Error, Field};
use crate::geom::frame::{CameraPoint, WorldPoint};
use crate::num::vec3::{cross, div, dot, norm};
use crate::num::{Rot, Sat, Wide};
use core::ops::{Add as _, Mul as _, Sub as _};

pub use crate::geom::error::ROTATION_TOLERANCE;

/// A validated camera pose.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Extrinsics {
    r: [[Rot; 3]; 3],
    t: WorldPoint,
}

type M3 = [[f64; 3]; 3];

fn transpose(a: &M3) -> M3 {
    [
        [a[0][0], a[1][0], a[2][0]],
        [a[0][1], a[1][1], a[2][1]],
        [a[0][2], a[1][2], a[2][2]],
    ]
}

fn mat_mul(a: &M3, b: &M3) -> M3 {
    let bt = transpose(b);
    a.map(|row| bt.map(|col| dot(row, col)))
}

fn det(a: &M3) -> f64 {
    a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
        + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0])
}

fn finite3(a: [f64; 3], field: Field) -> Result<[f64; 3], Error> {
    if a.iter().all(|v| v.is_finite()) {
        Ok(a)
    } else {
        Err(Error::NotFinite(field))
    }
}

impl Extrinsics {
    /// From `R` (rows = camera axes in world coordinates) and `T` (metres).
    ///
    /// `R` must be orthonormal with `det R = +1`, each within
    /// [`ROTATION_TOLERANCE`]; `T` within ±8.4·10⁶ m.
    pub fn from_matrix(r: [[f64; 3]; 3], t: [f64; 3]) -> Result<Self, Error> {
        for row in &r {
            finite3(*row, Field::Rotation)?;
        }
        let t = finite3(t, Field::Translation)?;
        let rrt = mat_mul(&r, &transpose(&r));
        let mut worst: f64 = 0.0;
        for (i, row) in rrt.iter().enumerate() {
            for (j, v) in row.iter().enumerate() {
                let want = if i == j { 1.0 } else { 0.0 };
                worst = worst.max((v - want).abs());
            }
        }
        if worst > ROTATION_TOLERANCE {
            return Err(Error::NotOrthonormal);
        }
        let d = det(&r);
        if d < 0.0 {
            return Err(Error::Reflection);
        }
        if (d - 1.0).abs() > ROTATION_TOLERANCE {
            return Err(Error::NotOrthonormal);
        }
        let mut rf = [[Rot::ZERO; 3]; 3];
        for (dst, src) in rf.iter_mut().zip(r.iter()) {
            for (d, s) in dst.iter_mut().zip(src.iter()) {
                *d = to_fixed(*s, Field::Rotation)?;
            }
        }
        Ok(Extrinsics {
            r: rf,
            t: WorldPoint {
                x: to_fixed(t[0], Field::Translation)?,
                y: to_fixed(t[1], Field::Translation)?,
                z: to_fixed(t[2], Field::Translation)?,
            },
        })
    }

    /// From yaw, pitch and roll (radians; see the module docs for the
    /// convention) and the centre of projection `T` (metres).
    pub fn from_yaw_pitch_roll(yaw: f64, pitch: f64, roll: f64, t: [f64; 3]) -> Result<Self, Error> {
        Self::from_matrix(yaw_pitch_roll_matrix(yaw, pitch, roll)?, t)
    }

    /// A camera at `eye` looking at `target`, with `up` giving the image's up
    /// direction (world coordinates, metres): [`look_at_matrix`].
    pub fn look_at(eye: [f64; 3], target: [f64; 3], up: [f64; 3]) -> Result<Self, Error> {
        let eye = finite3(eye, Field::Translation)?;
        Self::from_matrix(look_at_matrix(eye, target, up)?, eye)
    }

    /// `R`, as stored (I2F30 entries).
    pub fn rotation(&self) -> [[Rot; 3]; 3] {
        self.r
    }

    /// `T`, the centre of projection in world coordinates.
    pub fn translation(&self) -> WorldPoint {
        self.t
    }

    /// World → camera: `P_c = R (P_w − T)`.
    ///
    /// Error ≤ 0.5 pm + 10⁻¹⁸·|P_w − T| per coordinate; saturates when a
    /// camera coordinate exceeds ±8.4·10⁶ m.
    pub fn world_to_camera(&self, p: WorldPoint) -> Sat<CameraPoint> {
        let [x, y, z] = self.world_to_camera_wide(p);
        x.narrow()
            .zip(y.narrow())
            .zip(z.narrow())
            .map(|((x, y), z)| CameraPoint { x, y, z })
    }

    /// World → camera, not narrowed (for fused chains).
    pub(crate) fn world_to_camera_wide(&self, p: WorldPoint) -> [Wide; 3] {
        let d = [
            Wide::of(p.x).sub(Wide::of(self.t.x)),
            Wide::of(p.y).sub(Wide::of(self.t.y)),
            Wide::of(p.z).sub(Wide::of(self.t.z)),
        ];
        self.r.map(|r| {
            Wide::of(r[0])
                .mul(d[0])
                .add(Wide::of(r[1]).mul(d[1]))
                .add(Wide::of(r[2]).mul(d[2]))
        })
    }

    /// Camera → world: `P_w = Rᵀ P_c + T`.
    pub fn camera_to_world(&self, p: CameraPoint) -> Sat<WorldPoint> {
        let c = [Wide::of(p.x), Wide::of(p.y), Wide::of(p.z)];
        let rt = [
            [self.r[0][0], self.r[1][0], self.r[2][0]],
            [self.r[0][1], self.r[1][1], self.r[2][1]],
            [self.r[0][2], self.r[1][2], self.r[2][2]],
        ];
        let [x, y, z] =
            rt.map(|col| Wide::of(col[0]) * c[0] + Wide::of(col[1]) * c[1] + Wide::of(col[2]) * c[2]);
        (x + Wide::of(self.t.x))
            .narrow()
            .zip((y + Wide::of(self.t.y)).narrow())
            .zip((z + Wide::of(self.t.z)).narrow())
            .map(|((x, y), z)| WorldPoint { x, y, z })
    }
}

/// The largest yaw, pitch or roll taken, radians: ±1000 (about 160 turns);
/// beyond it an angle's f64 holds too few bits of the fraction of a turn
/// that sets the pose (at 10³⁰⁰ rad, none).
pub const MAX_ANGLE: f64 = 1000.0;

/// The `R` (f64, rows: the camera's axes in world coordinates) of yaw,
/// pitch and roll (radians, each within ±[`MAX_ANGLE`]; see the module docs
/// for the convention): what [`Extrinsics::from_yaw_pitch_roll`] builds its
/// pose from.
pub fn yaw_pitch_roll_matrix(yaw: f64, pitch: f64, roll: f64) -> Result<[[f64; 3]; 3], Error> {
    finite3([yaw, pitch, roll], Field::Angle)?;
    if [yaw, pitch, roll].iter().any(|a| a.abs() > MAX_ANGLE) {
        return Err(Error::OutOfRange(Field::Angle));
    }
    let (sy, cy) = (libm::sin(yaw), libm::cos(yaw));
    let (sp, cp) = (libm::sin(-pitch), libm::cos(-pitch));
    let (sr, cr) = (libm::sin(roll), libm::cos(roll));
    let ry = [[cy, 0.0, sy], [0.0, 1.0, 0.0], [-sy, 0.0, cy]];
    let rx = [[1.0, 0.0, 0.0], [0.0, cp, -sp], [0.0, sp, cp]];
    let rz = [[cr, -sr, 0.0], [sr, cr, 0.0], [0.0, 0.0, 1.0]];
    let m = mat_mul(&mat_mul(&ry, &rx), &rz);
    Ok(transpose(&m))
}

/// The `R` (f64) of a camera at `eye` looking at `target` with `up` giving
/// the image's up direction: the optic axis is
/// `z = (target − eye)/|target − eye|`, `x = up × z` normalized,
/// `y = z × x`. What [`Extrinsics::look_at`] builds its pose from.
///
/// Errors: the target within 1 µm of the eye, or `up` within 10⁻⁶ rad of
/// the optic axis (or zero).
pub fn look_at_matrix(eye: [f64; 3], target: [f64; 3], up: [f64; 3]) -> Result<[[f64; 3]; 3], Error> {
    let eye = finite3(eye, Field::Translation)?;
    let target = finite3(target, Field::Target)?;
    let up = finite3(up, Field::Up)?;
    let v = [target[0] - eye[0], target[1] - eye[1], target[2] - eye[2]];
    // Scaled by its largest component first, so that a target as far
    // as f64 reaches (|v|² overflowing) still gives the direction.
    let m = v.iter().fold(0.0f64, |m, c| m.max(c.abs()));
    if !m.is_finite() {
        return Err(Error::OutOfRange(Field::Target));
    }
    if m <= 1e-6 / 2.0 || m * norm(div(v, m)) <= 1e-6 {
        return Err(Error::Degenerate(Field::Target));
    }
    let v = div(v, m);
    let z = div(v, norm(v));
    let un = norm(up);
    let x = cross(up, z);
    let xn = norm(x);
    if un <= 0.0 || xn <= 1e-6 * un {
        return Err(Error::Degenerate(Field::Up));
    }
    let x = div(x, xn);
    let y = cross(z, x);
    Ok([x, y, z])
}
