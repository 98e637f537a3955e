//! The sensor stages a scene may ask for: pixel-area integration
//! (camera-model.md §7), defocus through the aperture (§8) and EMVA 1288
//! noise (§9).

pub mod defocus;
pub mod noise;
pub mod sampling;
