//! The scene-file parser on arbitrary text: it must not panic, and a scene
//! it accepts must build a core scene.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|text: &str| {
    if let Ok(r) = host_sim::scene_file::parse(text) {
        assert!(r.core_scene().is_ok(), "parse accepted a scene the core rejects");
    }
});
