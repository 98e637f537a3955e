//! Scenes as data: the core's reader (`scene_data::load`) against
//! postcard's encoder on arbitrary scenes, against the scene builders
//! called directly; truncated, padded and non-canonical encodings refused;
//! the largest scene's size.

use hilcam::geom::calibrated::Calibrated;
use hilcam::geom::distortion::Distortion;
use hilcam::geom::lens::Aperture;
use hilcam::scene::data::{
    load, CameraData, Colour, DataError, FormatData, LensData, LightData, MaterialData, NoiseData,
    PrimitiveData, SamplingData, SceneData, SpecularData, MAX_SCENE_DATA,
};
use hilcam::scene::{CheckerSpec, Item, Scene, ShapeSpec, MAX_LIGHTS, MAX_MATERIALS, MAX_PRIMITIVES};
use hilcam::{Camera, Extrinsics, IntrinsicsConfig, LensConfig, Model};
use proptest::prelude::*;
use std::path::Path;

fn encode(d: &SceneData) -> Vec<u8> {
    postcard::to_stdvec(d).expect("encodes")
}

/// The oracle: the scene builders called with the data's values directly.
fn direct(d: &SceneData) -> Result<Scene, DataError> {
    let c = &d.camera;
    let cam = DataError::Camera;
    let intr = IntrinsicsConfig {
        focal_length: c.focal_length,
        pitch: (c.pitch[0], c.pitch[1]),
        size: (c.width, c.height),
        principal_point: c.principal_point.map(|[x, y]| (x, y)),
    };
    let pose = Extrinsics::from_matrix(c.rotation, c.position).map_err(cam)?;
    let model = match c.orthographic_scale {
        None => Model::Perspective,
        Some(m) => Model::orthographic(m).map_err(cam)?,
    };
    let lens = LensConfig {
        aperture: c.aperture,
        focus_distance: c.focus_distance,
        tolerable_blur: c.tolerable_blur,
    };
    let camera = Camera::new(&intr, &lens, pose, model).map_err(cam)?;
    let distortion = match c.distortion {
        Some([k1, k2]) => Distortion::new(k1, k2).map_err(cam)?,
        None => Distortion::NONE,
    };
    // A colour triple in a one-channel format is refused, as a scene file's.
    let gray = hilcam::scene::PixelFormat::from(d.format).channels() == 1;
    let one = |c: &hilcam::scene::data::Colour, item, field| match c {
        hilcam::scene::data::Colour::Rgb(_) if gray => Err(DataError::Scene(hilcam::scene::SceneError {
            item,
            field,
            problem: hilcam::scene::Problem::OutOfRange,
        })),
        _ => Ok(()),
    };
    one(&d.ambient, Item::Scene, "environment.ambient")?;
    one(&d.background, Item::Scene, "environment.background")?;
    let mut s = Scene::new(
        camera,
        distortion,
        d.format.into(),
        d.exposure,
        d.ambient.rgb(),
        d.background.rgb(),
    )?;
    for (i, m) in d.materials.iter().enumerate() {
        one(&m.albedo, Item::Material(i as u8), "albedo")?;
        if let Some(sp) = &m.specular {
            one(&sp.albedo, Item::Material(i as u8), "specular")?;
        }
        let (sp, mix, e) = m
            .specular
            .map_or(([0.0; 3], 1.0, 0), |s| (s.albedo.rgb(), s.mix, s.exponent));
        s.add_material(m.albedo.rgb(), sp, mix, e)?;
    }
    for p in &d.primitives {
        s.add_primitive(p.shape, p.material, p.checker)?;
    }
    for (i, l) in d.lights.iter().enumerate() {
        match *l {
            LightData::Point { position, intensity } => {
                one(&intensity, Item::Light(i as u8), "intensity")?;
                s.add_point_light(position, intensity.rgb())?
            }
            LightData::Directional {
                direction,
                irradiance,
            } => {
                one(&irradiance, Item::Light(i as u8), "irradiance")?;
                s.add_directional_light(direction, irradiance.rgb())?
            }
        };
    }
    if let Some(sm) = d.sampling {
        s.set_sampling(sm.edge_error, sm.adaptive)?;
    }
    if let Some(n) = d.noise {
        s.set_noise(n.saturation, n.dark_noise, n.dark_offset, u64::from(n.seed))?;
    }
    if let Some(l) = d.lens {
        let lens = match l {
            LensData::OpenCv(c) => Calibrated::opencv(c),
            LensData::Fisheye(c) => Calibrated::fisheye(c),
        };
        s.set_calibrated(Some(lens.map_err(DataError::Camera)?))
            .map_err(DataError::Camera)?;
    }
    Ok(s)
}

