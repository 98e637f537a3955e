//! Reference renderer (camera-model.md §3, §5–§9), in f64.
//!
//! Built from the same parsed scene file as the core, but independently: the
//! ray of each pixel is taken into the world frame and intersected there
//! (the core moves the scene into the camera frame instead), distortion is
//! the polynomial itself (the core uses a table), and the scene's declared
//! camera model is used (the core may render an approximation the planner
//! chose).

use super::distortion::{Lens, Radial};
use super::extrinsics::Pose;
use super::intrinsics::Sensor;
use super::noise::NoiseModel;
use super::sampling::Pattern;
use super::shading::{self, Light, Material};
use super::shadows;
use super::vignetting;
use super::{cross, dot, unit, V3};
use crate::scene_file::{LightData, Pose as PoseSpec, Resolved};
use hilcam::scene::{PixelFormat, ShapeSpec};

/// A shape in the world frame.
#[derive(Clone, Copy, Debug)]
pub(super) enum Shape {
    Plane {
        p: V3,
        n: V3,
    },
    Sphere {
        c: V3,
        r: f64,
    },
    Disc {
        c: V3,
        n: V3,
        r: f64,
    },
    Rect {
        c: V3,
        n: V3,
        u: V3,
        v: V3,
        hu: f64,
        hv: f64,
    },
}

impl Shape {
    /// Where the line `o + t d` meets the shape: up to two `(t, unit
    /// normal)`, `t` of either sign.
    pub(super) fn meets(&self, o: V3, d: V3) -> [Option<(f64, V3)>; 2] {
        match *self {
            Shape::Plane { p, n } => [line_plane(o, d, p, n).map(|t| (t, n)), None],
            Shape::Disc { c, n, r } => [
                line_plane(o, d, c, n).and_then(|t| {
                    let q = sub(at(o, d, t), c);
                    (dot(q, q) <= r * r).then_some((t, n))
                }),
                None,
            ],
            Shape::Rect { c, n, u, v, hu, hv } => [
                line_plane(o, d, c, n).and_then(|t| {
                    let q = sub(at(o, d, t), c);
                    (dot(q, u).abs() <= hu && dot(q, v).abs() <= hv).then_some((t, n))
                }),
                None,
            ],
            Shape::Sphere { c, r } => {
                let oc = sub(o, c);
                let a = dot(d, d);
                let b = dot(oc, d);
                let cc = dot(oc, oc) - r * r;
                let disc = b * b - a * cc;
                if disc < 0.0 {
                    return [None, None];
                }
                let s = disc.sqrt();
                [(-b - s) / a, (-b + s) / a].map(|t| {
                    let q = sub(at(o, d, t), c);
                    Some((t, [q[0] / r, q[1] / r, q[2] / r]))
                })
            }
        }
    }
}

#[derive(Clone, Copy, Debug)]
struct Checker {
    origin: V3,
    u: V3,
    v: V3,
    cell: f64,
    material: usize,
}

#[derive(Clone, Copy, Debug)]
struct Prim {
    shape: Shape,
    material: usize,
    checker: Option<Checker>,
}

/// The camera's model as declared by the scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RefModel {
    /// Perspective.
    Perspective,
    /// Orthographic with scale `m`.
    Orthographic(f64),
}

/// What a ray sees, for edge detection: in the lens field, and which
/// primitive and texture cell it hits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Key {
    /// Inside the lens field.
    pub in_field: bool,
    /// Primitive index hit, if any.
    pub prim: Option<usize>,
    /// Texture cell, if the primitive is textured.
    pub cell: Option<(i64, i64)>,
    /// Through the aperture: a ray through its rim sees another primitive
    /// or cell than the chief ray (the point lies within the blurred
    /// extent of an edge; docs/sensor.md).
    pub mixed: bool,
    /// The lights shadowed at the point it sees (bit `i`: light `i`).
    pub shade: u8,
}

