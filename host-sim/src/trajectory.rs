//! Camera trajectories: timed keyframes (position, orientation), positions
//! interpolated linearly and orientations by slerp, sampled into the poses
//! a host sends (`host-sim drive`).
//!
//! Orientation is the unit quaternion `q = (w, x, y, z)` of the
//! camera-to-world rotation `M` (its columns are the camera's axes in world
//! coordinates); the contract's `R` (camera-model.md §1) is `Mᵀ`.

use serde::{Deserialize, Serialize};

/// A pose in the contract's terms: `R` (rows: the camera's axes in world
/// coordinates) and `T` (the centre of projection, metres).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Pose {
    /// `R`, row by row.
    pub rotation: [[f64; 3]; 3],
    /// `T`, metres.
    pub translation: [f64; 3],
}

/// A keyframe.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Keyframe {
    /// Time, seconds.
    pub t: f64,
    /// Centre of projection, metres.
    pub position: [f64; 3],
    /// `(w, x, y, z)` of the camera-to-world rotation (normalized on load).
    pub quaternion: [f64; 4],
}

/// Keyframes in increasing time.
#[derive(Clone, Debug, PartialEq)]
pub struct Trajectory {
    keys: Vec<Keyframe>,
}

fn normalize(q: [f64; 4]) -> Option<[f64; 4]> {
    let n = q.iter().map(|v| v * v).sum::<f64>().sqrt();
    (n.is_finite() && n > 1e-9).then(|| q.map(|v| v / n))
}

