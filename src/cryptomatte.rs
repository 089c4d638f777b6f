//! Cryptomatte (Friedman and Jones 2015, specification 1.2) as Cycles writes it: per pixel
//! and per layer (Object, Material, Asset) the ids of the entities its samples saw, each
//! with the fraction of the samples that saw it, ranked by that fraction.
//!
//! * An id is MurmurHash3_32 (seed 0) of the entity's name, turned into a float whose
//!   exponent is kept away from 0 and 255 (no denormal, infinity or NaN), as the
//!   specification's `uint32_to_float32` and Cycles' `util_hash_to_float`.
//! * Per pixel, a layer keeps a fixed number of (id, count) slots, Blender's levels rounded
//!   up to even (each EXR pass `CryptoObject00`, `01`, … holds two ranks in R G B A). A
//!   sample's id goes to its slot, or to the first free one; when all are taken, to the last
//!   slot, as Cycles' `film_write_cryptomatte_slots` does. Counts are integers: the pass is
//!   exact and the hot loop allocates nothing.
//! * The image ranks the slots by count (a stable insertion order for ties, as Cycles'
//!   `film_sort_cryptomatte_slots`) and divides by the pixel's samples.
//! * Chunks (`render --chunk`) keep more slots, [`EXACT_SLOTS`] per layer, filled by the
//!   same rule: a pixel's slots are then its distinct ids in first-seen order with their
//!   exact counts (unless it saw more ids, which is counted). The capped slots a single
//!   render keeps depend only on that list (its first ids keep their counts, the last slot
//!   takes every later id's), so the image replays it into them ([`capped`]) and a merge
//!   appends one chunk's list to the other's in sample order ([`add_n`]): merged chunks
//!   give the single render's Cryptomatte bit for bit.
//! * The manifest (`{"name":"hash in 8 hex digits",…}`) and the layer's name, hash and
//!   conversion go into the EXR header under `cryptomatte/<7 hex digits of the name's
//!   hash>/…`, so that compositors find the names.

use crate::error::{Error, Result};

/// The three Cryptomatte layers Blender offers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Kind {
    /// Objects, by object name.
    Object,
    /// Materials, by material name.
    Material,
    /// Assets: an object's topmost parent, by its name.
    Asset,
}

/// The layers in the order Cycles lays them out in its film (object, material, asset).
pub const KINDS: [Kind; 3] = [Kind::Object, Kind::Material, Kind::Asset];

/// Blender's most levels (`pass_cryptomatte_depth` is 2..=16).
pub const MAX_LEVELS: u32 = 16;

/// Blender's default levels.
pub const DEFAULT_LEVELS: u32 = 6;

/// Slots per pixel and layer a chunk keeps (at least the levels'): the distinct ids a pixel
/// of a chunk may see and still merge exactly. 8 bytes each per pixel.
pub const EXACT_SLOTS: u32 = 16;

impl Kind {
    /// Blender's pass name prefix (`CryptoObject00`, ...).
    pub fn name(self) -> &'static str {
        match self {
            Kind::Object => "CryptoObject",
            Kind::Material => "CryptoMaterial",
            Kind::Asset => "CryptoAsset",
        }
    }

    /// Index in [`KINDS`] and in a sample's ids.
    pub fn index(self) -> usize {
        self as usize
    }
}

/// MurmurHash3_32 (x86, 32-bit) of `data` with seed 0, as the Cryptomatte specification uses.
pub fn murmur3_32(data: &[u8]) -> u32 {
    const C1: u32 = 0xcc9e_2d51;
    const C2: u32 = 0x1b87_3593;
    let mut h: u32 = 0;
    let mut blocks = data.chunks_exact(4);
    for b in &mut blocks {
        let mut k = u32::from_le_bytes([b[0], b[1], b[2], b[3]]);
        k = k.wrapping_mul(C1).rotate_left(15).wrapping_mul(C2);
        h ^= k;
        h = h.rotate_left(13).wrapping_mul(5).wrapping_add(0xe654_6b64);
    }
    let tail = blocks.remainder();
    if !tail.is_empty() {
        let mut k = 0u32;
        for (i, &byte) in tail.iter().enumerate() {
            k ^= (byte as u32) << (8 * i);
        }
        h ^= k.wrapping_mul(C1).rotate_left(15).wrapping_mul(C2);
    }
    h ^= data.len() as u32;
    h ^= h >> 16;
    h = h.wrapping_mul(0x85eb_ca6b);
    h ^= h >> 13;
    h = h.wrapping_mul(0xc2b2_ae35);
    h ^ (h >> 16)
}

