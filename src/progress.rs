//! Progress reporting: JSON lines on stderr for hosts (the Blender add-on), an
//! indicatif bar for people, or nothing. Warnings and errors are always reported.

use indicatif::{ProgressBar, ProgressStyle};
use serde_json::{Value, json};
use std::io::Write;
use std::sync::Mutex;
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::Duration;

/// How progress is shown.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum ProgressMode {
    /// One JSON object per line on stderr.
    Json,
    /// A progress bar on stderr.
    Bar,
    /// Only warnings, errors and the summary.
    None,
}

/// The reporter shared by the render driver and its progress thread.
pub struct Reporter {
    mode: ProgressMode,
    bar: Mutex<Option<ProgressBar>>,
    silent: bool,
    /// The phase announced last ("" before the first), read by the signal watchdog.
    current: Mutex<String>,
    /// Images (interim or final) written so far, read by the signal watchdog.
    images: AtomicU32,
    /// Test hook (`--debug-delay PHASE=SECONDS`): an uninterruptible sleep at the start
    /// of a phase, standing in for slow work that cannot poll the stop flag.
    delays: Vec<(String, Duration)>,
}

impl Reporter {
    /// A reporter in the given mode.
    pub fn new(mode: ProgressMode) -> Self {
        Reporter {
            mode,
            bar: Mutex::new(None),
            silent: false,
            current: Mutex::new(String::new()),
            images: AtomicU32::new(0),
            delays: Vec::new(),
        }
    }

    /// Adds the `--debug-delay PHASE=SECONDS` sleeps (a hidden flag for the signal tests).
    pub fn with_debug_delays(mut self, specs: &[String]) -> Result<Self, String> {
        for spec in specs {
            let (phase, secs) =
                spec.split_once('=').ok_or_else(|| format!("--debug-delay '{spec}' is not PHASE=SECONDS"))?;
            let secs: f64 = secs.parse().map_err(|_| format!("--debug-delay '{spec}': bad seconds"))?;
            if !(0.0..=3600.0).contains(&secs) {
                return Err(format!("--debug-delay '{spec}': seconds must be in 0..=3600"));
            }
            self.delays.push((phase.to_string(), Duration::from_secs_f64(secs)));
        }
        Ok(self)
    }

    /// The phase announced last ("" before the first).
    pub fn current_phase(&self) -> String {
        self.current.lock().map(|p| p.clone()).unwrap_or_default()
    }

    /// Images written so far (interim and final).
    pub fn images_written(&self) -> u32 {
        self.images.load(Ordering::SeqCst)
    }

    /// A reporter that prints nothing at all (for `caustic bench`, which prints its own).
    pub fn silent() -> Self {
        Reporter { silent: true, ..Reporter::new(ProgressMode::None) }
    }

    /// The mode.
    pub fn mode(&self) -> ProgressMode {
        self.mode
    }

    fn json_line(&self, v: Value) {
        let mut err = std::io::stderr().lock();
        let _ = writeln!(err, "{v}");
        let _ = err.flush();
    }

    fn text_line(&self, s: &str) {
        if let Some(bar) = self.bar.lock().unwrap().as_ref() {
            bar.println(s);
            return;
        }
        eprintln!("{s}");
    }

    /// A phase starts: loading, bvh, rendering, writing.
    pub fn phase(&self, phase: &str, elapsed: f64) {
        if let Ok(mut p) = self.current.lock() {
            *p = phase.to_string();
        }
        self.phase_line(phase, elapsed);
        for (p, d) in &self.delays {
            if p == phase {
                std::thread::sleep(*d);
            }
        }
    }

    fn phase_line(&self, phase: &str, elapsed: f64) {
        match self.mode {
            ProgressMode::Json => self.json_line(json!({"type": "phase", "phase": phase, "elapsed": elapsed})),
            ProgressMode::Bar => {
                let mut bar = self.bar.lock().unwrap();
                if (phase == "rendering" || phase == "photons") && bar.is_none() {
                    let b = ProgressBar::new(1000);
                    b.set_style(
                        ProgressStyle::with_template("{spinner} {msg} [{bar:40}] {percent}% ETA {eta}")
                            .unwrap_or_else(|_| ProgressStyle::default_bar()),
                    );
                    *bar = Some(b);
                } else if phase != "rendering" && phase != "photons" {
                    if let Some(b) = bar.take() {
                        b.finish_and_clear();
                    }
                    drop(bar);
                    eprintln!("{phase}…");
                }
            }
            ProgressMode::None => {}
        }
    }

