//! The camera's command side on arbitrary bytes: the receiver (COBS, CRC,
//! postcard) and the command state. It must not panic, and a refused
//! command must leave the scene as it was.
#![no_main]

use hilcam::control::{Answer, Control, Receiver, MAX_REQUEST};
use libfuzzer_sys::fuzz_target;
use std::sync::OnceLock;

fn standard() -> &'static hilcam::scene::Scene {
    static SCENE: OnceLock<hilcam::scene::Scene> = OnceLock::new();
    SCENE.get_or_init(|| {
        host_sim::scene_file::load(std::path::Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../scenes/standard.toml"
        )))
        .and_then(|r| r.core_scene())
        .expect("standard scene")
    })
}

fuzz_target!(|data: &[u8]| {
    let mut scene = standard().clone();
    let mut control = Control::new();
    let mut rx = Receiver::<MAX_REQUEST>::new();
    for b in data {
        if let Some(Ok(req)) = rx.push(*b) {
            let before = scene.clone();
            let answer = control.handle(&req, &mut scene, 2, |_| Ok(standard().clone()));
            if let Answer::Reject(..) = answer {
                assert_eq!(scene, before, "a refused command changed the scene");
            }
            while control.frame_due(0) {}
        }
    }
    assert_eq!(rx.stats.bytes, data.len() as u64);
});
