//! `host-sim hil`.

/// Run the firmware in QEMU, decode its UART, and compare every frame
/// with the host render (bit-exact) and the f64 reference; writes hil.json
/// and the frames as PNGs.
#[derive(clap::Args)]
pub struct Args {
    /// A board of firmware/boards.toml: lm3s6965evb (Cortex-M3),
    /// mps2-an386 (M4F), microbit (M0, 16 KiB of RAM), mps2-an505 (M33),
    /// mps2-an500 (M7).
    #[arg(long)]
    board: String,
    /// Scenes to embed (default: every scene in scenes/).
    #[arg(long, num_args = 1..)]
    scene: Vec<std::path::PathBuf>,
    /// A firmware ELF built already (default: build it).
    #[arg(long)]
    elf: Option<std::path::PathBuf>,
    /// Render every scene with each of these variants (e.g.
    /// i16f16-lut256-linear; default: the planned renderer).
    #[arg(long, num_args = 1..)]
    variant: Vec<String>,
    /// Output directory.
    #[arg(long)]
    out: std::path::PathBuf,
}

/// Runs the command: the line it prints, or the error.
pub fn run(args: Args) -> Result<String, String> {
    let Args {
        board,
        scene,
        elf,
        variant,
        out,
    } = args;
    let board = host_sim::qemu::Board::parse(&board)?;
    let variants = variant
        .iter()
        .map(|v| host_sim::variant::Variant::parse(v))
        .collect::<Result<Vec<_>, _>>()?;
    let r = host_sim::hil_cmd::hil_variants(board, elf, &scene, &variants, &out)?;
    let mut s = String::new();
    for f in &r.frames {
        s.push_str(&format!(
            "  {:<20} {:<22} {}x{} {:<7} bit_exact={} instructions/pixel={} max_abs_lsb={}\n",
            f.scene,
            f.variant,
            f.width,
            f.height,
            f.format,
            f.bit_exact,
            f.instructions_per_pixel.map_or("-".into(), |v| format!("{v:.0}")),
            f.max_abs_lsb
        ));
    }
    s.push_str(&format!(
        "{}: {} frames, bit_exact={}, standard scene {} instructions/pixel (QEMU -icount; not cycles), \
         flash {} B ({} panic symbols), static RAM {} B, peak stack {} B, max_abs_lsb {}",
        r.board,
        r.frames.len(),
        r.bit_exact,
        r.instructions_per_pixel.map_or("-".into(), |v| format!("{v:.0}")),
        r.flash_bytes,
        r.panic_symbols.len(),
        r.ram_bytes,
        r.stack_peak_bytes.map_or("-".into(), |v| v.to_string()),
        r.max_abs_lsb
    ));
    let kb = |v: &[host_sim::profile::Share]| {
        v.iter()
            .take(6)
            .map(|x| format!("{} {:.1} K", x.name, x.bytes as f64 / 1000.0))
            .collect::<Vec<_>>()
            .join(", ")
    };
    s.push_str(&format!(
        "\n  largest symbols: {}\n  .text by source file: {}",
        kb(&r.flash_use.largest_symbols),
        kb(&r.flash_use.text_by_file)
    ));
    if r.bit_exact {
        Ok(s)
    } else {
        Err(format!("{s}\nnot bit-exact with the host render"))
    }
}
