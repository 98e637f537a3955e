//! The QEMU boards the firmware runs on, as data: `firmware/boards.toml`,
//! one entry a board, read by host-sim and by the firmware's build script.

use serde::Deserialize;
use std::sync::OnceLock;

/// The table, as the repository holds it.
const TABLE: &str = include_str!("../../firmware/boards.toml");

/// A board's UART0 (its registers: `firmware/src/board.rs`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Uart {
    /// Arm PL011 (lm3s6965evb).
    Pl011,
    /// Arm CMSDK APB UART (the MPS2 boards).
    Cmsdk,
    /// Nordic nRF51 UART (micro:bit).
    Nrf51,
}

impl Uart {
    /// The name the table and the firmware's cfg use.
    pub fn name(self) -> &'static str {
        match self {
            Uart::Pl011 => "pl011",
            Uart::Cmsdk => "cmsdk",
            Uart::Nrf51 => "nrf51",
        }
    }
}

/// One board of the table.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Spec {
    /// QEMU machine, and the name `--board` takes.
    pub name: String,
    /// The core, as tables print it (M3, M4F, M0, M33, M7).
    pub core: String,
    /// QEMU `-cpu`.
    pub cpu: String,
    /// Rust target.
    pub target: String,
    /// UART0's kind.
    pub uart: Uart,
    /// UART0's base address.
    pub uart_base: u64,
    /// SysTick's clock (the core clock), Hz.
    pub systick_hz: u64,
    /// Flash origin and length, bytes.
    pub flash: [u64; 2],
    /// RAM origin and length, bytes.
    pub ram: [u64; 2],
    /// The one-shot firmware's opt-level ("s" if absent).
    #[serde(default)]
    pub opt_level: Option<String>,
    /// The driven camera's opt-level ("s" if absent).
    #[serde(default)]
    pub camera_opt_level: Option<String>,
    /// Rustc flags the driven camera is built with besides.
    #[serde(default)]
    pub camera_rustflags: Option<String>,
    /// The driven camera's firmware features ("camera,mix32,sensor,status"
    /// if absent: no cast shadows, which the M3's and the M0's flash do not
    /// hold beside the camera).
    #[serde(default)]
    pub camera_features: Option<String>,
    /// Shipped scenes (file stems) the one-shot firmware leaves out by
    /// default, its RAM being too small for them.
    #[serde(default)]
    pub skip_scenes: Vec<String>,
}

#[derive(Deserialize)]
struct Table {
    board: Vec<Spec>,
}

/// Every board, in the table's order.
pub fn all() -> &'static [Spec] {
    static BOARDS: OnceLock<Vec<Spec>> = OnceLock::new();
    BOARDS.get_or_init(|| match toml::from_str::<Table>(TABLE) {
        Ok(t) => t.board,
        // The table is checked by the tests (`boards::tests`): an error
        // here is a broken checkout.
        Err(e) => panic!("firmware/boards.toml: {e}"),
    })
}