/// The bits of the float a hash becomes: its exponent clamped to 1..=254, so that the id is
/// a normal, finite float (never 0, which marks an empty slot).
pub fn hash_to_float_bits(hash: u32) -> u32 {
    let exponent = ((hash >> 23) & 0xff).clamp(1, 254);
    (hash & 0x8000_0000) | (exponent << 23) | (hash & 0x007f_ffff)
}

/// The float id of a name (its bits: [`hash_to_float_bits`] of its MurmurHash3).
pub fn id_of(name: &str) -> u32 {
    hash_to_float_bits(murmur3_32(name.as_bytes()))
}

/// Which layers a render writes and with how many levels.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Layout {
    /// Bit `Kind::index()` set for each layer written.
    pub kinds: u8,
    /// Slots per pixel and layer: the levels rounded up to even (0 without layers).
    pub slots: u32,
    /// Keep [`EXACT_SLOTS`] per layer for an exact merge of chunks (see the module doc).
    pub exact: bool,
}

impl Layout {
    /// The layers `kinds` with Blender's `levels` (2..=16).
    pub fn new(kinds: &[Kind], levels: u32) -> Result<Layout> {
        if !(2..=MAX_LEVELS).contains(&levels) {
            return Err(Error::Usage(format!(
                "cryptomatte levels {levels} out of range (Blender's 2 to {MAX_LEVELS})"
            )));
        }
        let mask = kinds.iter().fold(0u8, |m, k| m | 1 << k.index());
        Ok(Layout { kinds: mask, slots: if mask == 0 { 0 } else { levels.div_ceil(2) * 2 }, exact: false })
    }

    /// This layout keeping the slots an exact merge of chunks needs.
    pub fn with_exact(self) -> Layout {
        Layout { exact: true, ..self }
    }

    /// Slots the film keeps per pixel and layer.
    pub fn kept(self) -> u32 {
        if self.exact && self.slots > 0 { self.slots.max(EXACT_SLOTS) } else { self.slots }
    }

    /// True when no layer is written.
    pub fn is_empty(self) -> bool {
        self.kinds == 0
    }

    /// True when layer `k` is written.
    pub fn contains(self, k: Kind) -> bool {
        self.kinds >> k.index() & 1 == 1
    }

    /// The layers written, in [`KINDS`] order.
    pub fn iter(self) -> impl Iterator<Item = Kind> {
        KINDS.into_iter().filter(move |k| self.contains(*k))
    }

    /// Slots kept per pixel over all layers.
    pub fn stride(self) -> usize {
        self.kinds.count_ones() as usize * self.kept() as usize
    }

    /// The EXR passes of one layer (`CryptoObject00`, `CryptoObject01`, ...).
    pub fn pass_names(self, k: Kind) -> impl Iterator<Item = String> {
        (0..self.slots / 2).map(move |i| format!("{}{i:02}", k.name()))
    }
}

/// One (id, samples) entry of a pixel's layer; id 0 is an empty slot.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Slot {
    /// The float id's bits.
    pub id: u32,
    /// Samples that saw the id.
    pub count: u32,
}

/// Counts one sample that saw `id` (0: nothing, not counted) in a layer's `slots`; false
/// when every slot held another id (the count went to the last slot's id).
#[inline]
pub fn add(slots: &mut [Slot], id: u32) -> bool {
    add_n(slots, id, 1)
}

