//! `host-sim demo`.

/// Project a demo camera's points and compute its lens figures with the
/// fixed-point core and the f64 reference, and print both with the errors.
#[derive(clap::Args)]
pub struct Args {}

/// Runs the command: the line it prints, or the error.
pub fn run(_args: Args) -> Result<String, String> {
    let (text, errs) = host_sim::demo::run()?;
    // The table first, whatever the verdict.
    print!("{text}");
    if errs.max_px <= 1.0 / 256.0 && errs.max_lens_rel <= 1e-4 {
        Ok(String::new())
    } else {
        Err("the core missed a target against the reference".into())
    }
}