/// A board of the table.
#[derive(Clone, Copy, Debug)]
pub struct Board(&'static Spec);

impl PartialEq for Board {
    fn eq(&self, o: &Board) -> bool {
        self.0.name == o.0.name
    }
}

impl Eq for Board {}

impl Board {
    /// The board named `s` (its QEMU machine name).
    pub fn parse(s: &str) -> Result<Board, String> {
        all().iter().find(|b| b.name == s).map(Board).ok_or_else(|| {
            let names: Vec<&str> = all().iter().map(|b| b.name.as_str()).collect();
            format!("--board: expected one of {}, got {s:?}", names.join(", "))
        })
    }

    /// The first board of the table whose core is `core` (M3, M4F, ...),
    /// as the tables that show one board a core take it.
    pub fn by_core(core: &str) -> Option<Board> {
        all().iter().find(|b| b.core == core).map(Board)
    }

    /// Every board, in the table's order.
    pub fn every() -> impl Iterator<Item = Board> {
        all().iter().map(Board)
    }

    /// The board's entry.
    pub fn spec(self) -> &'static Spec {
        self.0
    }

    /// QEMU machine name.
    pub fn machine(self) -> &'static str {
        &self.0.name
    }

    /// QEMU `-cpu`.
    pub fn cpu(self) -> &'static str {
        &self.0.cpu
    }

    /// The core (M3, M4F, M0, M33, M7).
    pub fn core(self) -> &'static str {
        &self.0.core
    }

    /// Rust target.
    pub fn target(self) -> &'static str {
        &self.0.target
    }

    /// The firmware's opt-level on this board: the one-shot firmware's, or
    /// with `camera` the driven camera's.
    pub fn opt_level(self, camera: bool) -> &'static str {
        let o = if camera {
            &self.0.camera_opt_level
        } else {
            &self.0.opt_level
        };
        o.as_deref().unwrap_or("s")
    }

    /// Extra `rustc` flags for the firmware on this board, as the target's
    /// `RUSTFLAGS` variable and its value (added to
    /// `firmware/.cargo/config.toml`'s): the driven camera's, if any.
    pub fn rustflags(self, camera: bool) -> Option<(String, String)> {
        let flags = self.0.camera_rustflags.as_ref().filter(|_| camera)?;
        let var = format!(
            "CARGO_TARGET_{}_RUSTFLAGS",
            self.0.target.to_uppercase().replace(['-', '.'], "_")
        );
        Some((var, flags.clone()))
    }

    /// `scenes` less those this board's one-shot firmware leaves out
    /// ([`Spec::skip_scenes`]).
    pub fn held(self, scenes: Vec<std::path::PathBuf>) -> Vec<std::path::PathBuf> {
        let skip = &self.0.skip_scenes;
        scenes
            .into_iter()
            .filter(|p| {
                !p.file_stem()
                    .is_some_and(|s| skip.iter().any(|k| s == k.as_str()))
            })
            .collect()
    }

    /// The driven camera's firmware features.
    pub fn camera_features(self) -> &'static str {
        self.0
            .camera_features
            .as_deref()
            .unwrap_or("camera,mix32,sensor,status")
    }

    /// Picoseconds a SysTick tick.
    pub fn systick_ps(self) -> u64 {
        1_000_000_000_000 / self.0.systick_hz
    }
}

/// The linker's memory map of `b`.
pub fn memory_x(b: &Spec) -> String {
    format!(
        "/* Memory map of {} (QEMU {}, Cortex-{}), from firmware/boards.toml. */\nMEMORY\n{{\n  FLASH : ORIGIN = {:#010x}, LENGTH = {}\n  RAM   : ORIGIN = {:#010x}, LENGTH = {}\n}}\n",
        b.name, b.name, b.core, b.flash[0], b.flash[1], b.ram[0], b.ram[1]
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The table parses, names are unique, and the root memory.x (the
    /// default board's, for `cargo run`) is lm3s6965evb's entry.
    #[test]
    fn the_table_parses_and_the_root_memory_map_is_the_default_boards() {
        let names: Vec<&str> = all().iter().map(|b| b.name.as_str()).collect();
        assert!(names.len() >= 5, "{names:?}");
        let mut unique = names.clone();
        unique.sort();
        unique.dedup();
        assert_eq!(unique.len(), names.len(), "{names:?}");
        let root =
            std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../memory.x")).expect("memory.x");
        let m3 = Board::parse("lm3s6965evb").expect("lm3s6965evb");
        let flat = |s: &str| {
            s.lines()
                .filter(|l| l.contains("ORIGIN"))
                .map(str::trim)
                .collect::<Vec<_>>()
                .join("\n")
        };
        assert_eq!(flat(&root), flat(&memory_x(m3.spec())));
        assert!(Board::parse("nope").unwrap_err().contains("mps2-an505"));
    }
}
