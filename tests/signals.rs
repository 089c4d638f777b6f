//! Crash safety: SIGTERM while loading, building the BVH or tracing photons ends the
//! process within about two seconds with a "nothing rendered yet" error (exit 6) and no
//! file; while rendering, with the partial image (exit 5); while writing, once the write
//! is done (a second signal abandons it, keeping an interim image if there is one);
//! SIGKILL leaves at most a temporary file, which the next run removes.
//!
//! Phases that are too short to hit on these small scenes are stretched with the hidden
//! `--debug-delay PHASE=SECONDS` flag: an uninterruptible sleep at the phase's start,
//! which stands in for work that cannot poll the stop flag (decoding a texture,
//! building a BVH, writing a file) — the worst case for stopping in time.

mod common;

use common::{bin, root, temp_dir};
use serde_json::Value;
use std::io::BufRead;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// From the signal to the exit: the binary's grace time (1.5 s, `STOP_GRACE` in
/// main.rs) plus 1.5 s for process start-up noise on a loaded two-core machine.
const STOP_BOUND: Duration = Duration::from_secs(3);

fn cornell() -> String {
    root().join("scenes/cornell_box.gltf").to_str().unwrap().to_string()
}

fn spawn(args: &[&str]) -> Child {
    Command::new(bin())
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start caustic")
}

fn signal(child: &Child, sig: &str) {
    let ok = Command::new("kill").args([sig, &child.id().to_string()]).status().unwrap().success();
    assert!(ok, "kill {sig} failed");
}

/// Reads JSON lines until `ready` accepts one, sends SIGTERM, and returns the exit
/// code, the time from the signal to the exit and every line.
fn term_when(child: Child, ready: impl Fn(&Value) -> bool) -> (Option<i32>, Duration, Vec<Value>) {
    signal_when(child, "-TERM", ready)
}

/// [`term_when`] with another signal (`-INT`).
fn signal_when(mut child: Child, sig: &str, ready: impl Fn(&Value) -> bool) -> (Option<i32>, Duration, Vec<Value>) {
    let mut lines = std::io::BufReader::new(child.stderr.take().unwrap()).lines();
    let mut seen = Vec::new();
    for line in lines.by_ref() {
        let v: Value = serde_json::from_str(&line.unwrap()).expect("JSON line");
        let hit = ready(&v);
        seen.push(v);
        if hit {
            break;
        }
    }
    assert!(seen.last().is_some_and(&ready), "the awaited line never came: {seen:?}");
    signal(&child, sig);
    let t = Instant::now();
    // The pipe closes when the process exits; a watchdog kill keeps a broken build from hanging.
    let rest: Vec<Value> = lines.map_while(Result::ok).filter_map(|l| serde_json::from_str(&l).ok()).collect();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if t.elapsed() > Duration::from_secs(30) {
            let _ = child.kill();
            panic!("still running 30 s after SIGTERM");
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    let elapsed = t.elapsed();
    seen.extend(rest);
    (status.code(), elapsed, seen)
}

fn is_phase(v: &Value, phase: &str) -> bool {
    v["type"] == "phase" && v["phase"] == phase
}

fn files_in(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> =
        std::fs::read_dir(dir).unwrap().flatten().map(|e| e.file_name().to_string_lossy().to_string()).collect();
    v.sort();
    v
}

/// Exit 6 within the bound, an error line naming the phase, and an empty directory.
fn assert_nothing_rendered(r: (Option<i32>, Duration, Vec<Value>), dir: &Path, phase: &str) {
    let (code, elapsed, lines) = r;
    assert_eq!(code, Some(6), "{lines:?}");
    assert!(elapsed < STOP_BOUND, "{phase}: took {elapsed:?} to stop");
    let err = lines.iter().find(|v| v["type"] == "error").expect("an error line");
    assert_eq!(err["code"], 6);
    let msg = err["message"].as_str().unwrap();
    assert!(msg.contains("nothing"), "{msg}");
    assert!(files_in(dir).is_empty(), "{phase}: left {:?}", files_in(dir));
}

/// Exit 5 within the bound and a readable, finite, non-black image, and nothing else.
fn assert_partial_image(r: (Option<i32>, Duration, Vec<Value>), dir: &Path, phase: &str) {
    let (code, elapsed, lines) = r;
    assert_eq!(code, Some(5), "{phase}: {lines:?}");
    assert!(elapsed < STOP_BOUND, "{phase}: took {elapsed:?} to stop");
    assert_eq!(files_in(dir), vec!["out.exr".to_string()], "{phase}");
    let (_, _, px) = caustic::output::read_combined(&dir.join("out.exr")).unwrap();
    assert!(px.iter().all(|p| p.iter().all(|c| c.is_finite())));
    assert!(px.iter().map(|p| p[0] as f64).sum::<f64>() > 0.0, "{phase}: black partial image");
}

fn render_args<'a>(out: &'a str, cornell: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut a = vec!["render", cornell, "-o", out, "--progress", "json", "--resolution", "48x48"];
    a.extend_from_slice(extra);
    a
}

