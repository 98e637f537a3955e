//! Renders a small scene with the core alone and writes it as a PGM image.
//!
//! ```sh
//! cargo run --example render -- sphere.pgm
//! ```
//!
//! A checkered floor and a sphere under a point light, 320×240 Gray8,
//! rendered the way the planner picks within the default error budget
//! (1/256 px, 1 LSB); the plan's choice and its predicted error and cost
//! are printed.

use hilcam::render::{Image, LineBuffers};
use hilcam::{Aperture, Budget, Camera, CheckerSpec, Distortion, Extrinsics, Frame};
use hilcam::{IntrinsicsConfig, LensConfig, Model, PixelFormat, Scene, ShapeSpec};
use std::error::Error;

fn main() -> Result<(), Box<dyn Error>> {
    let out = std::env::args().nth(1).unwrap_or_else(|| "render.pgm".into());

    // The camera: a 3 mm lens at f/4 on a 320×240 sensor of 6 µm pixels,
    // 2 m from the origin and looking at it.
    let sensor = IntrinsicsConfig {
        focal_length: 3e-3,
        pitch: (6e-6, 6e-6),
        size: (320, 240),
        principal_point: None,
    };
    let lens = LensConfig {
        aperture: Aperture::FNumber(4.0),
        focus_distance: 2.0,
        tolerable_blur: 6e-6,
    };
    let pose = Extrinsics::look_at([0.0, 0.8, -2.0], [0.0, 0.0, 0.0], [0.0, 1.0, 0.0])?;
    let camera = Camera::new(&sensor, &lens, pose, Model::Perspective)?;

    // The scene: exposure K in DN per W/m², ambient and background radiance.
    let mut scene = Scene::new(
        camera,
        Distortion::NONE,
        PixelFormat::Gray8,
        2e4,
        [0.03; 3],
        [0.0; 3],
    )?;
    let light_grey = scene.add_material([0.7; 3], [0.0; 3], 1.0, 0)?;
    let dark_grey = scene.add_material([0.2; 3], [0.0; 3], 1.0, 0)?;
    let floor = ShapeSpec::Plane {
        point: [0.0, -0.4, 0.0],
        normal: [0.0, 1.0, 0.0],
    };
    let checker = CheckerSpec {
        cell: 0.2,
        u_axis: [1.0, 0.0, 0.0],
        material: dark_grey,
    };
    scene.add_primitive(floor, light_grey, Some(checker))?;
    let sphere = ShapeSpec::Sphere {
        centre: [0.0, 0.0, 0.0],
        radius: 0.4,
    };
    scene.add_primitive(sphere, light_grey, None)?;
    scene.add_point_light([1.0, 2.0, -1.0], [4.0; 3])?;

    // The planner's choice, and the frame prepared for it.
    let plan = hilcam::planner::plan(&scene, &Budget::default());
    if let Some(c) = plan.candidates.get(plan.chosen) {
        println!(
            "plan: {} ({:.2e} px, {:.2} LSB predicted; {:.0} M3 instructions a pixel)",
            c.name(),
            c.geom_err_px,
            c.lsb,
            c.m3_instructions_per_pixel
        );
    }
    let frame = Frame::new(&scene, &plan.options)?;

    // The whole frame into one buffer.
    let (w, h) = frame.size();
    let mut image = vec![0u8; frame.line_bytes() * h as usize];
    let mut flags = vec![0u8; w as usize];
    frame.render(LineBuffers::new(&mut [], &mut flags), &mut Image::new(&mut image))?;

    let mut pgm = format!("P5\n{w} {h}\n255\n").into_bytes();
    pgm.extend_from_slice(&image);
    std::fs::write(&out, pgm)?;
    println!("{out}: {w}x{h} Gray8");
    Ok(())
}