fn shipped() -> Vec<(String, SceneData)> {
    let mut v: Vec<_> = std::fs::read_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes"))
        .expect("scenes/")
        .map(|e| e.expect("entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    v.sort();
    v.into_iter()
        .map(|p| {
            let r = host_sim::scene_file::load(&p).expect("scene");
            (r.desc.name.clone(), r.scene_data().expect("scene data"))
        })
        .collect()
}

/// Values near the valid ranges (and some outside them).
fn num() -> impl Strategy<Value = f64> {
    prop_oneof![
        4 => -2.0f64..2.0,
        1 => Just(0.0),
        1 => Just(1.0),
        1 => 1e-6f64..1e-2,
        1 => any::<f64>(),
    ]
}

fn arr<const N: usize>() -> impl Strategy<Value = [f64; N]> {
    proptest::collection::vec(num(), N).prop_map(|v| v.try_into().expect("length"))
}

fn colour() -> impl Strategy<Value = Colour> {
    prop_oneof![num().prop_map(Colour::Gray), arr::<3>().prop_map(Colour::Rgb)]
}

fn shape() -> impl Strategy<Value = ShapeSpec> {
    prop_oneof![
        (arr::<3>(), arr::<3>()).prop_map(|(point, normal)| ShapeSpec::Plane { point, normal }),
        (arr::<3>(), num()).prop_map(|(centre, radius)| ShapeSpec::Sphere { centre, radius }),
        (arr::<3>(), arr::<3>(), num()).prop_map(|(centre, normal, radius)| ShapeSpec::Disc {
            centre,
            normal,
            radius
        }),
        (arr::<3>(), arr::<3>(), arr::<3>(), arr::<2>()).prop_map(|(centre, normal, u_axis, size)| {
            ShapeSpec::Rectangle {
                centre,
                normal,
                u_axis,
                size,
            }
        }),
    ]
}

/// A shipped scene with arbitrary changes: a value replaced, items added
/// or dropped, options toggled.
fn scene() -> impl Strategy<Value = SceneData> {
    let base = shipped();
    (
        0..base.len(),
        proptest::option::of(colour()),
        proptest::collection::vec(
            (colour(), proptest::option::of((colour(), num(), any::<u16>()))),
            0..3,
        ),
        proptest::collection::vec(
            (shape(), 0u8..4, proptest::option::of((num(), arr::<3>(), 0u8..4))),
            0..3,
        ),
        proptest::collection::vec((any::<bool>(), arr::<3>(), colour()), 0..3),
        proptest::option::of((num(), any::<bool>())),
        (
            proptest::option::of((num(), num(), num(), any::<u32>())),
            proptest::option::of((any::<bool>(), any::<bool>(), arr::<12>())),
        ),
        (
            any::<u16>(),
            any::<u16>(),
            proptest::option::of(arr::<2>()),
            any::<bool>(),
        ),
        0u8..20,
    )
        .prop_map(
            move |(i, ambient, mats, prims, lights, sampling, (noise, lens), cam, bits)| {
                let mut d = base[i].1.clone();
                if let Some(a) = ambient {
                    d.ambient = a;
                }
                for (albedo, sp) in mats {
                    let m = MaterialData {
                        albedo,
                        specular: sp.map(|(albedo, mix, exponent)| SpecularData {
                            albedo,
                            mix,
                            exponent: exponent % 1200,
                        }),
                    };
                    let _ = d.materials.push(m);
                }
                for (shape, material, checker) in prims {
                    let p = PrimitiveData {
                        shape,
                        material,
                        checker: checker.map(|(cell, u_axis, material)| CheckerSpec {
                            cell,
                            u_axis,
                            material,
                        }),
                    };
                    let _ = d.primitives.push(p);
                }
                for (point, a, c) in lights {
                    let l = if point {
                        LightData::Point {
                            position: a,
                            intensity: c,
                        }
                    } else {
                        LightData::Directional {
                            direction: a,
                            irradiance: c,
                        }
                    };
                    let _ = d.lights.push(l);
                }
                d.sampling = sampling.map(|(edge_error, adaptive)| SamplingData {
                    edge_error: edge_error.abs() / 4.0,
                    adaptive,
                });
                d.noise = noise.map(|(s, n, o, seed)| NoiseData {
                    saturation: s.abs() * 1e4,
                    dark_noise: n.abs(),
                    dark_offset: o.abs(),
                    seed,
                });
                // A lens with radial distortion beside it is refused: drawn
                // with and without.
                if let Some((_, true, _)) = lens {
                    d.camera.distortion = None;
                }
                d.lens = lens.map(|(fisheye, _, c)| match fisheye {
                    true => LensData::Fisheye([c[0], c[1], c[2], c[3]]),
                    false => LensData::OpenCv(c),
                });
                let (w, h, pp, small) = cam;
                if small {
                    d.camera.width = w % 700;
                    d.camera.height = h % 500;
                    d.camera.principal_point = pp;
                }
                if bits > 0 {
                    d.format = FormatData::Gray16 { bits };
                }
                d
            },
        )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(500))]

    /// The reader reads what postcard's encoder wrote, value for value: the
    /// scene (or the first error) equals the builders' called directly.
    #[test]
    fn load_reads_what_postcard_writes(d in scene()) {
        let bytes = encode(&d);
        prop_assert!(bytes.len() <= MAX_SCENE_DATA);
        prop_assert_eq!(load(&bytes), direct(&d));
    }

    /// Any bytes: never a panic.
    #[test]
    fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..600)) {
        let _ = load(&bytes);
    }
}

