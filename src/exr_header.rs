//! Byte-identical EXR files: the attributes of a written header put in name order.
//!
//! The `exr` crate keeps a layer's custom attributes (Cryptomatte's manifest keys, a
//! chunk's info) in a `std::collections::HashMap`, whose iteration order, and so the order
//! the attributes are written in, differs from one process to the next (its `RandomState`
//! is seeded per process). The OpenEXR format gives attribute order no meaning, so sorting
//! the records by name yields the same bytes for the same image without changing what any
//! reader sees. Sorting moves records but keeps the header's length, so the offset table
//! and the pixel blocks after it (whose offsets are absolute) stay valid.

/// OpenEXR's magic number, the first 4 bytes of every file (little-endian).
const MAGIC: u32 = 20_000_630;
/// The version field's flag of a multi-part file (several headers, not handled here).
const MULTIPART: u32 = 0x1000;

/// Sorts the attributes of the single-part EXR file in `file` (as written in memory)
/// by name, in place; fails, naming what is wrong, on anything but a single-part header.
pub fn sort_attributes(file: &mut [u8]) -> Result<(), String> {
    let word = |at: usize| -> Result<u32, String> {
        file.get(at..at + 4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .ok_or_else(|| format!("EXR header truncated at byte {at}"))
    };
    if word(0)? != MAGIC {
        return Err("not an OpenEXR file".into());
    }
    if word(4)? & MULTIPART != 0 {
        return Err("multi-part EXR headers are not sorted".into());
    }
    // Each attribute: name NUL, type NUL, value size (i32 LE), value; an empty name ends
    // the header.
    let start = 8;
    let mut records: Vec<(usize, usize)> = Vec::new();
    let mut pos = start;
    loop {
        let name_end = nul_after(file, pos)?;
        if name_end == pos {
            break;
        }
        let type_end = nul_after(file, name_end + 1)?;
        let size = word(type_end + 1)? as usize;
        let end = (type_end + 5).checked_add(size).filter(|&e| e <= file.len());
        let Some(end) = end else {
            return Err(format!("EXR attribute at byte {pos} runs past the end of the file"));
        };
        records.push((pos, end));
        pos = end;
    }
    let name = |&(at, _): &(usize, usize)| -> &[u8] {
        let len = file[at..].iter().position(|&b| b == 0).unwrap_or(0);
        &file[at..at + len]
    };
    // Names are unique within a header, so the order is total.
    records.sort_by(|a, b| name(a).cmp(name(b)));
    let mut sorted = Vec::with_capacity(pos - start);
    for &(a, b) in &records {
        sorted.extend_from_slice(&file[a..b]);
    }
    file[start..pos].copy_from_slice(&sorted);
    Ok(())
}

/// The index of the first NUL byte at or after `at`.
fn nul_after(file: &[u8], at: usize) -> Result<usize, String> {
    file.get(at..)
        .and_then(|rest| rest.iter().position(|&b| b == 0))
        .map(|i| at + i)
        .ok_or_else(|| format!("EXR header truncated after byte {at}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One attribute record: name NUL, type NUL, size, value.
    fn record(name: &str, value: &[u8]) -> Vec<u8> {
        let mut r = Vec::new();
        r.extend_from_slice(name.as_bytes());
        r.push(0);
        r.extend_from_slice(b"string\0");
        r.extend_from_slice(&(value.len() as i32).to_le_bytes());
        r.extend_from_slice(value);
        r
    }

    fn file(records: &[Vec<u8>], tail: &[u8]) -> Vec<u8> {
        let mut f = MAGIC.to_le_bytes().to_vec();
        f.extend_from_slice(&2u32.to_le_bytes());
        for r in records {
            f.extend_from_slice(r);
        }
        f.push(0);
        f.extend_from_slice(tail);
        f
    }

    #[test]
    fn any_order_gives_the_same_bytes() {
        let (a, b, c) = (record("zeta", b"1"), record("alpha", b"22"), record("mid", b""));
        let tail = [9u8, 8, 7];
        let mut x = file(&[a.clone(), b.clone(), c.clone()], &tail);
        let mut y = file(&[c.clone(), a.clone(), b.clone()], &tail);
        sort_attributes(&mut x).unwrap();
        sort_attributes(&mut y).unwrap();
        assert_eq!(x, y);
        assert_eq!(x, file(&[b, c, a], &tail), "records in name order, the rest untouched");
    }

    #[test]
    fn malformed_headers_are_errors() {
        let mut truncated = file(&[record("a", b"1234")], &[]);
        truncated.truncate(truncated.len() - 3);
        assert!(sort_attributes(&mut truncated).is_err());
        assert!(sort_attributes(&mut [0u8; 8]).is_err());
        let mut multi = file(&[], &[]);
        multi[4..8].copy_from_slice(&(2 | MULTIPART).to_le_bytes());
        assert!(sort_attributes(&mut multi).is_err());
    }
}