/// A scene in f64.
#[derive(Clone, Debug)]
pub struct RefScene {
    /// Sensor.
    pub sensor: Sensor,
    pose: Pose,
    /// Declared model.
    pub model: RefModel,
    radial: Option<Radial>,
    /// A calibrated lens and its valid field's radius.
    lens: Option<(Lens, f64)>,
    materials: Vec<Material>,
    prims: Vec<Prim>,
    lights: Vec<Light>,
    ambient: [f64; 3],
    background: [f64; 3],
    /// Cast shadows (§6).
    shadows: bool,
    exposure: f64,
    aperture: f64,
    /// Focus distance `Z̃`, metres.
    focus: f64,
    /// The aperture's points on the unit disc (empty: a pinhole), from
    /// `pattern.aperture`.
    spiral: Vec<(f64, f64)>,
    /// Output format.
    pub format: PixelFormat,
    /// The sample pattern (from the scene's `[sampling]`; the harness sets
    /// the one a frame was rendered with).
    pub pattern: Pattern,
    /// Sensor noise, if the scene asks.
    pub noise: Option<NoiseModel>,
    /// The frame id the noise is keyed by.
    pub frame_id: u32,
}

/// A rendered reference frame.
#[derive(Clone, Debug)]
pub struct RefFrame {
    /// Width.
    pub width: usize,
    /// Height.
    pub height: usize,
    /// Pixel values per channel (unused channels 0), row-major.
    pub dn: Vec<[u32; 3]>,
    /// Inside the lens field.
    pub in_field: Vec<bool>,
    /// Edge pixels: a 1/256 px move of the centre changes the key.
    pub edge: Vec<bool>,
    /// Undistorted normalized point of each pixel (None outside the field).
    pub undistorted: Vec<Option<(f64, f64)>>,
}

fn in_plane_axes(n: V3, u: V3) -> (V3, V3) {
    let u = unit(u);
    let d = dot(u, n);
    let u = unit([u[0] - d * n[0], u[1] - d * n[1], u[2] - d * n[2]]);
    (u, cross(n, u))
}

fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn at(o: V3, d: V3, t: f64) -> V3 {
    [o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]]
}

impl RefScene {
    /// From a parsed scene file.
    pub fn new(r: &Resolved) -> RefScene {
        let c = &r.desc.camera;
        let (sx, sy) = c.pitch.get();
        let mut sensor = Sensor::centred(c.focal_length, sx, sy, c.width as u32, c.height as u32);
        if let Some([ox, oy]) = c.principal_point {
            sensor.ox = ox;
            sensor.oy = oy;
        }
        let pose = pose_of(r);
        let model = match c.orthographic_scale {
            Some(m) if c.model == "orthographic" => RefModel::Orthographic(m),
            _ => RefModel::Perspective,
        };
        let radial = c.distortion.map(|[k1, k2]| Radial { k1, k2 });
        let lens = match c.lens() {
            Ok(Some(hilcam::scene::data::LensData::OpenCv(k))) => Some(Lens::OpenCv(k)),
            Ok(Some(hilcam::scene::data::LensData::Fisheye(k))) => Some(Lens::Fisheye(k)),
            _ => None,
        }
        .map(|l| (l, l.valid_radius()));
        let materials = r
            .desc
            .materials
            .iter()
            .map(|m| Material {
                albedo: m.albedo.rgb(),
                specular: m.specular.rgb(),
                mix: m.mix,
                exponent: m.exponent,
            })
            .collect();
        let prims = r
            .primitives
            .iter()
            .map(|p| {
                let (shape, plane) = match p.shape {
                    ShapeSpec::Plane { point, normal } => {
                        let n = unit(normal);
                        (Shape::Plane { p: point, n }, Some((point, n)))
                    }
                    ShapeSpec::Sphere { centre, radius } => (Shape::Sphere { c: centre, r: radius }, None),
                    ShapeSpec::Disc {
                        centre,
                        normal,
                        radius,
                    } => {
                        let n = unit(normal);
                        (
                            Shape::Disc {
                                c: centre,
                                n,
                                r: radius,
                            },
                            Some((centre, n)),
                        )
                    }
                    ShapeSpec::Rectangle {
                        centre,
                        normal,
                        u_axis,
                        size,
                    } => {
                        let n = unit(normal);
                        let (u, v) = in_plane_axes(n, u_axis);
                        (
                            Shape::Rect {
                                c: centre,
                                n,
                                u,
                                v,
                                hu: size[0] / 2.0,
                                hv: size[1] / 2.0,
                            },
                            Some((centre, n)),
                        )
                    }
                };
                let checker = match (p.checker, plane) {
                    (Some((cell, u_axis, material)), Some((origin, n))) => {
                        let (u, v) = in_plane_axes(n, u_axis);
                        Some(Checker {
                            origin,
                            u,
                            v,
                            cell,
                            material,
                        })
                    }
                    _ => None,
                };
                Prim {
                    shape,
                    material: p.material,
                    checker,
                }
            })
            .collect();
        let lights = r
            .lights
            .iter()
            .map(|l| match l {
                LightData::Point { position, intensity } => Light::Point {
                    position: *position,
                    intensity: intensity.rgb(),
                },
                LightData::Directional {
                    direction,
                    irradiance,
                } => Light::Directional {
                    towards: unit(*direction),
                    irradiance: irradiance.rgb(),
                },
            })
            .collect();
        RefScene {
            sensor,
            pose,
            model,
            radial,
            lens,
            materials,
            prims,
            lights,
            ambient: r.desc.environment.ambient.rgb(),
            background: r.desc.environment.background.rgb(),
            shadows: r.desc.environment.shadows,
            exposure: r.desc.output.exposure,
            aperture: r.aperture_diameter(),
            focus: r.desc.camera.focus_distance,
            spiral: Vec::new(),
            format: r.format,
            pattern: Pattern::CENTRE,
            noise: r.desc.noise.map(|n| NoiseModel {
                saturation: n.saturation,
                dark_noise: n.dark_noise,
                dark_offset: n.dark_offset,
                seed: u64::from(n.seed),
            }),
            frame_id: 0,
        }
        .with_pattern(Pattern::of_scene(r))
    }

