//! The core's test suite, as one test binary: each module was its own
//! integration-test crate, and each of those compiled the renderer's generic
//! line loops again (five of them 32–80 s apiece in the test command's
//! build). Run one module with `cargo test --test core_tests MODULE::`.

mod common;

mod control;
mod distortion;
mod extremes;
mod extremes_render;
mod golden;
mod lens;
mod mix32;
mod planner;
mod projection;
mod render;
mod scene_data;
mod shading;
mod shadows;
