//! Jensen's pair of photon maps: tracing them, and the photon-map file that lets a
//! static scene be rendered from any camera without tracing photons again
//! (`caustic photons SCENE -o MAP`, `caustic render SCENE --photon-map MAP`).
//!
//! File format (little-endian), version 2:
//!
//! ```text
//! magic      8 bytes  "CAUSTPM\0"
//! version    u32      2
//! scene_hash u64      the scene's source hash (`Scene::source_hash`: the glTF and every file it reads)
//! max_depth  u32      largest hit index stored
//! seed       u32
//! emitted    u64 × 2  photons emitted for the global and the caustic map
//! count      u64 × 2  photons stored in each
//! photons    32 bytes each, global then caustic, in kd-tree order (`kdtree.rs`: leaves of ≤ 16
//!            photons, the median opens the right half; a change of that layout
//!            needs a new version; version 1 had leaves of ≤ 8 and medians in no half):
//!            position f32×3, power f32×3, direction word u32, meta word u32
//! ```
//! A map made for another scene file (different bytes) is refused with a clear error.
//! The hash covers the .gltf/.glb file itself, not external buffers or textures.

use super::trace::{MapKind, TraceJob, TraceStats, trace_photons};
use super::{Photon, PhotonMap};
use crate::error::{Error, Result};
use crate::integrator::SceneContext;
use crate::light::emit::Emitters;
use std::io::{Read, Write};
use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

const MAGIC: &[u8; 8] = b"CAUSTPM\0";
/// Current file version.
pub const VERSION: u32 = 2;

/// The global and caustic maps of a scene.
#[derive(Clone, Debug, Default)]
pub struct PhotonMaps {
    /// Every non-specular photon hit.
    pub global: PhotonMap,
    /// L S+ D photon hits.
    pub caustic: PhotonMap,
    /// Photons emitted for each map.
    pub emitted: [u64; 2],
    /// Largest hit index stored.
    pub max_depth: u32,
    /// Seed.
    pub seed: u32,
    /// Hash of the scene file.
    pub scene_hash: u64,
}

/// Timings and counts of building the maps.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct MapStats {
    /// Tracing counters, global map.
    pub global: TraceStats,
    /// Tracing counters, caustic map.
    pub caustic: TraceStats,
    /// Seconds spent tracing.
    pub trace_seconds: f64,
    /// Seconds spent building the kd-trees.
    pub build_seconds: f64,
}

impl PhotonMaps {
    /// Traces both maps and builds their trees. `progress(done, total, elapsed)` is
    /// called as chunks of photons finish.
    #[allow(clippy::too_many_arguments)]
    pub fn trace(
        ctx: &SceneContext,
        photons: u64,
        caustic_photons: u64,
        seed: u32,
        max_depth: u32,
        scene_hash: u64,
        stop: &AtomicBool,
        progress: &(dyn Fn(u64, u64, f64) + Sync),
    ) -> (Self, MapStats) {
        let emitters = Emitters::new(ctx.scene).with_media(ctx.scene);
        let total = photons + caustic_photons;
        let t0 = Instant::now();
        // Photons carry their light's group whenever the scene has light groups (a byte
        // each beside the map), so that the light group passes can split map reads.
        let light_groups = !ctx.scene.light_groups.is_empty();
        let job = |kind, count| TraceJob { kind, count, seed, pass: 0, max_depth, skip_direct: false, light_groups };
        let (g, g_groups, gs) = trace_photons(ctx, &emitters, &job(MapKind::Global, photons), stop, &|d| {
            progress(d, total, t0.elapsed().as_secs_f64())
        });
        let (c, c_groups, cs) = trace_photons(ctx, &emitters, &job(MapKind::Caustic, caustic_photons), stop, &|d| {
            progress(photons + d, total, t0.elapsed().as_secs_f64())
        });
        let trace_seconds = t0.elapsed().as_secs_f64();
        let t1 = Instant::now();
        let (global, caustic) =
            rayon::join(|| PhotonMap::build_grouped(g, g_groups), || PhotonMap::build_grouped(c, c_groups));
        let build_seconds = t1.elapsed().as_secs_f64();
        (
            PhotonMaps { global, caustic, emitted: [photons, caustic_photons], max_depth, seed, scene_hash },
            MapStats { global: gs, caustic: cs, trace_seconds, build_seconds },
        )
    }

    /// The temporary file [`PhotonMaps::save`] writes before renaming it to `path`.
    pub fn temp_path(path: &Path) -> std::path::PathBuf {
        path.with_extension("tmp-photons")
    }

    /// Writes the maps (atomically: temp file, then rename).
    pub fn save(&self, path: &Path) -> Result<()> {
        let tmp = Self::temp_path(path);
        let write = || -> std::io::Result<()> {
            let f = std::fs::File::create(&tmp)?;
            let mut w = std::io::BufWriter::new(f);
            w.write_all(MAGIC)?;
            w.write_all(&VERSION.to_le_bytes())?;
            w.write_all(&self.scene_hash.to_le_bytes())?;
            w.write_all(&self.max_depth.to_le_bytes())?;
            w.write_all(&self.seed.to_le_bytes())?;
            for e in self.emitted {
                w.write_all(&e.to_le_bytes())?;
            }
            w.write_all(&(self.global.len() as u64).to_le_bytes())?;
            w.write_all(&(self.caustic.len() as u64).to_le_bytes())?;
            for p in self.global.photons().iter().chain(self.caustic.photons()) {
                let mut b = [0u8; 32];
                for (i, v) in p.p.iter().chain(p.power.iter()).enumerate() {
                    b[4 * i..4 * i + 4].copy_from_slice(&v.to_le_bytes());
                }
                let (d, m) = p.words();
                b[24..28].copy_from_slice(&d.to_le_bytes());
                b[28..32].copy_from_slice(&m.to_le_bytes());
                w.write_all(&b)?;
            }
            w.flush()?;
            Ok(())
        };
        if let Err(e) = write() {
            let _ = std::fs::remove_file(&tmp);
            return Err(Error::io(path, e));
        }
        std::fs::rename(&tmp, path).map_err(|e| Error::io(path, e))
    }

