//! Rendering a random valid scene: camera, distortion, materials, primitives
//! and lights drawn from the fuzz input within (and at the edges of) the
//! documented ranges. Whatever the builders accept must plan, prepare and
//! render without a panic, with every pixel within its format's range and
//! every out-of-field pixel black.
#![no_main]

use arbitrary::{Arbitrary, Unstructured};
use hilcam::geom::distortion::Distortion;
use hilcam::geom::lens::{Aperture, LensConfig};
use hilcam::planner::{plan, Budget};
use hilcam::render::{Frame, FLAG_OUTSIDE_FIELD};
use hilcam::scene::{CheckerSpec, PixelFormat, Scene, ShapeSpec};
use hilcam::{Camera, Extrinsics, IntrinsicsConfig, Model};
use libfuzzer_sys::fuzz_target;

/// A float in [lo, hi], or now and then an edge value.
fn f(u: &mut Unstructured, lo: f64, hi: f64) -> arbitrary::Result<f64> {
    let k = u8::arbitrary(u)?;
    Ok(match k {
        0 => lo,
        1 => hi,
        2 => f64::NAN,
        3 => -hi,
        _ => lo + (hi - lo) * (u32::arbitrary(u)? as f64 / u32::MAX as f64),
    })
}

fn v3(u: &mut Unstructured, r: f64) -> arbitrary::Result<[f64; 3]> {
    Ok([f(u, -r, r)?, f(u, -r, r)?, f(u, -r, r)?])
}

fn scene(u: &mut Unstructured) -> arbitrary::Result<Option<Scene>> {
    let w = u.int_in_range(1u16..=48)?;
    let h = u.int_in_range(1u16..=32)?;
    let intr = IntrinsicsConfig {
        focal_length: f(u, 1e-4, 10.0)?,
        pitch: (f(u, 1e-7, 1e-3)?, f(u, 1e-7, 1e-3)?),
        size: (w, h),
        principal_point: None,
    };
    let lens = LensConfig {
        aperture: Aperture::FNumber(f(u, 0.5, 256.0)?),
        focus_distance: f(u, 1e-3, 1e3)?,
        tolerable_blur: f(u, 1e-7, 1e-2)?,
    };
    let Ok(pose) = Extrinsics::look_at(v3(u, 50.0)?, v3(u, 50.0)?, v3(u, 1.0)?) else { return Ok(None) };
    let model = if bool::arbitrary(u)? {
        Model::Perspective
    } else {
        match Model::orthographic(f(u, 1e-6, 100.0)?) {
            Ok(m) => m,
            Err(_) => return Ok(None),
        }
    };
    let Ok(camera) = Camera::new(&intr, &lens, pose, model) else { return Ok(None) };
    let distortion = Distortion::new(f(u, -2.0, 2.0)?, f(u, -2.0, 2.0)?).unwrap_or(Distortion::NONE);
    let format = match u8::arbitrary(u)? % 3 {
        0 => PixelFormat::Gray8,
        1 => PixelFormat::Gray16 { bits: u.int_in_range(9u8..=16)? },
        _ => PixelFormat::Rgb565,
    };
    let Ok(mut s) = Scene::new(camera, distortion, format, f(u, 0.0, 1e6)?, v3(u, 10.0)?, v3(u, 10.0)?) else {
        return Ok(None);
    };
    for _ in 0..u.int_in_range(1u8..=4)? {
        let _ = s.add_material(v3(u, 1.0)?, v3(u, 1.0)?, f(u, 0.0, 1.0)?, u.int_in_range(0u16..=1000)?);
    }
    let nm = s.materials().len().max(1) as u8;
    for _ in 0..u.int_in_range(0u8..=6)? {
        let shape = match u8::arbitrary(u)? % 4 {
            0 => ShapeSpec::Plane { point: v3(u, 100.0)?, normal: v3(u, 1.0)? },
            1 => ShapeSpec::Sphere { centre: v3(u, 100.0)?, radius: f(u, 1e-4, 50.0)? },
            2 => ShapeSpec::Disc { centre: v3(u, 100.0)?, normal: v3(u, 1.0)?, radius: f(u, 1e-4, 50.0)? },
            _ => ShapeSpec::Rectangle {
                centre: v3(u, 100.0)?,
                normal: v3(u, 1.0)?,
                u_axis: v3(u, 1.0)?,
                size: [f(u, 2e-4, 50.0)?, f(u, 2e-4, 50.0)?],
            },
        };
        let checker = if bool::arbitrary(u)? {
            Some(CheckerSpec { cell: f(u, 1e-4, 10.0)?, u_axis: v3(u, 1.0)?, material: u8::arbitrary(u)? % nm })
        } else {
            None
        };
        let _ = s.add_primitive(shape, u8::arbitrary(u)? % nm, checker);
    }
    for _ in 0..u.int_in_range(0u8..=3)? {
        if bool::arbitrary(u)? {
            let _ = s.add_point_light(v3(u, 100.0)?, v3(u, 1e6)?);
        } else {
            let _ = s.add_directional_light(v3(u, 1.0)?, v3(u, 1e6)?);
        }
    }
    Ok(Some(s))
}

fuzz_target!(|data: &[u8]| {
    let mut u = Unstructured::new(data);
    let Ok(Some(s)) = scene(&mut u) else { return };
    let p = plan(&s, &Budget::default());
    let Ok(frame) = Frame::new(&s, &p.options) else { return };
    let (w, h) = frame.size();
    let mut line = vec![0u8; frame.line_bytes()];
    let mut flags = vec![0u8; w as usize];
    let bpp = s.format().bytes_per_pixel();
    for j in 0..h {
        frame.render_line(j, &mut line, &mut flags).expect("buffers are large enough");
        for (px, fl) in line.chunks_exact(bpp).zip(&flags) {
            let v = match bpp {
                1 => px[0] as u32,
                _ => u16::from_le_bytes([px[0], px[1]]) as u32,
            };
            if let PixelFormat::Gray16 { bits } = s.format() {
                assert!(v < 1 << bits, "value {v} beyond {bits} bits");
            }
            if fl & FLAG_OUTSIDE_FIELD != 0 {
                assert_eq!(v, 0, "out-of-field pixel not black");
            }
        }
    }
});