/// Counts `n` samples that saw `id`, as `n` calls of [`add`] would.
#[inline]
pub fn add_n(slots: &mut [Slot], id: u32, n: u32) -> bool {
    if id == 0 || n == 0 {
        return true;
    }
    let last = slots.len() - 1;
    for (i, s) in slots.iter_mut().enumerate() {
        if s.id == 0 {
            *s = Slot { id, count: n };
            return true;
        }
        // Cycles: the id's slot, or when every slot holds another id, the last one.
        if s.id == id || i == last {
            s.count += n;
            return s.id == id;
        }
    }
    true
}

/// The slots a render keeping `out.len()` slots holds, from a pixel's exact first-seen list
/// `kept` (a chunk's slots): each entry counted in order.
pub fn capped(kept: &[Slot], out: &mut [Slot]) {
    out.fill(Slot::default());
    for s in kept.iter().take_while(|s| s.id != 0) {
        add_n(out, s.id, s.count);
    }
}

/// Appends the exact lists `theirs` of a pixel's layers (`per` slots each) to `mine` (before
/// them when `theirs_first`), in place; returns the samples counted under another id.
pub fn merge_lists(mine: &mut [Slot], theirs: &[Slot], per: usize, theirs_first: bool) -> u64 {
    // One layer's list on the stack: at most the levels' 16 or EXACT_SLOTS.
    let mut earlier = [Slot::default(); (MAX_LEVELS + EXACT_SLOTS) as usize];
    let mut folded = 0;
    for (a, b) in mine.chunks_exact_mut(per).zip(theirs.chunks_exact(per)) {
        let (first, second) = if theirs_first { (b, &*a) } else { (&*a, b) };
        let earlier = &mut earlier[..per];
        earlier.copy_from_slice(first);
        for s in second.iter().take_while(|s| s.id != 0) {
            if !add_n(earlier, s.id, s.count) {
                folded += s.count as u64;
            }
        }
        a.copy_from_slice(earlier);
    }
    folded
}

/// Ranks a layer's slots by count, highest first, keeping the order of equal counts (an
/// insertion sort, as Cycles', over a handful of entries).
pub fn rank(slots: &mut [Slot]) {
    for i in 1..slots.len() {
        if slots[i].id == 0 {
            return;
        }
        let mut j = i;
        while j > 0 && slots[j].count > slots[j - 1].count {
            slots.swap(j, j - 1);
            j -= 1;
        }
    }
}

