//! The core's build profile: the cfgs that name the build variants its code
//! chooses between, set once here from the target (`src/target.rs` says
//! what each changes).

fn main() {
    println!("cargo::rerun-if-changed=build.rs");
    println!("cargo::rustc-check-cfg=cfg(hilcam_m0)");
    println!("cargo::rustc-check-cfg=cfg(hilcam_loops_out_of_line)");
    let arch = std::env::var("CARGO_CFG_TARGET_ARCH").unwrap_or_default();
    let atomics = std::env::var("CARGO_CFG_TARGET_HAS_ATOMIC").unwrap_or_default();
    // The Cortex-M0 (ARMv6-M): the Arm target without 32-bit atomics.
    if arch == "arm" && !atomics.split(',').any(|a| a == "32") {
        println!("cargo::rustc-cfg=hilcam_m0");
    }
    // Every target but the x86-64 host keeps the per-pixel loops out of
    // line (one copy each); the host inlines them into its entry points.
    if arch != "x86_64" {
        println!("cargo::rustc-cfg=hilcam_loops_out_of_line");
    }
}
