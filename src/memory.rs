//! The memory budget: large buffers (decoded textures, mesh and BVH, photon maps, film,
//! SPPM's per-pixel state) are estimated before they are allocated, and a scene or
//! setting that would exceed the budget fails with [`Error::Memory`] naming the biggest
//! items, instead of the process being killed by the operating system half-way.
//!
//! The budget is `--memory-limit` (bytes with an optional K/M/G/T suffix, a percentage
//! of the machine's available memory, or `none`); by default it is 90 % of what the
//! machine can give this process: the smaller of `MemAvailable` in `/proc/meminfo`
//! and the cgroup's memory limit. Where neither can be read the default is 8 GiB and
//! the error message says so. Estimates are upper-ish bounds of the peak (documented
//! per item where it is charged), not measurements.

use crate::error::{Error, Result};
use std::sync::Mutex;

/// Share of the available memory the default budget takes: the rest is headroom for
/// the allocations nobody estimates (stacks, small vectors, the allocator's slack).
pub const DEFAULT_SHARE: f64 = 0.9;

/// Budget when the machine's memory cannot be read.
pub const FALLBACK_BYTES: u64 = 8 << 30;

/// Where the limit came from, for messages.
#[derive(Clone, Debug, PartialEq)]
pub enum LimitSource {
    /// `--memory-limit` in bytes.
    Flag,
    /// A share of the available memory (the default, or `--memory-limit N%`).
    Available {
        /// The share in [0, 1].
        share: f64,
        /// The available bytes it was taken of.
        available: u64,
        /// What "available" was read from.
        from: &'static str,
    },
    /// The machine's memory could not be read.
    Fallback,
    /// No limit (`--memory-limit none`, and library callers that ask for none).
    Unlimited,
}

/// A memory budget and the estimates charged against it so far.
#[derive(Debug)]
pub struct MemoryBudget {
    limit: u64,
    source: LimitSource,
    /// (what, bytes) of every charge, in order; read for the error message.
    charges: Mutex<Vec<(String, u64)>>,
}

impl MemoryBudget {
    /// No limit: estimates are still recorded (and can be read) but never refused.
    pub fn unlimited() -> Self {
        MemoryBudget { limit: u64::MAX, source: LimitSource::Unlimited, charges: Mutex::new(Vec::new()) }
    }

    /// A budget of `bytes`.
    pub fn bytes(bytes: u64) -> Self {
        MemoryBudget { limit: bytes, source: LimitSource::Flag, charges: Mutex::new(Vec::new()) }
    }

    /// `share` of the machine's available memory ([`available_memory`]).
    pub fn share_of_available(share: f64) -> Self {
        match available_memory() {
            Some((available, from)) => MemoryBudget {
                limit: (available as f64 * share) as u64,
                source: LimitSource::Available { share, available, from },
                charges: Mutex::new(Vec::new()),
            },
            None => {
                MemoryBudget { limit: FALLBACK_BYTES, source: LimitSource::Fallback, charges: Mutex::new(Vec::new()) }
            }
        }
    }

    /// The budget for `--memory-limit VALUE` (None: the default, [`DEFAULT_SHARE`] of
    /// the available memory).
    pub fn from_flag(value: Option<&str>) -> Result<Self> {
        let Some(v) = value else { return Ok(Self::share_of_available(DEFAULT_SHARE)) };
        let v = v.trim();
        if v.eq_ignore_ascii_case("none") {
            return Ok(Self::unlimited());
        }
        if let Some(p) = v.strip_suffix('%') {
            let p: f64 = p.trim().parse().map_err(|_| bad_limit(v))?;
            if !(p > 0.0 && p <= 100.0) {
                return Err(bad_limit(v));
            }
            return Ok(Self::share_of_available(p / 100.0));
        }
        Ok(Self::bytes(parse_bytes(v).ok_or_else(|| bad_limit(v))?))
    }

    /// The limit in bytes (u64::MAX when unlimited).
    pub fn limit(&self) -> u64 {
        self.limit
    }

    /// Sum of the charges so far.
    pub fn charged(&self) -> u64 {
        self.charges.lock().map(|c| c.iter().fold(0u64, |s, (_, b)| s.saturating_add(*b))).unwrap_or(0)
    }

