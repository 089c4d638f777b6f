//! The voxel grid file (`.cvol`) that the add-on writes beside the glTF for a volume
//! object, named by the `CAUSTIC_volume` extension (docs/contract.md has the layout).
//! Little-endian, versioned, dense: one index space per file, holding the object's named
//! grids (density, temperature, colour...) over the box of their active voxels.
//!
//! ```text
//! offset  size  field
//! 0       8     magic "CAUSTICV"
//! 8       4     u32 version (1)
//! 12      12    u32 nx, ny, nz (each 1..=MAX_SIDE)
//! 24      48    f32[12] index → object affine, row-major 3×4: voxel (i, j, k) is centred
//!               at M · (i, j, k, 1) (OpenVDB's convention)
//! 72      4     u32 grid count G (1..=MAX_GRIDS)
//! 76      ...   G headers: u32 name length L (1..=255), L bytes of UTF-8, u32 components (1 or 3)
//! ...     ...   G blocks of nx·ny·nz·components f32, x fastest, then y, then z,
//!               components interleaved; the file ends after the last block
//! ```
//!
//! Every value must be finite. Dimensions are charged to the memory budget before the
//! voxels are copied, so an absurd header fails with the memory error, and a header that
//! promises more voxels than the file holds is a truncated file.

use crate::error::{Error, Result};
use crate::memory::MemoryBudget;

/// The magic bytes that open a grid file.
pub const MAGIC: &[u8; 8] = b"CAUSTICV";
/// The format version this reader understands.
pub const VERSION: u32 = 1;
/// Largest side (voxels) accepted: far beyond a production smoke simulation (~1000),
/// small enough that index arithmetic in f32 stays exact.
pub const MAX_SIDE: u32 = 1 << 15;
/// Most grids per file: as many as a volume object's graph reads
/// (`volume_grids::MAX_GRID_SLOTS`), so that every grid it names can be in the file.
pub const MAX_GRIDS: u32 = 16;

/// One named grid of a file.
#[derive(Clone, Debug)]
pub struct NamedGrid {
    /// The grid's name (OpenVDB's: "density", "temperature", "color"...).
    pub name: String,
    /// Values per voxel: 1 (float grid) or 3 (vector/colour grid).
    pub components: u32,
    /// nx·ny·nz·components values, x fastest.
    pub values: Vec<f32>,
}

/// A parsed grid file.
#[derive(Clone, Debug)]
pub struct GridFile {
    /// Voxels per axis.
    pub dims: [u32; 3],
    /// Index → object affine, row-major 3×4.
    pub index_to_object: [f32; 12],
    /// The grids, in file order.
    pub grids: Vec<NamedGrid>,
}

/// Reads little-endian fields from a byte slice, with truncation as an error.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn take(&mut self, n: usize) -> std::result::Result<&[u8], String> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.bytes.len()).ok_or_else(|| {
            format!("truncated: needs {} more bytes at offset {}, the file has {}", n, self.at, self.bytes.len())
        })?;
        let s = &self.bytes[self.at..end];
        self.at = end;
        Ok(s)
    }

    fn u32(&mut self) -> std::result::Result<u32, String> {
        Ok(u32::from_le_bytes(self.take(4)?.try_into().expect("4 bytes")))
    }

    fn f32(&mut self) -> std::result::Result<f32, String> {
        Ok(f32::from_le_bytes(self.take(4)?.try_into().expect("4 bytes")))
    }
}