/// The EXR header attributes of layer `k` whose entities are `names`: `(key, value)` pairs,
/// the specification's keys under `cryptomatte/<first 7 hex digits of the layer name's hash>/`.
pub fn header(k: Kind, names: &[String]) -> Vec<(String, String)> {
    let layer = k.name();
    let key = format!("cryptomatte/{}", &format!("{:08x}", murmur3_32(layer.as_bytes()))[..7]);
    let mut manifest = String::from("{");
    for (i, n) in names.iter().enumerate() {
        if i > 0 {
            manifest.push(',');
        }
        // serde_json escapes quotes, backslashes and control characters in the name.
        manifest.push_str(&serde_json::to_string(n).unwrap_or_default());
        manifest.push_str(&format!(":\"{:08x}\"", murmur3_32(n.as_bytes())));
    }
    manifest.push('}');
    vec![
        (format!("{key}/name"), layer.to_string()),
        (format!("{key}/hash"), "MurmurHash3_32".into()),
        (format!("{key}/conversion"), "uint32_to_float32".into()),
        (format!("{key}/manifest"), manifest),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Reference values: Blender's own test of its metadata keys (BKE cryptomatte tests:
    /// "ViewLayer.CryptoMaterial" gives the key hash c7dbf5e…) and MurmurHash3's published
    /// vectors (empty input 0, "hello" 0x248bfa47 with seed 0).
    #[test]
    fn murmur_matches_reference_values() {
        assert_eq!(murmur3_32(b""), 0);
        assert_eq!(murmur3_32(b"hello"), 0x248b_fa47);
        assert!(format!("{:08x}", murmur3_32(b"ViewLayer.CryptoMaterial")).starts_with("c7dbf5e"));
    }

    #[test]
    fn float_ids_are_normal_floats() {
        for h in [0u32, 0xffff_ffff, 0x7f80_0000, 0x0000_0001, 0x8000_0000] {
            let f = f32::from_bits(hash_to_float_bits(h));
            assert!(f.is_normal(), "{h:08x} -> {f}");
        }
        // A hash whose exponent is already in range is unchanged.
        assert_eq!(hash_to_float_bits(0x3f80_1234), 0x3f80_1234);
    }

    #[test]
    fn slots_fill_count_and_overflow_into_the_last() {
        let mut s = [Slot::default(); 4];
        for id in [7, 7, 9, 0, 11, 13, 15, 7] {
            add(&mut s, id);
        }
        // 15 found every slot taken: it counts in the last one (13's), as in Cycles.
        assert_eq!(
            s,
            [Slot { id: 7, count: 3 }, Slot { id: 9, count: 1 }, Slot { id: 11, count: 1 }, Slot { id: 13, count: 2 }]
        );
        rank(&mut s);
        assert_eq!(s.map(|x| x.id), [7, 13, 9, 11]);
    }

    /// A long list kept exactly and replayed into few slots gives what those slots hold when
    /// the samples are counted straight into them, for any split of the samples into two
    /// chunks merged in order (a small LCG draws the ids: 9 of them over 200 samples).
    #[test]
    fn exact_lists_replay_into_the_capped_slots() {
        let mut x = 12345u32;
        let ids: Vec<u32> = (0..200)
            .map(|_| {
                x = x.wrapping_mul(1_103_515_245).wrapping_add(12345);
                (x >> 16) % 10 // 0 is "nothing"
            })
            .collect();
        for split in [0, 1, 37, 120, 200] {
            let mut direct = [Slot::default(); 4];
            for &id in &ids {
                add(&mut direct, id);
            }
            let (mut a, mut b) = ([Slot::default(); EXACT_SLOTS as usize], [Slot::default(); EXACT_SLOTS as usize]);
            assert!(ids[..split].iter().all(|&id| add(&mut a, id)) && ids[split..].iter().all(|&id| add(&mut b, id)));
            for s in b.iter().take_while(|s| s.id != 0) {
                assert!(add_n(&mut a, s.id, s.count));
            }
            let mut replayed = [Slot::default(); 4];
            capped(&a, &mut replayed);
            assert_eq!(replayed, direct, "split at {split}");
        }
        let mut full = [Slot::default(); 2];
        assert!(add(&mut full, 1) && add(&mut full, 2) && !add(&mut full, 3) && add(&mut full, 2));
    }

    #[test]
    fn layout_rounds_levels_up_to_pairs() {
        let l = Layout::new(&[Kind::Object, Kind::Asset], 3).unwrap();
        assert_eq!((l.slots, l.stride()), (4, 8));
        assert!(l.contains(Kind::Asset) && !l.contains(Kind::Material));
        assert_eq!(l.pass_names(Kind::Asset).collect::<Vec<_>>(), ["CryptoAsset00", "CryptoAsset01"]);
        assert!(Layout::new(&[Kind::Object], 17).is_err());
    }

    #[test]
    fn header_has_the_specification_keys() {
        let h = header(Kind::Object, &["Cube".into(), "Say \"hi\"".into()]);
        let key = &format!("{:08x}", murmur3_32(b"CryptoObject"))[..7];
        assert_eq!(h[0], (format!("cryptomatte/{key}/name"), "CryptoObject".into()));
        let manifest: serde_json::Value = serde_json::from_str(&h[3].1).unwrap();
        assert_eq!(manifest["Cube"], format!("{:08x}", murmur3_32(b"Cube")));
        assert!(manifest.get("Say \"hi\"").is_some());
    }
}