    /// Where the world point `p` is imaged, in pixel coordinates (the
    /// declared model, then distortion, camera-model.md §1–§3); `None` if
    /// it is behind the camera or beyond the lens field's fold.
    pub fn project(&self, p: V3) -> Option<(f64, f64)> {
        let c = self.pose.world_to_camera(p);
        let (x, y) = match self.model {
            RefModel::Perspective if c[2] > 0.0 => (c[0] / c[2], c[1] / c[2]),
            RefModel::Perspective => return None,
            RefModel::Orthographic(m) => (m * c[0] / self.sensor.f, m * c[1] / self.sensor.f),
        };
        let (xd, yd) = match (self.radial, self.lens) {
            (Some(r), _) => r.distort(x, y)?,
            (None, Some((l, r_max))) => {
                if x.hypot(y) > r_max {
                    return None;
                }
                let (xd, yd) = l.forward_cv(-x, -y);
                (-xd, -yd)
            }
            (None, None) => (x, y),
        };
        Some(self.sensor.normalized_to_pixel(xd, yd))
    }

    /// Each checkered rectangle's inner corners, rectangle by rectangle and
    /// row by row: `f(rectangle, texture coordinates (m), world point)`.
    /// Nothing is held: a board of millions of cells costs time, not
    /// memory.
    pub fn for_each_checker_corner(&self, mut f: impl FnMut(usize, [f64; 2], V3)) {
        let rects = self.prims.iter().filter_map(|p| match (p.shape, p.checker) {
            (Shape::Rect { c, u, v, hu, hv, .. }, Some(ch)) => Some((c, u, v, hu, hv, ch)),
            _ => None,
        });
        for (index, (c, u, v, hu, hv, ch)) in rects.enumerate() {
            let reach = |h: f64| ((h - ch.cell) / ch.cell + 1e-9).floor() as i64;
            // Enough cells either way for any in-plane texture direction;
            // the test below keeps those inside the rectangle.
            let reach = reach(hu.max(hv)) + 1;
            for l in -reach..=reach {
                for k in -reach..=reach {
                    let (a, b) = (k as f64 * ch.cell, l as f64 * ch.cell);
                    let q = [
                        ch.origin[0] + a * ch.u[0] + b * ch.v[0],
                        ch.origin[1] + a * ch.u[1] + b * ch.v[1],
                        ch.origin[2] + a * ch.u[2] + b * ch.v[2],
                    ];
                    let rel = sub(q, c);
                    let inside =
                        dot(rel, u).abs() <= hu - ch.cell + 1e-9 && dot(rel, v).abs() <= hv - ch.cell + 1e-9;
                    if inside {
                        f(index, [a, b], q);
                    }
                }
            }
        }
    }