#[test]
fn sigterm_while_loading_or_building_the_bvh_writes_nothing() {
    let c = cornell();
    // SIGINT (Ctrl-C) is handled as SIGTERM: one of each.
    for (phase, sig) in [("loading", "-TERM"), ("bvh", "-INT")] {
        let dir = temp_dir();
        let out = dir.path().join("out.exr");
        let delay = format!("{phase}=60");
        let child = spawn(&render_args(out.to_str().unwrap(), &c, &["--debug-delay", &delay]));
        let r = signal_when(child, sig, |v| is_phase(v, phase));
        assert_nothing_rendered(r, dir.path(), phase);
    }
}

#[test]
fn sigterm_while_tracing_photons_writes_nothing() {
    let c = cornell();
    // 50 M photons take minutes; the tracer polls the stop flag per chunk. (No memory
    // limit: the estimate reserves room for 4 stored photons each, which is only
    // touched as photons are traced.)
    let dir = temp_dir();
    let out = dir.path().join("out.exr");
    let extra = ["--integrator", "photon", "--photons", "50000000", "--memory-limit", "none"];
    let child = spawn(&render_args(out.to_str().unwrap(), &c, &extra));
    let r = term_when(child, |v| v["type"] == "progress" && v["phase"] == "photons");
    assert_nothing_rendered(r, dir.path(), "photons");

    // `caustic photons` the same, and no temporary map is left.
    let map = dir.path().join("m.pm");
    let child = spawn(&[
        "photons",
        &c,
        "-o",
        map.to_str().unwrap(),
        "--photons",
        "50000000",
        "--memory-limit",
        "none",
        "--progress",
        "json",
    ]);
    let r = term_when(child, |v| v["type"] == "progress" && v["phase"] == "photons");
    assert_nothing_rendered(r, dir.path(), "photons (caustic photons)");
}

#[test]
fn sigterm_while_rendering_writes_the_partial_image() {
    let c = cornell();
    for integrator in ["path", "sppm"] {
        let dir = temp_dir();
        let out = dir.path().join("out.exr");
        let extra = ["--integrator", integrator, "--spp", "1000000", "--sppm-iterations", "1000000"];
        let child = spawn(&render_args(out.to_str().unwrap(), &c, &extra));
        let r = term_when(child, |v| v["type"] == "progress" && v["samples_done"].as_u64().unwrap_or(0) > 0);
        assert_partial_image(r, dir.path(), integrator);
    }
}

/// SPPM stops within an iteration: here the first iteration's photon pass (50 M photons,
/// tens of seconds on 2 cores) is cut short a second into it, and the abandoned iteration
/// leaves nothing behind (exit 6). Before, the whole iteration ran to its end.
#[test]
fn sigterm_inside_an_sppm_iteration_stops_promptly() {
    let c = cornell();
    let dir = temp_dir();
    let out = dir.path().join("out.exr");
    let extra = ["--integrator", "sppm", "--sppm-photons", "50000000", "--sppm-iterations", "4"];
    let child = spawn(&render_args(out.to_str().unwrap(), &c, &extra));
    let r = term_when(child, |v| {
        let hit = is_phase(v, "rendering");
        if hit {
            std::thread::sleep(Duration::from_secs(1));
        }
        hit
    });
    assert_nothing_rendered(r, dir.path(), "an SPPM photon pass");
}

#[test]
fn sigterm_while_writing_lets_the_write_finish() {
    // The render is complete and being written (a 2 s stand-in for a slow write): the
    // signal must neither cut the file short nor lose it. The render was not interrupted.
    let c = cornell();
    let dir = temp_dir();
    let out = dir.path().join("out.exr");
    let child = spawn(&render_args(out.to_str().unwrap(), &c, &["--spp", "4", "--debug-delay", "writing=2"]));
    let (code, elapsed, lines) = term_when(child, |v| is_phase(v, "writing"));
    assert_eq!(code, Some(0), "{lines:?}");
    assert!(elapsed < Duration::from_secs(2) + STOP_BOUND, "{elapsed:?}");
    assert_eq!(files_in(dir.path()), vec!["out.exr".to_string()]);
    let (w, h, px) = caustic::output::read_combined(&out).unwrap();
    assert_eq!((w, h), (48, 48));
    assert!(px.iter().all(|p| p.iter().all(|c| c.is_finite())));
}

