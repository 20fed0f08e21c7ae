//! The library's archive format, written by the build script and read by the server: every
//! file deflated on its own (a load inflates only the files it reads), under its library name.
//!
//! ```text
//! "PMCPLIB1"                                  magic
//! u32 count                                   little-endian, as every integer here
//! count × { u16 name_len, name (UTF-8),       the file's library name ("kuka_iiwa/model.urdf")
//!           u32 raw_len, u32 packed_len,      its size, and its deflated size
//!           packed bytes }                    raw deflate (RFC 1951)
//! ```
//! Entries are in name order, so one set of files always makes the same archive.

use std::collections::BTreeMap;

const MAGIC: &[u8; 8] = b"PMCPLIB1";

/// One file of the archive, still deflated.
#[derive(Clone, Copy, Debug)]
pub struct Packed<'a> {
    /// Its size once inflated (bytes).
    pub raw_len: usize,
    /// The deflated bytes.
    pub packed: &'a [u8],
}

impl Packed<'_> {
    /// The file's bytes (None if the archive is damaged: it inflates to another size).
    pub fn inflate(&self) -> Option<Vec<u8>> {
        let bytes = miniz_oxide::inflate::decompress_to_vec_with_limit(self.packed, self.raw_len).ok()?;
        (bytes.len() == self.raw_len).then_some(bytes)
    }
}

/// Every file of an archive by name, or why the bytes are not one.
pub fn entries(archive: &[u8]) -> Result<BTreeMap<&str, Packed<'_>>, String> {
    let mut at = archive.strip_prefix(MAGIC.as_slice()).ok_or("not a model archive (no PMCPLIB1 magic)")?;
    let mut take = |n: usize| -> Result<&[u8], String> {
        if at.len() < n {
            return Err("the model archive is truncated".to_string());
        }
        let (head, rest) = at.split_at(n);
        at = rest;
        Ok(head)
    };
    let u32_at = |b: &[u8]| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize;
    let count = u32_at(take(4)?);
    let mut out = BTreeMap::new();
    for _ in 0..count {
        let name_len = u16::from_le_bytes(take(2)?.try_into().map_err(|_| "bad name length")?) as usize;
        let name = std::str::from_utf8(take(name_len)?).map_err(|_| "a file name in the model archive is not UTF-8")?;
        let raw_len = u32_at(take(4)?);
        let packed_len = u32_at(take(4)?);
        out.insert(name, Packed { raw_len, packed: take(packed_len)? });
    }
    Ok(out)
}

/// The archive of `files` (library name → bytes), deflated at `level` (0-10).
pub fn write(files: &BTreeMap<String, Vec<u8>>, level: u8) -> Result<Vec<u8>, String> {
    let mut out = MAGIC.to_vec();
    let count = u32::try_from(files.len()).map_err(|_| "too many files")?;
    out.extend_from_slice(&count.to_le_bytes());
    for (name, bytes) in files {
        let packed = miniz_oxide::deflate::compress_to_vec(bytes, level);
        let name_len = u16::try_from(name.len()).map_err(|_| format!("file name too long: {name}"))?;
        let raw_len = u32::try_from(bytes.len()).map_err(|_| format!("{name} is over 4 GiB"))?;
        let packed_len = u32::try_from(packed.len()).map_err(|_| format!("{name} is over 4 GiB packed"))?;
        out.extend_from_slice(&name_len.to_le_bytes());
        out.extend_from_slice(name.as_bytes());
        out.extend_from_slice(&raw_len.to_le_bytes());
        out.extend_from_slice(&packed_len.to_le_bytes());
        out.extend_from_slice(&packed);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_archive_gives_back_every_file_and_refuses_damage() {
        let files = BTreeMap::from([("a/b.urdf".to_string(), b"<robot/>".repeat(100)), ("c.stl".to_string(), vec![0u8, 1, 2, 255])]);
        let archive = write(&files, 10).unwrap();
        let read = entries(&archive).unwrap();
        assert_eq!(read.len(), 2);
        for (name, bytes) in &files {
            assert_eq!(read[name.as_str()].inflate().as_ref(), Some(bytes), "{name}");
        }
        assert!(entries(&archive[..archive.len() - 1]).is_err(), "truncated");
        assert!(entries(b"PMCPLIB0").is_err(), "wrong magic");
    }
}
