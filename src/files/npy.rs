//! NumPy `.npy` files (format version 1.0) for get_camera_image's depth and segmentation
//! arrays: `numpy.load` reads them as they are, with no dependency on our side. The header is
//! small enough to write by hand: the magic `\x93NUMPY`, version 1.0, a little-endian u16
//! header length, then a Python dict literal padded with spaces and ended by `\n` so the data
//! starts at a multiple of 64 bytes.

/// One element type the files hold: its NumPy `descr` and its little-endian bytes.
pub trait Element: Copy {
    /// The dtype string (`<f4`, `<i4`).
    const DESCR: &'static str;
    /// The element's little-endian bytes.
    fn le_bytes(self) -> [u8; 4];
}

impl Element for f32 {
    const DESCR: &'static str = "<f4";
    fn le_bytes(self) -> [u8; 4] {
        self.to_le_bytes()
    }
}

impl Element for i32 {
    const DESCR: &'static str = "<i4";
    fn le_bytes(self) -> [u8; 4] {
        self.to_le_bytes()
    }
}

/// A C-order array of shape `(rows, cols)` as `.npy` bytes; `data` must hold rows × cols values.
pub fn encode<T: Element>(rows: usize, cols: usize, data: &[T]) -> Vec<u8> {
    assert_eq!(data.len(), rows * cols, "npy: data does not match its shape");
    let dict = format!("{{'descr': '{}', 'fortran_order': False, 'shape': ({rows}, {cols}), }}", T::DESCR);
    // magic (6) + version (2) + header length (2) + dict + padding + '\n' ≡ 0 (mod 64).
    let unpadded = 10 + dict.len() + 1;
    let padding = (64 - unpadded % 64) % 64;
    let header_len = dict.len() + padding + 1;
    let mut out = Vec::with_capacity(10 + header_len + data.len() * 4);
    out.extend_from_slice(b"\x93NUMPY\x01\x00");
    out.extend_from_slice(&(header_len as u16).to_le_bytes());
    out.extend_from_slice(dict.as_bytes());
    out.extend(std::iter::repeat_n(b' ', padding));
    out.push(b'\n');
    for v in data {
        out.extend_from_slice(&v.le_bytes());
    }
    out
}

/// Reads back a file from [`encode`]: (descr, shape, raw little-endian data). For tests and
/// tools that check what was written; not a general `.npy` reader.
pub fn decode(bytes: &[u8]) -> Option<(String, (usize, usize), &[u8])> {
    if bytes.get(..8)? != b"\x93NUMPY\x01\x00" {
        return None;
    }
    let header_len = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
    let header = std::str::from_utf8(bytes.get(10..10 + header_len)?).ok()?;
    let field = |key: &str| {
        let at = header.find(key)? + key.len();
        Some(&header[at..])
    };
    let descr = field("'descr': '")?.split('\'').next()?.to_string();
    let shape = field("'shape': (")?.split(')').next()?;
    let mut dims = shape.split(',').map(str::trim).filter(|s| !s.is_empty()).map(str::parse::<usize>);
    let (rows, cols) = (dims.next()?.ok()?, dims.next()?.ok()?);
    Some((descr, (rows, cols), &bytes[10 + header_len..]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_is_numpy_1_0_and_data_starts_at_a_multiple_of_64() {
        let bytes = encode(2, 3, &[1.5f32, -2.0, 0.0, f32::MAX, 1e-30, 7.0]);
        assert_eq!(&bytes[..8], b"\x93NUMPY\x01\x00");
        let header_len = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
        assert_eq!((10 + header_len) % 64, 0);
        assert_eq!(bytes[10 + header_len - 1], b'\n');
        let header = std::str::from_utf8(&bytes[10..10 + header_len]).unwrap();
        assert!(header.starts_with("{'descr': '<f4', 'fortran_order': False, 'shape': (2, 3), }"), "{header}");
        let (descr, shape, data) = decode(&bytes).unwrap();
        assert_eq!((descr.as_str(), shape, data.len()), ("<f4", (2, 3), 24));
        assert_eq!(&data[12..16], &f32::MAX.to_le_bytes());
    }

    #[test]
    fn integers_round_trip() {
        let v = [-1i32, 0, 5, i32::MAX];
        let bytes = encode(1, 4, &v);
        let (descr, shape, data) = decode(&bytes).unwrap();
        assert_eq!((descr.as_str(), shape), ("<i4", (1, 4)));
        let back: Vec<i32> = data.chunks(4).map(|c| i32::from_le_bytes(c.try_into().unwrap())).collect();
        assert_eq!(back, v);
    }
}