    /// Rendering progress.
    #[allow(clippy::too_many_arguments)]
    pub fn progress(
        &self,
        fraction: f64,
        samples_done: u32,
        samples_total: Option<u32>,
        elapsed: f64,
        eta: Option<f64>,
        rays_per_sec: f64,
    ) {
        match self.mode {
            ProgressMode::Json => self.json_line(json!({
                "type": "progress", "phase": "rendering", "fraction": fraction, "samples_done": samples_done,
                "samples_total": samples_total, "elapsed": elapsed, "eta": eta, "rays_per_sec": rays_per_sec
            })),
            ProgressMode::Bar => {
                if let Some(b) = self.bar.lock().unwrap().as_ref() {
                    b.set_position((fraction.clamp(0.0, 1.0) * 1000.0) as u64);
                    let total = samples_total.map(|t| t.to_string()).unwrap_or_else(|| "∞".into());
                    b.set_message(format!("{samples_done}/{total} spp, {:.1} Mrays/s", rays_per_sec / 1e6));
                }
            }
            ProgressMode::None => {}
        }
    }

    /// Photon-tracing progress (the "photons" phase).
    pub fn photon_progress(
        &self,
        fraction: f64,
        photons_done: u64,
        photons_total: u64,
        elapsed: f64,
        photons_per_sec: f64,
    ) {
        match self.mode {
            ProgressMode::Json => self.json_line(json!({
                "type": "progress", "phase": "photons", "fraction": fraction, "photons_done": photons_done,
                "photons_total": photons_total, "elapsed": elapsed, "photons_per_sec": photons_per_sec
            })),
            ProgressMode::Bar => {
                if let Some(b) = self.bar.lock().unwrap().as_ref() {
                    b.set_position((fraction.clamp(0.0, 1.0) * 1000.0) as u64);
                    b.set_message(format!("photons {photons_done}/{photons_total}, {:.2} M/s", photons_per_sec / 1e6));
                }
            }
            ProgressMode::None => {}
        }
    }

    /// A warning.
    pub fn warning(&self, message: &str) {
        if self.silent {
            return;
        }
        match self.mode {
            ProgressMode::Json => self.json_line(json!({"type": "warning", "message": message})),
            _ => self.text_line(&format!("warning: {message}")),
        }
    }

    /// An image was written.
    pub fn image(&self, path: &str, samples: u32, is_final: bool) {
        self.images.fetch_add(1, Ordering::SeqCst);
        if self.mode == ProgressMode::Json {
            self.json_line(json!({"type": "image", "path": path, "samples": samples, "final": is_final}));
        }
    }

    /// The final summary.
    pub fn summary(&self, summary: Value) {
        if self.silent {
            return;
        }
        match self.mode {
            ProgressMode::Json => {
                let mut s = summary;
                s["type"] = json!("summary");
                self.json_line(s);
            }
            _ => {
                if let Some(b) = self.bar.lock().unwrap().take() {
                    b.finish_and_clear();
                }
                let rays = &summary["stats"]["rays"];
                eprintln!(
                    "wrote {} ({}×{}, {} spp{}) in {:.2} s, {:.2} Mrays/s (camera {}, bounce {}, shadow {})",
                    summary["output"].as_str().unwrap_or(""),
                    summary["width"],
                    summary["height"],
                    summary["spp"],
                    if summary["interrupted"].as_bool() == Some(true) { ", interrupted" } else { "" },
                    summary["elapsed"].as_f64().unwrap_or(0.0),
                    summary["stats"]["rays_per_sec"].as_f64().unwrap_or(0.0) / 1e6,
                    rays["camera"],
                    rays["bounce"],
                    rays["shadow"]
                );
            }
        }
    }

    /// A fatal error.
    pub fn error(&self, code: i32, message: &str) {
        if let Some(b) = self.bar.lock().unwrap().take() {
            b.finish_and_clear();
        }
        match self.mode {
            ProgressMode::Json => self.json_line(json!({"type": "error", "code": code, "message": message})),
            _ => eprintln!("error: {message}"),
        }
    }
}
