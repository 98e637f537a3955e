//! f64 3-vectors for parameter conversion at construction (never per point
//! or per pixel).

pub(crate) type V = [f64; 3];

pub(crate) fn dot(a: V, b: V) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub(crate) fn cross(a: V, b: V) -> V {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

pub(crate) fn norm(a: V) -> f64 {
    libm::sqrt(dot(a, a))
}

/// `a / s`.
pub(crate) fn div(a: V, s: f64) -> V {
    [a[0] / s, a[1] / s, a[2] / s]
}
