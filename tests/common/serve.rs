//! `caustic serve` driven over pipes as the add-on drives it, for tests/server.rs and
//! tests/server_objects.rs: requests and their replies, frames by generation, and the image
//! comparisons the served frames are held to.

use super::{bin, render_image, root};
use serde_json::Value;
use std::io::{Read, Write};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc::{Receiver, RecvTimeoutError, channel};
use std::time::{Duration, Instant};

/// Longest wait for any one reply or frame: the scenes here render in well under a second
/// per pass; this only turns a hang into a failure.
pub const LIMIT: Duration = Duration::from_secs(60);

/// One `caustic serve` process: its stdin, and its messages as a reader thread parsed them.
pub struct Server {
    child: Child,
    stdin: Option<ChildStdin>,
    rx: Receiver<(Value, Vec<u8>)>,
}

/// One framed message.
pub fn frame(header: &Value, payload: &[u8]) -> Vec<u8> {
    let h = serde_json::to_vec(header).unwrap();
    let mut m = Vec::new();
    m.extend_from_slice(&(h.len() as u32).to_le_bytes());
    m.extend_from_slice(&(payload.len() as u32).to_le_bytes());
    m.extend_from_slice(&h);
    m.extend_from_slice(payload);
    m
}

impl Server {
    /// Starts `caustic serve` on two threads.
    pub fn start() -> Server {
        let mut child = Command::new(bin())
            .args(["serve", "--threads", "2"])
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("start caustic serve");
        let mut out = child.stdout.take().unwrap();
        let (tx, rx) = channel();
        std::thread::spawn(move || {
            loop {
                let mut prefix = [0u8; 8];
                if out.read_exact(&mut prefix).is_err() {
                    return;
                }
                let hl = u32::from_le_bytes(prefix[..4].try_into().unwrap()) as usize;
                let pl = u32::from_le_bytes(prefix[4..].try_into().unwrap()) as usize;
                let mut h = vec![0; hl];
                let mut p = vec![0; pl];
                if out.read_exact(&mut h).is_err() || out.read_exact(&mut p).is_err() {
                    return;
                }
                if tx.send((serde_json::from_slice(&h).expect("the server's headers are JSON"), p)).is_err() {
                    return;
                }
            }
        });
        let stdin = child.stdin.take();
        Server { child, stdin, rx }
    }

    /// Writes raw bytes to the server.
    pub fn raw(&mut self, bytes: &[u8]) {
        let s = self.stdin.as_mut().unwrap();
        s.write_all(bytes).unwrap();
        s.flush().unwrap();
    }

    /// Closes the server's input (the end of the stream, as a client that went away).
    pub fn close_input(&mut self) {
        drop(self.stdin.take());
    }

    /// Sends a request without payload.
    pub fn send(&mut self, header: Value) {
        self.raw(&frame(&header, &[]));
    }

    /// The next reply to a request (ok, error or hello), skipping frames and progress.
    pub fn reply(&self) -> Value {
        let end = Instant::now() + LIMIT;
        loop {
            let (h, _) = self.rx.recv_timeout(end - Instant::now()).expect("a reply in time");
            if matches!(h["type"].as_str(), Some("ok" | "error" | "hello")) {
                return h;
            }
        }
    }

    /// Sends a request and returns its ok reply, failing on an error.
    pub fn ok(&mut self, header: Value) -> Value {
        self.send(header.clone());
        let r = self.reply();
        assert_eq!(r["type"], "ok", "{header} was refused: {r}");
        r
    }

    /// Sends raw bytes and returns the error reply they must cause.
    pub fn error_for(&mut self, bytes: &[u8]) -> String {
        self.raw(bytes);
        let r = self.reply();
        assert_eq!(r["type"], "error", "expected an error reply, got {r}");
        r["message"].as_str().unwrap().to_string()
    }

