//! host-sim's test suite, as one test binary: each module was its own
//! integration-test crate, linked on its own and compiling the renderer's
//! generic loops again (`defocus` and `sensor` 40 and 36 s apiece in the
//! test command's build). Run one module with `cargo test -p host-sim
//! --test sim_tests MODULE::`.

mod bad_input;
mod cli;
mod closed_loop;
mod defocus;
mod export;
mod hostile;
mod link;
mod scenes;
mod sensor;
mod trajectory;