    /// Reads maps written by [`save`](Self::save); refuses a map made for another scene.
    pub fn load(path: &Path, expected_scene_hash: u64) -> Result<Self> {
        let bad = |what: &str| Error::Usage(format!("'{}' is not a usable photon map: {what}", path.display()));
        let f = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
        let len = f.metadata().map_err(|e| Error::io(path, e))?.len();
        let mut r = std::io::BufReader::new(f);
        let mut head = [0u8; 8 + 4 + 8 + 4 + 4 + 16 + 16];
        r.read_exact(&mut head).map_err(|_| bad("too short for the header"))?;
        if &head[0..8] != MAGIC {
            return Err(bad("wrong magic bytes"));
        }
        let u32_at = |o: usize| u32::from_le_bytes(head[o..o + 4].try_into().unwrap());
        let u64_at = |o: usize| u64::from_le_bytes(head[o..o + 8].try_into().unwrap());
        let version = u32_at(8);
        if version != VERSION {
            return Err(bad(&format!("file version {version}, this build reads version {VERSION}")));
        }
        let hash = u64_at(12);
        if hash != expected_scene_hash {
            return Err(Error::Usage(format!(
                "the photon map '{}' was made for a different scene file (scene hash {hash:016x}, this scene {expected_scene_hash:016x}); run `caustic photons` on this scene again",
                path.display()
            )));
        }
        let max_depth = u32_at(20);
        let seed = u32_at(24);
        let emitted = [u64_at(28), u64_at(36)];
        let counts = [u64_at(44), u64_at(52)];
        let expect = head.len() as u64 + 32 * (counts[0].saturating_add(counts[1]));
        if len != expect {
            return Err(bad(&format!("{len} bytes where the header announces {expect}")));
        }
        let mut read_map = |n: u64| -> std::io::Result<PhotonMap> {
            let mut v = Vec::with_capacity(n as usize);
            let mut b = [0u8; 32];
            for _ in 0..n {
                r.read_exact(&mut b)?;
                let f = |i: usize| f32::from_le_bytes(b[4 * i..4 * i + 4].try_into().unwrap());
                let w = |o: usize| u32::from_le_bytes(b[o..o + 4].try_into().unwrap());
                v.push(Photon::from_raw([f(0), f(1), f(2)], [f(3), f(4), f(5)], w(24), w(28)));
            }
            Ok(PhotonMap::from_tree_order(v))
        };
        let global = read_map(counts[0]).map_err(|e| Error::io(path, e))?;
        let caustic = read_map(counts[1]).map_err(|e| Error::io(path, e))?;
        Ok(PhotonMaps { global, caustic, emitted, max_depth, seed, scene_hash: hash })
    }
}

/// Photons per second for a count and a duration.
pub fn rate(n: u64, d: Duration) -> f64 {
    n as f64 / d.as_secs_f64().max(1e-9)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn save_load_round_trip_and_refusals() {
        let dir = std::env::temp_dir().join(format!("caustic-pm-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("m.pm");
        let ph: Vec<Photon> = (0..100)
            .map(|i| {
                Photon::new(
                    Vec3::new(i as f32, 0.5, -1.0),
                    Vec3::splat(0.1 * i as f32),
                    Vec3::Y,
                    Vec3::Y,
                    1 + i % 4,
                    i % 5 == 0,
                )
            })
            .collect();
        let maps = PhotonMaps {
            global: PhotonMap::build(ph.clone()),
            caustic: PhotonMap::build(ph[..7].to_vec()),
            emitted: [1000, 70],
            max_depth: 9,
            seed: 3,
            scene_hash: 0xabcdef,
        };
        maps.save(&path).unwrap();
        let back = PhotonMaps::load(&path, 0xabcdef).unwrap();
        assert_eq!(back.global.photons(), maps.global.photons());
        assert_eq!(back.caustic.photons(), maps.caustic.photons());
        assert_eq!((back.emitted, back.max_depth, back.seed), ([1000, 70], 9, 3));
        let e = PhotonMaps::load(&path, 1).unwrap_err().to_string();
        assert!(e.contains("different scene"), "{e}");
        let bytes = std::fs::read(&path).unwrap();
        std::fs::write(&path, &bytes[..bytes.len() - 5]).unwrap();
        assert!(PhotonMaps::load(&path, 0xabcdef).is_err());
        std::fs::write(&path, b"not a photon map at all: plain text, comfortably longer than the 60-byte header.")
            .unwrap();
        assert!(PhotonMaps::load(&path, 0xabcdef).unwrap_err().to_string().contains("magic"));
        let _ = std::fs::remove_dir_all(&dir);
    }
}
