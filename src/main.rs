//! The `caustic` binary: parses the command line, runs a command, and turns the
//! outcome into an exit code (documented in the README and `docs/contract.md`).

use caustic::cli::{Cli, Command};
use caustic::error::exit_code;
use caustic::progress::{ProgressMode, Reporter};
use clap::Parser;
use std::io::IsTerminal;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

fn main() {
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            let code = if e.use_stderr() { exit_code::USAGE } else { exit_code::OK };
            // A host that asked for JSON gets the error as JSON too.
            let args: Vec<String> = std::env::args().collect();
            let json = args.windows(2).any(|w| w[0] == "--progress" && w[1] == "json")
                || args.iter().any(|a| a == "--progress=json");
            if json && code != exit_code::OK {
                let msg = e
                    .to_string()
                    .lines()
                    .next()
                    .unwrap_or("invalid command line")
                    .trim_start_matches("error: ")
                    .to_string();
                Reporter::new(ProgressMode::Json).error(code, &msg);
            } else {
                let _ = e.print();
            }
            std::process::exit(code);
        }
    };
    std::process::exit(match cli.command {
        Command::Info(args) => match caustic::cli::run_info(&args) {
            Ok(()) => exit_code::OK,
            Err(e) => {
                eprintln!("error: {e}");
                e.exit_code()
            }
        },
        Command::Bench(args) => {
            let stop = AtomicBool::new(false);
            match caustic::cli::run_bench(&args, &stop) {
                Ok(()) => exit_code::OK,
                Err(e) => {
                    eprintln!("error: {e}");
                    e.exit_code()
                }
            }
        }
        Command::Photons(args) => {
            let mode = args.progress.unwrap_or(ProgressMode::None);
            let reporter = Reporter::new(mode);
            let stop = Arc::new(AtomicBool::new(false));
            let handler_stop = stop.clone();
            let _ = ctrlc::set_handler(move || {
                if handler_stop.swap(true, Ordering::SeqCst) {
                    std::process::exit(exit_code::INTERRUPTED_EMPTY);
                }
            });
            match caustic::cli::run_photons(&args, &reporter, &stop) {
                Ok(()) => exit_code::OK,
                Err(e) => {
                    reporter.error(e.exit_code(), &e.to_string());
                    e.exit_code()
                }
            }
        }
        Command::Render(args) => {
            let mode = args.progress.unwrap_or(if std::io::stderr().is_terminal() {
                ProgressMode::Bar
            } else {
                ProgressMode::None
            });
            let reporter = Reporter::new(mode);
            let stop = Arc::new(AtomicBool::new(false));
            let handler_stop = stop.clone();
            // First signal: stop and write what we have. Second: leave at once.
            let _ = ctrlc::set_handler(move || {
                if handler_stop.swap(true, Ordering::SeqCst) {
                    std::process::exit(exit_code::INTERRUPTED_EMPTY);
                }
            });
            match caustic::cli::run_render(&args, &reporter, &stop) {
                Ok(o) if o.interrupted => exit_code::INTERRUPTED_PARTIAL,
                Ok(_) => exit_code::OK,
                Err(e) => {
                    reporter.error(e.exit_code(), &e.to_string());
                    e.exit_code()
                }
            }
        }
    });
}
