//! The command line: one module a command, each its arguments and its run.

use clap::{Parser, Subcommand};

mod calls;
mod camera;
mod costfit;
mod demo;
mod drive;
mod export;
mod faults;
mod frame;
mod hil;
mod profile;
mod receive;
mod render;
mod replay;
mod stream;
mod throughput;
mod tradeoff;
mod wire_example;

/// hilcam host harness: reference models, comparisons, links, the firmware
/// in QEMU.
#[derive(Parser)]
#[command(
    name = "host-sim",
    version,
    about = "hilcam host harness: reference models, comparisons, links"
)]
pub struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// Project a demo camera's points and compute its lens figures with the
    /// fixed-point core and the f64 reference, and print both with the errors.
    Demo(demo::Args),
    /// Render a scene with the core and the f64 reference; write frame.png,
    /// reference.png, diff.png and metrics.json into OUT.
    Render(render::Args),
    /// Render a scene with the core only (the planner's choice, or
    /// --variant) and write frame.png and truth.json: the camera in
    /// OpenCV's conventions and the true pixel positions of every checker
    /// texture's inner corners, from the f64 reference.
    Frame(frame::Args),
    /// Render a scene, encode N frames with the core's encoder, send them
    /// through a simulated link with faults, decode, and report (stream.json,
    /// received.png).
    Stream(stream::Args),
    /// Run the standard fault campaign (12 000 frames of the standard scene)
    /// and write faults.json.
    Faults(faults::Args),
    /// Decode frames from a real serial device or pty and write each as a
    /// PNG as it arrives, then receive.json.
    Receive(receive::Args),
    /// Print a complete small frame as it goes on the wire, then a few
    /// commands and answers (docs/wire.md's examples).
    WireExample(wire_example::Args),
    /// Drive the camera firmware in QEMU (UART0 both ways) along a
    /// trajectory: SetPose and Trigger for each pose; check every frame byte
    /// for byte against the host render of that pose and its ground truth
    /// against the pose sent. Writes frame-N.png, frame-N.json (the frame's
    /// ground truth) and drive.json.
    Drive(drive::Args),
    /// Export a scene's camera for calibration tools: opencv.yaml (OpenCV
    /// FileStorage: camera matrix, distortion refitted in OpenCV's direction,
    /// rotation and translation), ros.yaml (ROS CameraInfo) and export.json
    /// (the fit's largest residual in px, and world points with the pixels
    /// the emulator images them at).
    Export(export::Args),
    /// Be the camera on a serial device (a real port or a pty): obey the
    /// commands that arrive (docs/wire.md), stream the frames they ask for
    /// with their ground truth, until the other end hangs up.
    Camera(camera::Args),
    /// Decode a captured stream (--capture of drive or camera): every
    /// frame as frame-N.png with its ground truth in frame-N.json, the
    /// answers and the decoder's counts in replay.json.
    Replay(replay::Args),
    /// Run the firmware in QEMU, decode its UART, and compare every frame
    /// with the host render (bit-exact) and the f64 reference; writes hil.json
    /// and the frames as PNGs.
    Hil(hil::Args),
    /// Measure the speed/accuracy trade: every variant's fidelity against the
    /// f64 reference, its instructions per pixel on the M3 and the M4F in
    /// QEMU, host ns per pixel, table and flash bytes; growth with resolution
    /// and primitives; what the planner's pruning saves. Writes tradeoff.json,
    /// tradeoff.md and tradeoff.png.
    Tradeoff(tradeoff::Args),
    /// Fit the planner's cost model: calibration scenes rendered on the M3
    /// in QEMU with each arithmetic, least squares per arithmetic, and the
    /// shipped scenes' predicted against measured cost. Writes costfit.json
    /// and costfit.md.
    Costfit(costfit::Args),
    /// Where a frame's instructions go on a board, by pipeline stage: the
    /// firmware holding the scenes runs in QEMU with its executed blocks
    /// logged, each instruction attributed to the stage whose function
    /// inlined it (from the ELF's debug information), and to its source
    /// line. Writes profile.json and profile.md (stages, then each frame's
    /// costliest source lines).
    Profile(profile::Args),
    /// Instructions of each call of a function in QEMU's block log of a
    /// firmware's run (`-d in_asm,exec,nochain -D LOG`, without
    /// -icount), by function, a library routine's (soft-float, `__aeabi_*`)
    /// counted for its caller: e.g. a driven camera's plan per pose,
    /// `--function hilcam::planner::plan --caller hilcam_firmware::options`
    Calls(calls::Args),
    /// Host throughput of the default render (plan, prepare and render
    /// every frame, lines in parallel on every core, as `render` does),
    /// and on one core: frames/s and ns/pixel (medians over the frames),
    /// with the core's loops built for the processor's x86-64 level
    /// (HILCAM_X86_LEVEL=1 or 3 caps it: the baseline build, x86-64-v3).
    Throughput(throughput::Args),
}

impl Cli {
    /// Runs the command given: the line it prints, or the error.
    pub fn run(self) -> Result<String, String> {
        match self.cmd {
            Cmd::Demo(a) => demo::run(a),
            Cmd::Render(a) => render::run(a),
            Cmd::Frame(a) => frame::run(a),
            Cmd::Stream(a) => stream::run(a),
            Cmd::Faults(a) => faults::run(a),
            Cmd::Receive(a) => receive::run(a),
            Cmd::WireExample(a) => wire_example::run(a),
            Cmd::Drive(a) => drive::run(a),
            Cmd::Export(a) => export::run(a),
            Cmd::Camera(a) => camera::run(a),
            Cmd::Replay(a) => replay::run(a),
            Cmd::Hil(a) => hil::run(a),
            Cmd::Tradeoff(a) => tradeoff::run(a),
            Cmd::Costfit(a) => costfit::run(a),
            Cmd::Profile(a) => profile::run(a),
            Cmd::Calls(a) => calls::run(a),
            Cmd::Throughput(a) => throughput::run(a),
        }
    }
}