    /// Charges `bytes` for `what` (a phrase such as "film for 640x480 pixels"); fails,
    /// without recording it, when the running total would exceed the limit.
    pub fn charge(&self, what: impl Into<String>, bytes: u64) -> Result<()> {
        let what = what.into();
        let mut charges = self.charges.lock().map_err(|_| Error::Internal("memory budget poisoned".into()))?;
        let before = charges.iter().fold(0u64, |s, (_, b)| s.saturating_add(*b));
        let total = before.saturating_add(bytes);
        if total > self.limit {
            let mut items: Vec<(String, u64)> = charges.clone();
            items.push((what.clone(), bytes));
            items.sort_by_key(|item| std::cmp::Reverse(item.1));
            let list: Vec<String> = items.iter().take(4).map(|(w, b)| format!("{w}: {}", human(*b))).collect();
            return Err(Error::Memory(format!(
                "{what} would need an estimated {}, bringing the total to {}, over the memory limit of {} ({}); largest items: {}. Lower the setting, simplify the scene, or raise --memory-limit",
                human(bytes),
                human(total),
                human(self.limit),
                self.describe_source(),
                list.join(", ")
            )));
        }
        charges.push((what, bytes));
        Ok(())
    }

    /// Charges a transient peak: `bytes` that are freed again before the next charge
    /// (a decoder's scratch buffer), checked against what is left but not kept.
    pub fn check_peak(&self, what: impl Into<String>, bytes: u64) -> Result<()> {
        let what = what.into();
        self.charge(what.clone(), bytes)?;
        if let Ok(mut c) = self.charges.lock()
            && let Some(i) = c.iter().rposition(|(w, b)| *w == what && *b == bytes)
        {
            c.remove(i);
        }
        Ok(())
    }

    /// Where the limit came from, in words.
    pub fn describe_source(&self) -> String {
        match &self.source {
            LimitSource::Flag => "set by --memory-limit".into(),
            LimitSource::Available { share, available, from } => {
                format!("{:.0} % of the {} available per {from}", share * 100.0, human(*available))
            }
            LimitSource::Fallback => format!(
                "the machine's available memory could not be read, so {} was assumed; set --memory-limit",
                human(FALLBACK_BYTES)
            ),
            LimitSource::Unlimited => "no limit".into(),
        }
    }
}

fn bad_limit(v: &str) -> Error {
    Error::Usage(format!(
        "--memory-limit '{v}' is not a size (e.g. 8G, 512M, 2000000000), a percentage of the available memory (e.g. 50%), or 'none'"
    ))
}

/// Parses "123", "512K", "8G", "1.5T" (binary multiples; a trailing "B"/"iB" is allowed).
pub fn parse_bytes(s: &str) -> Option<u64> {
    let s = s.trim();
    let s = s.strip_suffix("iB").or_else(|| s.strip_suffix('B')).unwrap_or(s);
    let (num, mult) = match s.chars().last()? {
        'k' | 'K' => (&s[..s.len() - 1], 1u64 << 10),
        'm' | 'M' => (&s[..s.len() - 1], 1 << 20),
        'g' | 'G' => (&s[..s.len() - 1], 1 << 30),
        't' | 'T' => (&s[..s.len() - 1], 1 << 40),
        _ => (s, 1),
    };
    let x: f64 = num.trim().parse().ok()?;
    let bytes = x * mult as f64;
    (x >= 0.0 && bytes.is_finite() && bytes < u64::MAX as f64 && bytes >= 1.0).then_some(bytes as u64)
}

/// A byte count for people: "1.50 GiB".
pub fn human(bytes: u64) -> String {
    const UNITS: [&str; 5] = ["B", "KiB", "MiB", "GiB", "TiB"];
    let mut v = bytes as f64;
    let mut u = 0;
    while v >= 1024.0 && u + 1 < UNITS.len() {
        v /= 1024.0;
        u += 1;
    }
    if u == 0 { format!("{bytes} B") } else { format!("{v:.2} {}", UNITS[u]) }
}

/// The memory this process can use: the smaller of `MemAvailable` (/proc/meminfo) and
/// the cgroup limit (v2 `memory.max`, v1 `memory.limit_in_bytes`), with what it was
/// read from. None when neither can be read (not Linux, or a sandbox hiding /proc).
pub fn available_memory() -> Option<(u64, &'static str)> {
    let meminfo = std::fs::read_to_string("/proc/meminfo").ok().and_then(|s| meminfo_available(&s));
    let cgroup = ["/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"]
        .iter()
        .find_map(|p| std::fs::read_to_string(p).ok().and_then(|s| s.trim().parse::<u64>().ok()));
    match (meminfo, cgroup) {
        (Some(m), Some(c)) if c < m => Some((c, "the cgroup memory limit")),
        (Some(m), _) => Some((m, "MemAvailable in /proc/meminfo")),
        (None, Some(c)) if c < (1 << 50) => Some((c, "the cgroup memory limit")),
        _ => None,
    }
}

