//! The `caustic` binary: parses the command line, runs a command, and turns the
//! outcome into an exit code (documented in the README and `docs/contract.md`).

use caustic::cli::{Cli, Command};
use caustic::error::exit_code;
use caustic::progress::{ProgressMode, Reporter};
use clap::Parser;
use std::io::IsTerminal;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

/// After the first SIGINT/SIGTERM the pipeline has this long to reach its next stop
/// check (per photon chunk, between phases); a phase before rendering that cannot poll
/// (decoding a texture, building the BVH or a kd-tree) is then abandoned, so that the
/// process ends within about two seconds. Rendering, denoising and writing are never abandoned:
/// rendering stops within a pixel's work and then writes the partial image, and cutting
/// that write short would lose the evening's work (a 4K EXR takes seconds to write).
const STOP_GRACE: Duration = Duration::from_millis(1500);

/// Phases in which the pipeline, once stopped, is delivering its image.
const DELIVERING: [&str; 3] = ["rendering", "denoising", "writing"];

/// Ends the process at once after a signal: removes this process's temporary files, and
/// exits 5 if this run already put an image at the output (an interim one, which was
/// renamed into place whole), else 6 with an error line saying nothing was written.
fn abandon(reporter: &Reporter, temps: &[PathBuf], why: &str) -> ! {
    for t in temps {
        let _ = std::fs::remove_file(t);
    }
    let phase = reporter.current_phase();
    let phase = if phase.is_empty() { "start-up".to_string() } else { phase };
    if reporter.images_written() > 0 {
        reporter
            .warning(&format!("interrupted during the {phase} phase ({why}); the output holds the last interim image"));
        std::process::exit(exit_code::INTERRUPTED_PARTIAL);
    }
    reporter.error(
        exit_code::INTERRUPTED_EMPTY,
        &format!("interrupted during the {phase} phase ({why}); nothing rendered yet, nothing written"),
    );
    std::process::exit(exit_code::INTERRUPTED_EMPTY);
}

/// First signal: set `stop` and start the watchdog that abandons the run after
/// [`STOP_GRACE`]. Second signal: abandon at once.
fn handle_signals(stop: Arc<AtomicBool>, reporter: Arc<Reporter>, temps: Vec<PathBuf>) {
    let _ = ctrlc::set_handler(move || {
        if stop.swap(true, Ordering::SeqCst) {
            abandon(&reporter, &temps, "second signal");
        }
        let (reporter, temps) = (reporter.clone(), temps.clone());
        std::thread::spawn(move || {
            std::thread::sleep(STOP_GRACE);
            if !DELIVERING.contains(&reporter.current_phase().as_str()) {
                abandon(&reporter, &temps, "the phase could not stop in time");
            }
        });
    });
}

/// The reporter with the hidden `--debug-delay` hooks, or the usage error they cause.
fn reporter_with_delays(mode: ProgressMode, delays: &[String]) -> Arc<Reporter> {
    match Reporter::new(mode).with_debug_delays(delays) {
        Ok(r) => Arc::new(r),
        Err(msg) => {
            Reporter::new(mode).error(exit_code::USAGE, &msg);
            std::process::exit(exit_code::USAGE);
        }
    }
}

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
        // The server ends on `quit` or at the end of its input; a signal ends it at once
        // (nothing of it is worth writing out).
        Command::Serve(args) => match caustic::cli::run_serve(&args) {
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
            let reporter = reporter_with_delays(mode, &args.debug_delay);
            let stop = Arc::new(AtomicBool::new(false));
            let temps = vec![caustic::integrator::photon::io::PhotonMaps::temp_path(&args.output)];
            handle_signals(stop.clone(), reporter.clone(), temps);
            match caustic::cli::run_photons(&args, &reporter, &stop) {
                Ok(()) => exit_code::OK,
                Err(e) => {
                    reporter.error(e.exit_code(), &e.to_string());
                    e.exit_code()
                }
            }
        }
        Command::Merge(args) => {
            let reporter = Arc::new(Reporter::new(args.progress.unwrap_or(ProgressMode::None)));
            // A signal while reading the chunks ends the merge (exit 6, nothing written);
            // a write in progress finishes, as for `render`.
            handle_signals(
                Arc::new(AtomicBool::new(false)),
                reporter.clone(),
                vec![caustic::output::temp_path(&args.output)],
            );
            match caustic::cli::run_merge(&args, &reporter) {
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
            let reporter = reporter_with_delays(mode, &args.debug_delay);
            let stop = Arc::new(AtomicBool::new(false));
            // First signal: stop and write what we have. Second, or a phase that cannot
            // stop within the grace time: leave at once.
            handle_signals(stop.clone(), reporter.clone(), vec![caustic::output::temp_path(&args.output)]);
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