    /// The number of checkered rectangles.
    pub fn checkered_rectangles(&self) -> usize {
        self.prims
            .iter()
            .filter(|p| matches!((p.shape, p.checker), (Shape::Rect { .. }, Some(_))))
            .count()
    }

    /// This scene sampled with `pattern`.
    pub fn with_pattern(&self, pattern: Pattern) -> RefScene {
        let spiral = if pattern.aperture == self.pattern.aperture && !self.spiral.is_empty() {
            self.spiral.clone()
        } else if pattern.aperture > 0 {
            super::defocus::spiral(pattern.aperture)
        } else {
            Vec::new()
        };
        RefScene {
            pattern,
            spiral,
            ..self.clone()
        }
    }

    /// Pixel position → undistorted normalized point; `None` outside the
    /// lens field.
    pub fn undistorted(&self, xi: f64, yi: f64) -> Option<(f64, f64)> {
        let (xd, yd) = self.sensor.pixel_to_normalized(xi, yi);
        match (self.radial, self.lens) {
            (Some(r), _) => r.undistort(xd, yd),
            (None, Some((l, r_max))) => l.undistort(xd, yd, r_max).map(|(x, y, _)| (x, y)),
            (None, None) => Some((xd, yd)),
        }
    }

    /// The world-frame ray of an undistorted normalized point.
    fn ray(&self, x: f64, y: f64) -> (V3, V3) {
        match self.model {
            RefModel::Perspective => self.to_world([0.0; 3], [x, y, 1.0]),
            RefModel::Orthographic(m) => {
                let f = self.sensor.f;
                self.to_world([x * f / m, y * f / m, 0.0], [0.0, 0.0, 1.0])
            }
        }
    }

    /// A camera-frame ray (origin, direction) in the world frame.
    fn to_world(&self, o: V3, d: V3) -> (V3, V3) {
        let ow = self.pose.camera_to_world(o);
        let dw = sub(self.pose.camera_to_world(d), self.pose.t);
        (ow, dw)
    }

    /// Nearest hit `t > 0`: (t, primitive index, unit normal).
    fn hit(&self, o: V3, d: V3) -> Option<(f64, usize, V3)> {
        let mut best: Option<(f64, usize, V3)> = None;
        for (i, p) in self.prims.iter().enumerate() {
            for (t, n) in p.shape.meets(o, d).into_iter().flatten() {
                if t > 0.0 && best.is_none_or(|(bt, _, _)| t < bt) {
                    best = Some((t, i, n));
                }
            }
        }
        best
    }

    /// The lights a point `p` with unit normal `n` (towards the viewer)
    /// does not receive (§6): bit `i` set where light `i` shines on its
    /// side and a primitive meets the way to it. Shadows off: none.
    fn shadowed(&self, p: V3, n: V3) -> u8 {
        if !self.shadows {
            return 0;
        }
        let mut mask = 0;
        for (i, light) in self.lights.iter().enumerate() {
            let (d, t_max) = match *light {
                Light::Point { position, .. } => (sub(position, p), 1.0),
                Light::Directional { towards, .. } => (towards, f64::INFINITY),
            };
            let meets = self
                .prims
                .iter()
                .map(|q| q.shape.meets(p, d).map(|h| h.map(|(t, _)| t)));
            if dot(n, d) > 0.0 && shadows::blocked(meets, d, t_max) {
                mask |= 1 << i;
            }
        }
        mask
    }

    fn cell(&self, prim: usize, p: V3) -> Option<(i64, i64)> {
        let c = self.prims[prim].checker?;
        let q = sub(p, c.origin);
        Some((
            (dot(q, c.u) / c.cell).floor() as i64,
            (dot(q, c.v) / c.cell).floor() as i64,
        ))
    }