/// `n` poses about `pose`, from the generator state `state` (a 64-bit LCG:
/// the same poses for the same state): the first half turned by up to ±1.4°
/// about each axis and moved by up to ±2.5 cm along each, the second half
/// by up to ±11° and ±20 cm. The pinned plans (`tests/golden.rs`) and
/// `examples/pose_plans.rs` take them, one state through every shipped
/// scene in turn.
pub fn poses_about(pose: &Pose, n: usize, state: &mut u64) -> Vec<Pose> {
    let mut next = || {
        *state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (*state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    let q0 = quaternion_of(&pose.rotation);
    (0..n)
        .map(|k| {
            let s = if k < n / 2 { 0.025 } else { 0.2 };
            let q = [q0[0], q0[1] + s * next(), q0[2] + s * next(), q0[3] + s * next()];
            let norm = q.iter().map(|v| v * v).sum::<f64>().sqrt();
            let translation = pose.translation.map(|v| v + 2.0 * s * next());
            Pose {
                rotation: rotation_of(q.map(|v| v / norm)),
                translation,
            }
        })
        .collect()
}

/// The generator state [`poses_about`] starts from for the pinned plans.
pub const POSES_SEED: u64 = 0x9e37_79b9_7f4a_7c15;

/// How many poses about each shipped scene's own have their plans pinned.
pub const PINNED_POSES: usize = 40;

/// `R` (= `Mᵀ`) of a unit quaternion of `M`.
pub fn rotation_of(q: [f64; 4]) -> [[f64; 3]; 3] {
    let [w, x, y, z] = q;
    let m = [
        [
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y - w * z),
            2.0 * (x * z + w * y),
        ],
        [
            2.0 * (x * y + w * z),
            1.0 - 2.0 * (x * x + z * z),
            2.0 * (y * z - w * x),
        ],
        [
            2.0 * (x * z - w * y),
            2.0 * (y * z + w * x),
            1.0 - 2.0 * (x * x + y * y),
        ],
    ];
    [
        [m[0][0], m[1][0], m[2][0]],
        [m[0][1], m[1][1], m[2][1]],
        [m[0][2], m[1][2], m[2][2]],
    ]
}

/// The unit quaternion of `M = Rᵀ` (Shepperd's method: the largest of the
/// four candidates, for accuracy).
pub fn quaternion_of(r: &[[f64; 3]; 3]) -> [f64; 4] {
    // m[i][j] = r[j][i].
    let m = |i: usize, j: usize| r[j][i];
    let tr = m(0, 0) + m(1, 1) + m(2, 2);
    let q = if tr > 0.0 {
        let s = (tr + 1.0).sqrt() * 2.0;
        [
            s / 4.0,
            (m(2, 1) - m(1, 2)) / s,
            (m(0, 2) - m(2, 0)) / s,
            (m(1, 0) - m(0, 1)) / s,
        ]
    } else if m(0, 0) > m(1, 1) && m(0, 0) > m(2, 2) {
        let s = (1.0 + m(0, 0) - m(1, 1) - m(2, 2)).sqrt() * 2.0;
        [
            (m(2, 1) - m(1, 2)) / s,
            s / 4.0,
            (m(0, 1) + m(1, 0)) / s,
            (m(0, 2) + m(2, 0)) / s,
        ]
    } else if m(1, 1) > m(2, 2) {
        let s = (1.0 + m(1, 1) - m(0, 0) - m(2, 2)).sqrt() * 2.0;
        [
            (m(0, 2) - m(2, 0)) / s,
            (m(0, 1) + m(1, 0)) / s,
            s / 4.0,
            (m(1, 2) + m(2, 1)) / s,
        ]
    } else {
        let s = (1.0 + m(2, 2) - m(0, 0) - m(1, 1)).sqrt() * 2.0;
        [
            (m(1, 0) - m(0, 1)) / s,
            (m(0, 2) + m(2, 0)) / s,
            (m(1, 2) + m(2, 1)) / s,
            s / 4.0,
        ]
    };
    normalize(q).unwrap_or([1.0, 0.0, 0.0, 0.0])
}

/// Spherical linear interpolation between unit quaternions (the shorter
/// arc), `s` in [0, 1].
pub fn slerp(a: [f64; 4], b: [f64; 4], s: f64) -> [f64; 4] {
    let mut d: f64 = a.iter().zip(&b).map(|(x, y)| x * y).sum();
    let b = if d < 0.0 {
        d = -d;
        b.map(|v| -v)
    } else {
        b
    };
    let (wa, wb) = if d > 1.0 - 1e-12 {
        (1.0 - s, s)
    } else {
        let th = d.min(1.0).acos();
        let sin = th.sin();
        (((1.0 - s) * th).sin() / sin, (s * th).sin() / sin)
    };
    let q = [0, 1, 2, 3].map(|i| wa * a[i] + wb * b[i]);
    normalize(q).unwrap_or(a)
}

impl Trajectory {
    /// From keyframes: at least one, times finite and strictly increasing,
    /// positions within ±1000 m, quaternions finite and non-zero. Errors name the
    /// keyframe and the field.
    pub fn new(mut keys: Vec<Keyframe>) -> Result<Trajectory, String> {
        if keys.is_empty() {
            return Err("trajectory: no keyframes".into());
        }
        for (i, k) in keys.iter_mut().enumerate() {
            if !k.t.is_finite() {
                return Err(format!("trajectory keyframe {i}: t: not finite"));
            }
            // (As every scene position: docs/scenes.md.)
            if !k.position.iter().all(|v| v.is_finite() && v.abs() <= 1000.0) {
                return Err(format!(
                    "trajectory keyframe {i}: position: {:?} is not within ±1000 m of the origin",
                    k.position
                ));
            }
            k.quaternion = normalize(k.quaternion)
                .ok_or_else(|| format!("trajectory keyframe {i}: quaternion: zero or not finite"))?;
        }
        if let Some(i) = keys.windows(2).position(|w| w[1].t <= w[0].t) {
            return Err(format!(
                "trajectory keyframe {}: t: not after keyframe {i}'s",
                i + 1
            ));
        }
        Ok(Trajectory { keys })
    }

    /// Keyframes from a file of JSON lines (`{"t": 0.0, "position": [x, y,
    /// z], "quaternion": [w, x, y, z]}`) or CSV lines (`t,x,y,z,qw,qx,qy,qz`;
    /// a header line and `#` comments are skipped).
    pub fn parse(text: &str) -> Result<Trajectory, String> {
        let mut keys = Vec::new();
        for (n, line) in text.lines().enumerate() {
            let line = line.trim();
            if line.is_empty() || line.starts_with('#') {
                continue;
            }
            let k = if line.starts_with('{') {
                serde_json::from_str::<Keyframe>(line).map_err(|e| format!("line {}: {e}", n + 1))?
            } else {
                let v: Result<Vec<f64>, _> = line.split(',').map(|f| f.trim().parse::<f64>()).collect();
                match v {
                    Ok(v) if v.len() == 8 => Keyframe {
                        t: v[0],
                        position: [v[1], v[2], v[3]],
                        quaternion: [v[4], v[5], v[6], v[7]],
                    },
                    Ok(v) => {
                        return Err(format!(
                            "line {}: {} fields; t,x,y,z,qw,qx,qy,qz are 8",
                            n + 1,
                            v.len()
                        ))
                    }
                    Err(_) if keys.is_empty() && n == 0 => continue, // a header
                    Err(e) => return Err(format!("line {}: {e}", n + 1)),
                }
            };
            keys.push(k);
        }
        Trajectory::new(keys)
    }

    /// A small loop around `base` over `duration` s: the camera moves 5 cm
    /// along its own x axis and back, 5 cm the other way and back, turning
    /// 2° about its y axis as it goes (five keyframes).
    pub fn wobble(base: &Pose, duration: f64) -> Trajectory {
        let q0 = quaternion_of(&base.rotation);
        let x_axis = base.rotation[0];
        let y_axis = base.rotation[1];
        let key = |s: f64, side: f64| {
            let a = side * 2f64.to_radians() / 2.0;
            // A turn about the camera's y axis, composed on the world side.
            let turn = [
                a.cos(),
                y_axis[0] * a.sin(),
                y_axis[1] * a.sin(),
                y_axis[2] * a.sin(),
            ];
            Keyframe {
                t: s * duration,
                position: [0, 1, 2].map(|i| base.translation[i] + side * 0.05 * x_axis[i]),
                quaternion: mul(turn, q0),
            }
        };
        Trajectory {
            keys: vec![
                key(0.0, 0.0),
                key(0.25, 1.0),
                key(0.5, 0.0),
                key(0.75, -1.0),
                key(1.0, 0.0),
            ],
        }
    }

    /// Time of the first and last keyframe, s.
    pub fn span(&self) -> (f64, f64) {
        let first = self.keys.first().map_or(0.0, |k| k.t);
        (first, self.keys.last().map_or(first, |k| k.t))
    }

    /// The pose at `t` (held before the first and after the last keyframe).
    pub fn at(&self, t: f64) -> Pose {
        let pose = |k: &Keyframe| Pose {
            rotation: rotation_of(k.quaternion),
            translation: k.position,
        };
        let i = self.keys.partition_point(|k| k.t <= t);
        match (i.checked_sub(1).and_then(|j| self.keys.get(j)), self.keys.get(i)) {
            (Some(a), Some(b)) => {
                let s = (t - a.t) / (b.t - a.t);
                Pose {
                    rotation: rotation_of(slerp(a.quaternion, b.quaternion, s)),
                    translation: [0, 1, 2].map(|k| a.position[k] + s * (b.position[k] - a.position[k])),
                }
            }
            (Some(k), None) | (None, Some(k)) => pose(k),
            // `new` refuses an empty trajectory.
            (None, None) => Pose {
                rotation: rotation_of([1.0, 0.0, 0.0, 0.0]),
                translation: [0.0; 3],
            },
        }
    }

    /// `n` poses evenly spaced over the span (both ends included).
    pub fn sample(&self, n: usize) -> Vec<Pose> {
        let (t0, t1) = self.span();
        (0..n)
            .map(|k| {
                let s = if n > 1 { k as f64 / (n - 1) as f64 } else { 0.0 };
                self.at(t0 + s * (t1 - t0))
            })
            .collect()
    }
}

/// The quaternion product `a b`.
fn mul(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
    [
        a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
        a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
        a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
        a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
    ]
}