/// Every shipped scene: read equals built; every strict prefix and a
/// trailing byte refused; an over-long varint refused.
#[test]
fn shipped_scenes_load_and_damaged_encodings_are_refused() {
    for (name, d) in shipped() {
        let bytes = encode(&d);
        assert_eq!(load(&bytes), direct(&d), "{name}");
        assert!(load(&bytes).is_ok(), "{name}");
        for n in 0..bytes.len() {
            assert!(load(&bytes[..n]).is_err(), "{name}: {n}-byte prefix read");
        }
        let mut padded = bytes.clone();
        padded.push(0);
        assert_eq!(load(&padded), Err(DataError::Malformed), "{name}");
        // The width (the first field) as an over-long varint.
        let w = d.camera.width;
        assert!(w >= 128, "{name}: a two-byte width");
        let mut long = vec![(w as u8) | 0x80, ((w >> 7) as u8) | 0x80, 0];
        long.extend_from_slice(&bytes[2..]);
        assert_eq!(load(&long), Err(DataError::Malformed), "{name}");
    }
}

/// The largest encoding with `m` materials, `p` primitives and `l` lights:
/// every value given per channel, every shape a rectangle with a checker,
/// every option given, every varint at its longest.
fn largest(m: usize, p: usize, l: usize) -> SceneData {
    let rgb = Colour::Rgb([0.5; 3]);
    let mut d = shipped()[0].1.clone();
    d.camera = CameraData {
        width: u16::MAX,
        height: u16::MAX,
        principal_point: Some([1.0; 2]),
        orthographic_scale: Some(1.0),
        aperture: Aperture::FNumber(2.0),
        distortion: Some([0.0; 2]),
        ..d.camera
    };
    d.format = FormatData::Gray16 { bits: 255 };
    d.ambient = rgb;
    d.background = rgb;
    d.materials.clear();
    d.primitives.clear();
    d.lights.clear();
    for _ in 0..m {
        let m = MaterialData {
            albedo: rgb,
            specular: Some(SpecularData {
                albedo: rgb,
                mix: 0.5,
                exponent: u16::MAX,
            }),
        };
        d.materials.push(m).expect("room");
    }
    for _ in 0..p {
        let p = PrimitiveData {
            shape: ShapeSpec::Rectangle {
                centre: [0.0; 3],
                normal: [0.0; 3],
                u_axis: [0.0; 3],
                size: [0.0; 2],
            },
            material: 255,
            checker: Some(CheckerSpec {
                cell: 1.0,
                u_axis: [0.0; 3],
                material: 255,
            }),
        };
        d.primitives.push(p).expect("room");
    }
    for _ in 0..l {
        let l = LightData::Directional {
            direction: [0.0; 3],
            irradiance: rgb,
        };
        d.lights.push(l).expect("room");
    }
    d.sampling = Some(SamplingData {
        edge_error: 0.5,
        adaptive: true,
    });
    d.noise = Some(NoiseData {
        saturation: 1.0,
        dark_noise: 1.0,
        dark_offset: 1.0,
        seed: u32::MAX,
    });
    d.lens = Some(LensData::OpenCv([0.0; 12]));
    d
}

/// The largest encoding is exactly `max_bytes` of its counts — with every
/// list full, MAX_SCENE_DATA — so a camera built for fewer items (the
/// firmware's capacities) holds an upload buffer that size.
#[test]
fn the_largest_scene_is_max_scene_data_bytes() {
    assert_eq!(
        encode(&largest(MAX_MATERIALS, MAX_PRIMITIVES, MAX_LIGHTS)).len(),
        MAX_SCENE_DATA
    );
    for (m, p, l) in [
        (1, 1, 1),
        (4, 4, 1),
        (2, 7, 3),
        (MAX_MATERIALS, 1, MAX_LIGHTS),
        (1, MAX_PRIMITIVES, 1),
    ] {
        assert_eq!(
            encode(&largest(m, p, l)).len(),
            hilcam::scene::data::max_bytes(m, p, l),
            "{m} materials, {p} primitives, {l} lights"
        );
    }
}