    /// What the ray through pixel position `(xi, yi)` sees; through the
    /// aperture under the adaptive rule, also whether the rays from its rim
    /// at the eight angles `kπ/4` through the same point in focus see the
    /// same (docs/sensor.md, "Defocus and the adaptive rule").
    pub fn key(&self, xi: f64, yi: f64) -> Key {
        let Some((x, y)) = self.undistorted(xi, yi) else {
            return Key {
                in_field: false,
                prim: None,
                cell: None,
                mixed: false,
                shade: 0,
            };
        };
        let (o, d) = self.ray(x, y);
        let key = self.key_along(o, d);
        // (Only the adaptive rule asks: with one sample, or the grid on
        // every pixel, nothing is decided at a blurred extent.)
        let adaptive = self.pattern.n > 1 && self.pattern.adaptive;
        if self.model != RefModel::Perspective || self.spiral.is_empty() || !adaptive {
            return key;
        }
        let f = [self.focus * x, self.focus * y, self.focus];
        let r = self.aperture / 2.0;
        let mixed = (0..8).any(|k| {
            let t = f64::from(k) * std::f64::consts::FRAC_PI_4;
            let a = [r * t.cos(), r * t.sin(), 0.0];
            let (o, d) = self.to_world(a, sub(f, a));
            self.key_along(o, d) != key
        });
        Key { mixed, ..key }
    }

    /// What the world-frame ray `o + t d` sees (in the field).
    fn key_along(&self, o: V3, d: V3) -> Key {
        match self.hit(o, d) {
            None => Key {
                in_field: true,
                prim: None,
                cell: None,
                mixed: false,
                shade: 0,
            },
            Some((t, i, n)) => {
                let p = at(o, d, t);
                let n = if dot(n, d) > 0.0 { [-n[0], -n[1], -n[2]] } else { n };
                Key {
                    in_field: true,
                    prim: Some(i),
                    cell: self.cell(i, p),
                    mixed: false,
                    shade: self.shadowed(p, n),
                }
            }
        }
    }

    /// The pose.
    pub fn pose(&self) -> Pose {
        self.pose
    }

    /// The radial distortion, if any.
    pub fn radial(&self) -> Option<Radial> {
        self.radial
    }

    /// The calibrated lens, if any, and its valid field's radius.
    pub fn lens(&self) -> Option<(Lens, f64)> {
        self.lens
    }

    /// The camera-frame depth `z` of what the chief ray through pixel
    /// position `(xi, yi)` hits; `None` outside the lens field or if it
    /// hits nothing.
    pub fn depth(&self, xi: f64, yi: f64) -> Option<f64> {
        let (x, y) = self.undistorted(xi, yi)?;
        let (o, d) = self.ray(x, y);
        let (t, _, _) = self.hit(o, d)?;
        Some(self.pose.world_to_camera(at(o, d, t))[2])
    }

    /// Pixel values of the sample at pixel position `(xi, yi)` per
    /// channel (rounded, no noise), and whether it is in the lens field.
    pub fn pixel(&self, xi: f64, yi: f64) -> ([u32; 3], bool) {
        match self.sample(xi, yi) {
            None => ([0; 3], false),
            Some(v) => (
                [0, 1, 2].map(|c| {
                    if c < self.format.channels() {
                        vignetting::round_dn(v[c], self.format.dn_max(c))
                    } else {
                        0
                    }
                }),
                true,
            ),
        }
    }

    /// `K E` per channel at pixel position `(xi, yi)`, DN before rounding;
    /// `None` outside the lens field.
    pub fn sample(&self, xi: f64, yi: f64) -> Option<[f64; 3]> {
        let (x, y) = self.undistorted(xi, yi)?;
        let radiance = if self.model == RefModel::Perspective && !self.spiral.is_empty() {
            // §8: the mean over the aperture's points A of the radiance
            // along the ray from A through F = Z̃ (x̂, ŷ, 1).
            let f = [self.focus * x, self.focus * y, self.focus];
            let r = self.aperture / 2.0;
            let mut sum = [0.0; 3];
            for (u, v) in &self.spiral {
                let a = [r * u, r * v, 0.0];
                let (o, d) = self.to_world(a, sub(f, a));
                let l = self.radiance(o, d);
                for c in 0..3 {
                    sum[c] += l[c];
                }
            }
            sum.map(|s| s / self.spiral.len() as f64)
        } else {
            let (o, d) = self.ray(x, y);
            self.radiance(o, d)
        };
        // §5: cos⁴α of the undistorted point (none for a telecentric
        // camera), times the distortion's area factor where there is one.
        let cos4 = match self.model {
            RefModel::Orthographic(_) => 1.0,
            RefModel::Perspective => vignetting::cos4(x, y),
        };
        let (xd, yd) = self.sensor.pixel_to_normalized(xi, yi);
        let cos4 = match (self.radial, self.lens) {
            (Some(r), _) => cos4 * r.area_factor(xd, yd),
            (None, Some((l, r_max))) => cos4 * l.undistort(xd, yd, r_max).map_or(1.0, |(_, _, j)| j),
            (None, None) => cos4,
        };
        let mut v = [0.0; 3];
        for (c, v) in v.iter_mut().enumerate().take(self.format.channels()) {
            let e = vignetting::irradiance(radiance[c], self.aperture, self.sensor.f, cos4);
            // K is in DN of channel 0; a channel with a larger full scale
            // (RGB565 green) scales it by dn_max(c) / dn_max(0).
            let k = self.exposure * self.format.dn_max(c) as f64 / self.format.dn_max(0) as f64;
            *v = k * e;
        }
        Some(v)
    }

