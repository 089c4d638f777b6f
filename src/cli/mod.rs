//! The `caustic` commands: argument types (`args`), settings resolution (`settings`:
//! flag > scene > default, every default in one place), and one module per command.

/// Prints a line to stdout, ignoring a closed pipe (`caustic info --json | head`).
macro_rules! outln {
    ($($arg:tt)*) => {{
        use std::io::Write;
        let _ = writeln!(std::io::stdout().lock(), $($arg)*);
    }};
}

pub mod args;
mod bench;
mod info;
mod merge;
mod photons;
mod render;
mod serve;
pub mod settings;

pub use args::*;
pub use bench::run_bench;
pub use info::run_info;
pub use merge::run_merge;
pub use photons::run_photons;
pub(crate) use render::build_bsdf_tables;
pub use render::{Outcome, run_render};
pub use serve::run_serve;
pub use settings::{Resolved, resolve, resolve_photon};
