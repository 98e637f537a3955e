//! `host-sim profile`.

/// Where a frame's instructions go on a board, by pipeline stage: the
/// firmware holding the scenes runs in QEMU with its executed blocks
/// logged, each instruction attributed to the stage whose function
/// inlined it (from the ELF's debug information), and to its source
/// line. Writes profile.json and profile.md (stages, then each frame's
/// costliest source lines).
#[derive(clap::Args)]
pub struct Args {
    /// A board of firmware/boards.toml: lm3s6965evb (Cortex-M3),
    /// mps2-an386 (M4F), microbit (M0, 16 KiB of RAM), mps2-an505 (M33),
    /// mps2-an500 (M7).
    #[arg(long)]
    board: String,
    /// Scenes the firmware holds, in order (default: the standard
    /// scene). A frame of 320x240 logs about 1 GB through a pipe;
    /// shallow-dof's defocus about 50 GB.
    #[arg(long, num_args = 1..)]
    scene: Vec<std::path::PathBuf>,
    /// A firmware ELF built already, holding `--scene` (default: build it).
    #[arg(long)]
    elf: Option<std::path::PathBuf>,
    /// How many of each frame's costliest functions and source lines
    /// profile.json keeps (profile.md's table shows at most 25 lines).
    #[arg(long, default_value_t = 40)]
    top: usize,
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
        top,
        out,
    } = args;
    let board = host_sim::qemu::Board::parse(&board)?;
    let scenes = if scene.is_empty() {
        vec![host_sim::qemu::repo_root().join("scenes/standard.toml")]
    } else {
        scene
    };
    let r = host_sim::profile::profile(board, elf, &scenes, top, &out)?;
    Ok(format!(
        "{}\nprofile.json, profile.md in {}",
        host_sim::profile::table(&r),
        out.display()
    ))
}