    /// The first frame of `generation`; with `done`, the frame the render finished on.
    pub fn frame(&self, generation: u64, done: bool) -> (Value, Vec<u8>) {
        let end = Instant::now() + LIMIT;
        let mut last = None;
        loop {
            let (h, p) = match self.rx.recv_timeout(end.saturating_duration_since(Instant::now())) {
                Ok(m) => m,
                Err(RecvTimeoutError::Timeout) => panic!("no frame of generation {generation} in time"),
                Err(e) => panic!("the server ended: {e}"),
            };
            if h["generation"].as_u64() != Some(generation) {
                continue;
            }
            match h["type"].as_str() {
                Some("frame") if !done => return (h, p),
                Some("frame") => last = Some((h, p)),
                Some("done") => return last.expect("a frame before done"),
                _ => {}
            }
        }
    }

    /// Closes stdin and checks that the server ends cleanly.
    pub fn finish(mut self) {
        drop(self.stdin.take());
        let end = Instant::now() + LIMIT;
        loop {
            if let Some(st) = self.child.try_wait().unwrap() {
                assert!(st.success(), "the server ended with {st}");
                return;
            }
            assert!(Instant::now() < end, "the server did not end at the end of its input");
            std::thread::sleep(Duration::from_millis(5));
        }
    }
}

/// The bundled Cornell box.
pub fn cornell() -> String {
    root().join("scenes/cornell_box.gltf").display().to_string()
}

/// A frame's f32 payload as values.
pub fn f32_pixels(p: &[u8]) -> Vec<f32> {
    p.chunks_exact(4).map(|b| f32::from_le_bytes(b.try_into().unwrap())).collect()
}

/// Mean colour of RGBA pixels.
pub fn mean_rgb(px: &[f32]) -> [f64; 3] {
    let n = (px.len() / 4) as f64;
    let mut m = [0.0; 3];
    for p in px.chunks_exact(4) {
        for c in 0..3 {
            m[c] += p[c] as f64 / n;
        }
    }
    m
}

/// The generation a reply names.
pub fn generation(r: &Value) -> u64 {
    r["generation"].as_u64().unwrap()
}

/// The Cornell box with the named nodes left out of its scene, rendered at 4 spp by
/// `caustic render`.
pub fn cornell_without(dir: &std::path::Path, names: &[&str]) -> Vec<f32> {
    let src = root().join("scenes/cornell_box.gltf");
    let mut doc: Value = serde_json::from_str(&std::fs::read_to_string(&src).unwrap()).unwrap();
    let keep: Vec<Value> = doc["scenes"][0]["nodes"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|n| !names.contains(&doc["nodes"][n.as_u64().unwrap() as usize]["name"].as_str().unwrap()))
        .cloned()
        .collect();
    doc["scenes"][0]["nodes"] = Value::Array(keep);
    let path = dir.join(format!("without_{}.gltf", names.join("_")));
    std::fs::write(&path, doc.to_string()).unwrap();
    let _ = std::fs::copy(root().join("scenes/cornell_box.bin"), dir.join("cornell_box.bin"));
    let img = render_image(&path, &path.with_extension("exr"), &["--spp", "4", "--threads", "2"], LIMIT);
    img.iter().flatten().copied().collect()
}

/// The same samples of the same scene, up to float rounding of the geometry: paths that meet
/// a surface placed by different roundings continue from points ulps apart, so their pixels
/// differ in the last digits (a relative 1e-4 covers the drift of a few bounces by orders of
/// magnitude), and a path grazing an edge may part another way and change its pixel by a
/// sample's share: 1 % of the pixels are let off. Means agree to 1e-3.
pub fn assert_same_image(served: &[f32], reference: &[f32], what: &str) {
    let (a, b) = (mean_rgb(served), mean_rgb(reference));
    for c in 0..3 {
        assert!(
            (a[c] - b[c]).abs() <= 1e-3 * b[c].max(1e-6),
            "{what}, channel {c}: served {} vs render {}",
            a[c],
            b[c]
        );
    }
    let floor = 1e-3 * (b[0] + b[1] + b[2]) as f32 / 3.0;
    let differing = served
        .chunks(4)
        .zip(reference.chunks(4))
        .filter(|(x, y)| x.iter().zip(y.iter()).any(|(p, q)| (p - q).abs() > 1e-4 * q.abs().max(floor)))
        .count();
    assert!(differing * 100 < served.len() / 4, "{what}: {differing} of {} pixels differ", served.len() / 4);
}
