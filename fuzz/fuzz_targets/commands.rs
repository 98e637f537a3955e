//! The camera's command side on arbitrary bytes: the receiver (COBS, CRC,
//! postcard), the command state and scenes loaded as data. It must not
//! panic, and a refused command must leave the scene as it was.
#![no_main]

use hilcam::link::control::{Answer, Control, Library, Receiver};
use hilcam::link::MAX_REQUEST;
use hilcam::scene::data::MAX_SCENE_DATA;
use libfuzzer_sys::fuzz_target;
use std::sync::OnceLock;

/// The standard scene as data (the library's scene 0).
fn standard() -> &'static [u8] {
    static SCENE: OnceLock<Vec<u8>> = OnceLock::new();
    SCENE.get_or_init(|| {
        host_sim::scene_file::load(std::path::Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../scenes/standard.toml"
        )))
        .and_then(|r| r.scene_bytes())
        .expect("standard scene")
    })
}

fuzz_target!(|data: &[u8]| {
    // The same bytes as scene data: refused or built, never a panic.
    let _ = hilcam::scene::data::load(data);
    let blobs = [standard()];
    let mut library = Library::<MAX_SCENE_DATA>::new(&blobs, 640);
    let mut scene = library.scene(0).expect("scene 0");
    let mut control = Control::new();
    let mut rx = Receiver::<MAX_REQUEST>::new();
    for b in data {
        if let Some(Ok(req)) = rx.push(*b) {
            let before = scene.clone();
            let answer = control.handle(&req, &mut scene, &mut library);
            if let Answer::Reject(..) = answer {
                assert_eq!(scene, before, "a refused command changed the scene");
            }
            while control.frame_due(0) {}
        }
    }
    assert_eq!(rx.stats.bytes, data.len() as u64);
});
