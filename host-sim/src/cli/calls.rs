//! `host-sim calls`.

/// Instructions of each call of a function in QEMU's block log of a
/// firmware's run (`-d in_asm,exec,nochain -D LOG`, without
/// -icount), by function, a library routine's (soft-float, `__aeabi_*`)
/// counted for its caller: e.g. a driven camera's plan per pose,
/// `--function hilcam::planner::plan --caller hilcam_firmware::options`
#[derive(clap::Args)]
pub struct Args {
    /// QEMU's log.
    #[arg(long)]
    log: std::path::PathBuf,
    /// The firmware ELF that ran.
    #[arg(long)]
    elf: std::path::PathBuf,
    /// The function whose calls are counted (its path without hash).
    #[arg(long)]
    function: String,
    /// The functions it returns to, which end a call.
    #[arg(long, num_args = 1.., required = true)]
    caller: Vec<String>,
    /// Functions listed for the last call.
    #[arg(long, default_value_t = 12)]
    top: usize,
}

/// Runs the command: the line it prints, or the error.
pub fn run(args: Args) -> Result<String, String> {
    let Args {
        log,
        elf,
        function,
        caller,
        top,
    } = args;
    let c = host_sim::profile::calls(&log, &elf, &function, &caller, top)?;
    let mut s = String::new();
    for (k, t) in c.totals.iter().enumerate() {
        s += &format!("call {k}: {t} instructions\n");
    }
    s += "the last, by function (a library routine's instructions counted for its caller):";
    for (name, n) in c.last {
        s += &format!("\n{n:>10}  {name}");
    }
    Ok(s)
}