impl GridFile {
    /// Parses `bytes` (a file named `uri` in messages), charging the voxels to `budget`
    /// before they are copied. Errors are scene errors of `file` (exit 3), or the memory error.
    pub fn parse(bytes: &[u8], uri: &str, file: &str, budget: &MemoryBudget) -> Result<GridFile> {
        let bad =
            |m: String| Error::Scene { file: file.to_string(), message: format!("volume grid file '{uri}': {m}") };
        let mut r = Reader { bytes, at: 0 };
        if r.take(8).map_err(bad)? != MAGIC {
            return Err(bad("not a Caustic grid file (the magic 'CAUSTICV' is missing)".into()));
        }
        let version = r.u32().map_err(bad)?;
        if version != VERSION {
            return Err(bad(format!("version {version} is not supported (this build reads version {VERSION})")));
        }
        let mut dims = [0u32; 3];
        for d in &mut dims {
            *d = r.u32().map_err(bad)?;
        }
        if dims.iter().any(|&d| d == 0 || d > MAX_SIDE) {
            return Err(bad(format!("dimensions {dims:?} are outside 1..={MAX_SIDE} per axis")));
        }
        let mut index_to_object = [0f32; 12];
        for m in &mut index_to_object {
            *m = r.f32().map_err(bad)?;
        }
        if index_to_object.iter().any(|m| !m.is_finite()) {
            return Err(bad("the index-to-object transform is not finite".into()));
        }
        let count = r.u32().map_err(bad)?;
        if !(1..=MAX_GRIDS).contains(&count) {
            return Err(bad(format!("{count} grids (1..={MAX_GRIDS} allowed)")));
        }
        let mut headers = Vec::new();
        for g in 0..count {
            let len = r.u32().map_err(bad)?;
            if !(1..=255).contains(&len) {
                return Err(bad(format!("grid {g}: name length {len} is outside 1..=255")));
            }
            let name = std::str::from_utf8(r.take(len as usize).map_err(bad)?)
                .map_err(|_| bad(format!("grid {g}: the name is not UTF-8")))?
                .to_string();
            let components = r.u32().map_err(bad)?;
            if components != 1 && components != 3 {
                return Err(bad(format!("grid '{name}': {components} components (1 or 3 allowed)")));
            }
            headers.push((name, components));
        }
        // Sides ≤ 2^15 and ≤ 16 grids of ≤ 3 components: the product fits in u64.
        let voxels = dims.iter().map(|&d| d as u64).product::<u64>();
        let values: u64 = headers.iter().map(|(_, c)| voxels * *c as u64).sum();
        budget.charge(format!("volume grids of '{uri}' ({}×{}×{} voxels)", dims[0], dims[1], dims[2]), values * 4)?;
        let remaining = (bytes.len() - r.at) as u64;
        if remaining != values * 4 {
            let what = if remaining < values * 4 { "truncated" } else { "has trailing bytes" };
            return Err(bad(format!(
                "{what}: the header promises {} bytes of voxels, the file holds {remaining}",
                values * 4
            )));
        }
        let mut grids = Vec::with_capacity(headers.len());
        for (name, components) in headers {
            let n = (voxels * components as u64) as usize;
            let raw = r.take(n * 4).map_err(bad)?;
            let values: Vec<f32> =
                raw.chunks_exact(4).map(|b| f32::from_le_bytes(b.try_into().expect("4 bytes"))).collect();
            if let Some(i) = values.iter().position(|v| !v.is_finite()) {
                let v = i / components as usize;
                let (x, y, z) =
                    (v % dims[0] as usize, v / dims[0] as usize % dims[1] as usize, v / (dims[0] * dims[1]) as usize);
                return Err(bad(format!(
                    "grid '{name}': voxel ({x}, {y}, {z}) is {} (values must be finite)",
                    values[i]
                )));
            }
            grids.push(NamedGrid { name, components, values });
        }
        Ok(GridFile { dims, index_to_object, grids })
    }

    /// The bytes of a grid file (the writer the tests use; the add-on has its own in Python).
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = Vec::new();
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&VERSION.to_le_bytes());
        for d in self.dims {
            out.extend_from_slice(&d.to_le_bytes());
        }
        for m in self.index_to_object {
            out.extend_from_slice(&m.to_le_bytes());
        }
        out.extend_from_slice(&(self.grids.len() as u32).to_le_bytes());
        for g in &self.grids {
            out.extend_from_slice(&(g.name.len() as u32).to_le_bytes());
            out.extend_from_slice(g.name.as_bytes());
            out.extend_from_slice(&g.components.to_le_bytes());
        }
        for g in &self.grids {
            for v in &g.values {
                out.extend_from_slice(&v.to_le_bytes());
            }
        }
        out
    }

    /// The grid named `name`, if the file has it.
    pub fn grid(&self, name: &str) -> Option<&NamedGrid> {
        self.grids.iter().find(|g| g.name == name)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> GridFile {
        GridFile {
            dims: [2, 3, 4],
            index_to_object: [0.5, 0.0, 0.0, -1.0, 0.0, 0.5, 0.0, 0.0, 0.0, 0.0, 0.5, 1.0],
            grids: vec![
                NamedGrid { name: "density".into(), components: 1, values: (0..24).map(|i| i as f32).collect() },
                NamedGrid { name: "color".into(), components: 3, values: vec![0.25; 72] },
            ],
        }
    }

    fn parse(bytes: &[u8]) -> Result<GridFile> {
        GridFile::parse(bytes, "v.cvol", "scene.gltf", &MemoryBudget::unlimited())
    }

    #[test]
    fn round_trip() {
        let f = parse(&sample().to_bytes()).expect("parses");
        assert_eq!(f.dims, [2, 3, 4]);
        assert_eq!(f.grid("density").expect("density").values[23], 23.0);
        assert_eq!(f.grid("color").expect("color").components, 3);
    }

    #[test]
    fn bad_files_are_scene_errors() {
        let good = sample().to_bytes();
        let message = |b: &[u8]| match parse(b) {
            Err(e @ Error::Scene { .. }) => e.to_string(),
            other => panic!("expected a scene error, got {other:?}"),
        };
        assert!(message(&good[..good.len() - 3]).contains("truncated"));
        assert!(message(b"NOTAGRID").contains("magic"));
        let mut nan = sample();
        nan.grids[0].values[7] = f32::NAN;
        assert!(message(&nan.to_bytes()).contains("voxel (1, 0, 1)"));
        let mut version = good.clone();
        version[8] = 9;
        assert!(message(&version).contains("version 9"));
    }

    #[test]
    fn absurd_dimensions_hit_the_memory_budget() {
        let mut big = sample();
        big.dims = [MAX_SIDE, MAX_SIDE, MAX_SIDE];
        let r = GridFile::parse(&big.to_bytes(), "v.cvol", "scene.gltf", &MemoryBudget::bytes(1 << 30));
        assert!(matches!(r, Err(Error::Memory(_))), "{r:?}");
    }
}