    /// The radiance along the world-frame ray `o + t d`, per channel.
    fn radiance(&self, o: V3, d: V3) -> [f64; 3] {
        match self.hit(o, d) {
            None => self.background,
            Some((t, i, n)) => {
                let p = at(o, d, t);
                let mut m = self.prims[i].material;
                if let (Some(c), Some((cu, cv))) = (self.prims[i].checker, self.cell(i, p)) {
                    if (cu + cv).rem_euclid(2) == 1 {
                        m = c.material;
                    }
                }
                let n = if dot(n, d) > 0.0 { [-n[0], -n[1], -n[2]] } else { n };
                let dl = dot(d, d).sqrt();
                let v = [-d[0] / dl, -d[1] / dl, -d[2] / dl];
                let shadowed = self.shadowed(p, n);
                shading::radiance(
                    &self.materials[m],
                    &self.lights,
                    self.ambient,
                    (p, n, v),
                    shadowed,
                )
            }
        }
    }

    /// The mean `K E` of pixel `(i, j)` under the pattern (§7): `None` if
    /// any sample the pattern takes lies outside the lens field.
    pub fn area_mean(&self, i: usize, j: usize) -> Option<[f64; 3]> {
        let (x, y) = (i as f64, j as f64);
        let p = self.pattern;
        if !self.takes_grid(i, j) {
            return self.sample(x, y);
        }
        let off = p.offsets();
        let mut sum = [0.0; 3];
        for b in &off {
            for a in &off {
                let v = self.sample(x + a, y + b)?;
                for c in 0..3 {
                    sum[c] += v[c];
                }
            }
        }
        let n2 = f64::from(p.n) * f64::from(p.n);
        Some(sum.map(|s| s / n2))
    }

    /// Whether the pattern takes the grid at pixel `(i, j)`: always with
    /// more than one sample, unless the adaptive rule finds its four
    /// corners and its centre in the field and seeing the same primitive
    /// and texture cell (through the aperture, with their rims too).
    pub fn takes_grid(&self, i: usize, j: usize) -> bool {
        let (x, y) = (i as f64, j as f64);
        let p = self.pattern;
        if p.n <= 1 {
            return false;
        }
        if !p.adaptive {
            return true;
        }
        let centre = self.key(x, y);
        let corners = [(-0.5, -0.5), (0.5, -0.5), (-0.5, 0.5), (0.5, 0.5)];
        !(centre.in_field && !centre.mixed && corners.iter().all(|(a, b)| self.key(x + a, y + b) == centre))
    }

    /// Pixel `(i, j)`'s values per channel (§7 and §9), and whether it is in
    /// the lens field.
    pub fn pixel_value(&self, i: usize, j: usize) -> ([u32; 3], bool) {
        let Some(mean) = self.area_mean(i, j) else {
            return ([0; 3], false);
        };
        let p = (j * self.sensor.width as usize + i) as u64;
        let dn0 = self.format.dn_max(0);
        let mut dn = [0u32; 3];
        for (c, d) in dn.iter_mut().enumerate().take(self.format.channels()) {
            let max = self.format.dn_max(c);
            *d = match &self.noise {
                None => vignetting::round_dn(mean[c], max),
                Some(n) => n.record(mean[c], max, dn0, n.deviate(self.frame_id, p, c as u64)),
            };
        }
        (dn, true)
    }

