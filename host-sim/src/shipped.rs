//! The shipped scenes (`scenes/*.toml`), embedded in the binary: what
//! `host-sim camera` holds by default, wherever the binary is run from.

use crate::scene_file::{parse, Resolved};

/// File stem and text of each shipped scene, in file-name order (the
/// firmware's scene ids).
pub const SHIPPED: [(&str, &str); 9] = [
    (
        "calibration-board",
        include_str!("../../scenes/calibration-board.toml"),
    ),
    (
        "checkerboard-barrel",
        include_str!("../../scenes/checkerboard-barrel.toml"),
    ),
    ("low-light", include_str!("../../scenes/low-light.toml")),
    ("shadows", include_str!("../../scenes/shadows.toml")),
    ("shallow-dof", include_str!("../../scenes/shallow-dof.toml")),
    ("shallow-target", include_str!("../../scenes/shallow-target.toml")),
    (
        "spheres-specular",
        include_str!("../../scenes/spheres-specular.toml"),
    ),
    ("standard", include_str!("../../scenes/standard.toml")),
    (
        "wide-vignetting",
        include_str!("../../scenes/wide-vignetting.toml"),
    ),
];

/// The shipped scenes, parsed and checked.
pub fn shipped() -> Result<Vec<Resolved>, String> {
    SHIPPED
        .iter()
        .map(|(name, text)| parse(text).map_err(|e| format!("scenes/{name}.toml (built in): {e}")))
        .collect()
}

#[cfg(test)]
mod tests {
    /// The embedded list is the directory's: no scene added or removed
    /// without it.
    #[test]
    fn the_embedded_scenes_are_the_directory_s() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes");
        let mut files: Vec<String> = std::fs::read_dir(&dir)
            .expect("scenes/")
            .filter_map(|e| e.ok())
            .filter_map(|e| e.file_name().to_str()?.strip_suffix(".toml").map(str::to_string))
            .collect();
        files.sort();
        let embedded: Vec<&str> = super::SHIPPED.iter().map(|(n, _)| *n).collect();
        assert_eq!(files, embedded);
        for (n, text) in super::SHIPPED {
            let on_disk = std::fs::read_to_string(dir.join(format!("{n}.toml"))).expect("scene");
            assert_eq!(on_disk, text, "{n}");
        }
        assert_eq!(super::shipped().expect("parse").len(), files.len());
    }
}