#[test]
fn a_second_signal_while_writing_keeps_the_interim_image() {
    // With an interim image in place, abandoning the final write leaves that image: exit 5.
    let c = cornell();
    let dir = temp_dir();
    let out = dir.path().join("out.exr");
    let mut child = spawn(&render_args(
        out.to_str().unwrap(),
        &c,
        &["--spp", "64", "--interim", "0.001", "--debug-delay", "writing=60"],
    ));
    let mut interim = false;
    for line in std::io::BufReader::new(child.stderr.take().unwrap()).lines() {
        let v: Value = serde_json::from_str(&line.unwrap()).unwrap();
        interim |= v["type"] == "image" && v["final"] == false;
        if is_phase(&v, "writing") {
            break;
        }
    }
    assert!(interim, "no interim image was written");
    signal(&child, "-TERM");
    std::thread::sleep(Duration::from_millis(200));
    signal(&child, "-TERM");
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(5));
    assert_eq!(files_in(dir.path()), vec!["out.exr".to_string()]);
    let (_, _, px) = caustic::output::read_combined(&out).expect("the interim image, whole");
    assert!(px.iter().map(|p| p[0] as f64).sum::<f64>() > 0.0);
}

#[test]
fn a_second_signal_ends_the_process_at_once() {
    let c = cornell();
    let dir = temp_dir();
    let out = dir.path().join("out.exr");
    let mut child = spawn(&render_args(out.to_str().unwrap(), &c, &["--debug-delay", "bvh=60"]));
    let lines = std::io::BufReader::new(child.stderr.take().unwrap()).lines();
    for line in lines {
        if is_phase(&serde_json::from_str(&line.unwrap()).unwrap(), "bvh") {
            break;
        }
    }
    signal(&child, "-TERM");
    let t = Instant::now();
    std::thread::sleep(Duration::from_millis(200));
    signal(&child, "-TERM");
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(6));
    // The watchdog alone would take 1.5 s: ending well before shows the second signal did it.
    assert!(t.elapsed() < Duration::from_millis(1200), "{:?}", t.elapsed());
    assert!(files_in(dir.path()).is_empty());
}

/// A pid that is certainly not running: a child that has exited and been reaped.
fn dead_pid() -> u32 {
    let mut c = Command::new("true").spawn().unwrap();
    let pid = c.id();
    c.wait().unwrap();
    pid
}

#[test]
fn sigkill_leaves_at_most_a_temp_file_and_the_next_run_removes_it() {
    let c = cornell();
    let dir = temp_dir();
    let out = dir.path().join("out.exr");
    let out_s = out.to_str().unwrap();
    let prefix = ".out.exr.caustic-tmp-";
    // Kill at different moments of a render that rewrites its output all the time.
    for i in 0..8u64 {
        let mut child = spawn(&[
            "render",
            &c,
            "-o",
            out_s,
            "--resolution",
            "256x256",
            "--spp",
            "100000",
            "--interim",
            "0.001",
            "--progress",
            "none",
        ]);
        std::thread::sleep(Duration::from_millis(150 + 97 * i));
        signal(&child, "-KILL");
        child.wait().unwrap();
        for f in files_in(dir.path()) {
            assert!(f == "out.exr" || f.starts_with(prefix), "unexpected file {f}");
        }
        if out.exists() {
            // Whatever was in place is a whole image: renames are atomic.
            let (w, h, px) = caustic::output::read_combined(&out).expect("a complete EXR");
            assert_eq!((w, h), (256, 256));
            assert!(px.iter().all(|p| p.iter().all(|c| c.is_finite())));
        }
    }
    // A killed run's temp (dead pid) goes; a running process's temp stays.
    let stale = dir.path().join(format!("{prefix}{}", dead_pid()));
    let live = dir.path().join(format!("{prefix}{}", std::process::id()));
    std::fs::write(&stale, b"half an EXR").unwrap();
    std::fs::write(&live, b"someone else's").unwrap();
    let r = common::run(&["render", &c, "-o", out_s, "--resolution", "16x16", "--spp", "1"], Duration::from_secs(60));
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    let left = files_in(dir.path());
    assert!(!left.iter().any(|f| f.starts_with(prefix) && f != &live.file_name().unwrap().to_string_lossy()));
    assert!(live.exists(), "the temp file of a running process was removed");
    std::fs::remove_file(&live).unwrap();
    assert_eq!(files_in(dir.path()), vec!["out.exr".to_string()]);
}