    /// Whether pixel `(i, j)` is an edge pixel: a 1/256 px move of its
    /// centre, or (sampled) of any of its corners inwards or outwards,
    /// changes what the ray sees — where core and reference may decide
    /// differently.
    pub fn is_edge(&self, i: usize, j: usize) -> bool {
        let (x, y) = (i as f64, j as f64);
        let e = 1.0 / 256.0;
        let k = self.key(x, y);
        let centre = [(x + e, y), (x - e, y), (x, y + e), (x, y - e)]
            .into_iter()
            .any(|(a, b)| self.key(a, b) != k);
        if centre || self.pattern.n <= 1 {
            return centre;
        }
        let mut pts = Vec::with_capacity(8);
        for (a, b) in [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)] {
            for r in [0.5 - e, 0.5 + e] {
                pts.push((x + a * r, y + b * r));
            }
        }
        pts.into_iter().any(|(a, b)| self.key(a, b) != k)
    }

    /// Renders line `j`, with edge pixels marked.
    pub fn render_line(&self, j: usize) -> RefFrame {
        let w = self.sensor.width as usize;
        let mut f = RefFrame {
            width: w,
            height: 1,
            dn: Vec::with_capacity(w),
            in_field: Vec::with_capacity(w),
            edge: Vec::with_capacity(w),
            undistorted: Vec::with_capacity(w),
        };
        let y = j as f64;
        for i in 0..w {
            let x = i as f64;
            let (dn, in_field) = self.pixel_value(i, j);
            let edge = self.is_edge(i, j);
            f.dn.push(dn);
            f.in_field.push(in_field);
            f.edge.push(edge);
            f.undistorted.push(self.undistorted(x, y));
        }
        f
    }

    /// Renders the frame, a line at a time ([`RefScene::render_line`]).
    pub fn render(&self) -> RefFrame {
        let (w, h) = (self.sensor.width as usize, self.sensor.height as usize);
        let mut f = RefFrame {
            width: w,
            height: h,
            dn: Vec::with_capacity(w * h),
            in_field: Vec::with_capacity(w * h),
            edge: Vec::with_capacity(w * h),
            undistorted: Vec::with_capacity(w * h),
        };
        for j in 0..h {
            f.append(self.render_line(j));
        }
        f
    }
}

impl RefFrame {
    /// Appends the lines of `o` (of the same width).
    pub fn append(&mut self, o: RefFrame) {
        self.dn.extend(o.dn);
        self.in_field.extend(o.in_field);
        self.edge.extend(o.edge);
        self.undistorted.extend(o.undistorted);
    }

    /// Line `j` as slices.
    pub fn row(&self, j: usize) -> RefRow<'_> {
        let r = j * self.width..(j + 1) * self.width;
        RefRow {
            dn: &self.dn[r.clone()],
            in_field: &self.in_field[r.clone()],
            edge: &self.edge[r.clone()],
            undistorted: &self.undistorted[r],
        }
    }
}

/// One line of a [`RefFrame`].
#[derive(Clone, Copy, Debug)]
pub struct RefRow<'a> {
    /// Pixel values per channel.
    pub dn: &'a [[u32; 3]],
    /// Inside the lens field.
    pub in_field: &'a [bool],
    /// Edge pixels.
    pub edge: &'a [bool],
    /// Undistorted normalized points.
    pub undistorted: &'a [Option<(f64, f64)>],
}

/// `t > 0` where the ray meets the plane through `p` with normal `n`.
/// The scene's camera pose, as its file gives it.
fn pose_of(r: &Resolved) -> Pose {
    match r.pose {
        PoseSpec::LookAt { eye, target, up } => Pose::look_at(eye, target, up),
        PoseSpec::Ypr {
            position,
            angles: [y, p, r],
        } => Pose::from_yaw_pitch_roll(y, p, r, position),
        PoseSpec::Matrix { position, rotation } => Pose {
            r: rotation,
            t: position,
        },
    }
}

fn line_plane(o: V3, d: V3, p: V3, n: V3) -> Option<f64> {
    let den = dot(n, d);
    if den == 0.0 {
        return None;
    }
    Some(dot(n, sub(p, o)) / den)
}
