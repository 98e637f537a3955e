//! `host-sim wire-example`.

/// Print a complete small frame as it goes on the wire, then a few
/// commands and answers (docs/wire.md's examples).
#[derive(clap::Args)]
pub struct Args {}

/// Runs the command: the line it prints, or the error.
pub fn run(_args: Args) -> Result<String, String> {
    let frame = host_sim::stream_cmd::wire_example()?;
    let commands = host_sim::stream_cmd::command_example()?;
    Ok(format!("{frame}\n{}", commands.trim_end()))
}