/// `MemAvailable` in bytes from the text of /proc/meminfo.
fn meminfo_available(text: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    kb.checked_mul(1024)
}

/// Bytes per pixel of a render's image buffers: the film's per-tile sums, the
/// normalised [`FilmImage`] and the EXR writer's per-channel copies (15 channels of
/// 4 bytes), all counted as if alive at once: 284 B since the sums are fixed point
/// (176 B of i128 sums; 168 B before, against a measured peak of 122 B/pixel for a whole
/// 2048×2048 render of the Cornell box, 1 spp, depth 1).
///
/// [`FilmImage`]: crate::film::FilmImage
pub fn film_bytes_per_pixel() -> u64 {
    let accum = std::mem::size_of::<crate::film::PixelAccum>() as u64;
    let image = 4 * 4 + 4 + 3 * 4 + 3 * 4 + 4;
    let exr = 15 * 4;
    accum + image + exr
}

/// Bytes per triangle of the BVH build and the acceleration structure kept for
/// rendering (the triangle list handed to the builder, the builder's primitive copies,
/// bounds, indices and nodes, the reordered triangles and ids kept by `Accel`): the
/// peak resident memory of `caustic render` on a 2-million-triangle grid rose by
/// 262 B/triangle over `caustic info` on it (obvhs 0.4); charged with a 20 % margin.
pub const BVH_BYTES_PER_TRIANGLE: u64 = 320 + BVH_PLANES_BYTES_PER_TRIANGLE;

/// Bytes per triangle of the float child planes kept beside the BVH's nodes
/// (`accel::planes`, 192 bytes a node): 24.2 B on a 20k-triangle soup, 17.9 B on a
/// grid (the test `planes_fit_their_memory_charge`), charged with a 30 % margin.
pub const BVH_PLANES_BYTES_PER_TRIANGLE: u64 = 32;

/// Bytes per vertex of the flattened world-space mesh (position, normal, tangent, two
/// UV sets, colour).
pub const MESH_BYTES_PER_VERTEX: u64 = 12 + 12 + 16 + 8 + 8 + 16;

/// Bytes per triangle of the flattened mesh (three indices and a material id).
pub const MESH_BYTES_PER_TRIANGLE: u64 = 12 + 4;

/// Photons stored per emitted photon that the tracer reserves room for (see
/// `integrator::photon::trace`), for a path depth of `max_depth`.
pub fn stored_per_emitted(max_depth: u32) -> u64 {
    max_depth.clamp(1, 4) as u64
}

/// Peak bytes of tracing `emitted` photons and building their kd-tree: the tracer's
/// per-chunk buffers, reserved for [`stored_per_emitted`] photons each, live together
/// with the merged list they are copied into (the tree is then built in place).
pub fn photon_map_bytes(emitted: u64, max_depth: u32) -> u64 {
    let p = std::mem::size_of::<crate::integrator::photon::Photon>() as u64;
    emitted.saturating_mul(stored_per_emitted(max_depth)).saturating_mul(p).saturating_mul(2)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse() {
        assert_eq!(parse_bytes("123"), Some(123));
        assert_eq!(parse_bytes("8G"), Some(8 << 30));
        assert_eq!(parse_bytes("512MiB"), Some(512 << 20));
        assert_eq!(parse_bytes("1.5k"), Some(1536));
        assert_eq!(parse_bytes("0"), None);
        assert_eq!(parse_bytes("-3G"), None);
        assert_eq!(parse_bytes("lots"), None);
        assert!(MemoryBudget::from_flag(Some("150%")).is_err());
        assert!(MemoryBudget::from_flag(Some("none")).unwrap().limit() == u64::MAX);
    }

    #[test]
    fn meminfo_is_read() {
        let text = "MemTotal:       24684092 kB\nMemFree: 1 kB\nMemAvailable:   24072744 kB\n";
        assert_eq!(meminfo_available(text), Some(24072744 * 1024));
        assert_eq!(meminfo_available("MemTotal: 5 kB\n"), None);
    }

    #[test]
    fn charges_add_up_and_the_overflow_is_named() {
        let b = MemoryBudget::bytes(1000);
        b.charge("textures", 600).unwrap();
        b.check_peak("decoder scratch", 300).unwrap();
        assert_eq!(b.charged(), 600);
        let e = b.charge("film for 10x10 pixels", 500).unwrap_err();
        let msg = e.to_string();
        assert!(msg.contains("film for 10x10 pixels") && msg.contains("textures"), "{msg}");
        assert_eq!(e.exit_code(), crate::error::exit_code::MEMORY);
        assert_eq!(b.charged(), 600, "a refused charge is not kept");
    }
}
