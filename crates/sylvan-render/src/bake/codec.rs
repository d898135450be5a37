//! A small little-endian binary codec for baked assets: explicit, bounds-checked, no reflection.
//! Every length read from a file is checked against the bytes left before anything is
//! allocated, so a corrupt or truncated file gives an error, never a huge allocation.

/// Why a baked payload could not be decoded.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct DecodeError(pub String);

/// Appends values to a byte buffer.
#[derive(Debug, Default)]
pub struct Encoder {
    /// The bytes written so far.
    pub buf: Vec<u8>,
}

impl Encoder {
    /// A `u32`.
    pub fn u32(&mut self, v: u32) {
        self.buf.extend_from_slice(&v.to_le_bytes());
    }
    /// A `u64`.
    pub fn u64(&mut self, v: u64) {
        self.buf.extend_from_slice(&v.to_le_bytes());
    }
    /// An `f32`.
    pub fn f32(&mut self, v: f32) {
        self.buf.extend_from_slice(&v.to_le_bytes());
    }
    /// A length-prefixed byte string.
    pub fn bytes(&mut self, v: &[u8]) {
        self.u64(v.len() as u64);
        self.buf.extend_from_slice(v);
    }
    /// A length-prefixed UTF-8 string.
    pub fn str(&mut self, v: &str) {
        self.bytes(v.as_bytes());
    }
    /// A length-prefixed `u32` array.
    pub fn u32s(&mut self, v: &[u32]) {
        self.u64(v.len() as u64);
        for &x in v {
            self.u32(x);
        }
    }
    /// A length-prefixed `f32` array.
    pub fn f32s(&mut self, v: &[f32]) {
        self.u64(v.len() as u64);
        for &x in v {
            self.f32(x);
        }
    }
}

/// Reads values back in the order an [`Encoder`] wrote them.
#[derive(Debug)]
pub struct Decoder<'a> {
    data: &'a [u8],
    pos: usize,
}

impl<'a> Decoder<'a> {
    /// Starts at the beginning of `data`.
    pub fn new(data: &'a [u8]) -> Self {
        Self { data, pos: 0 }
    }

    /// Bytes not read yet.
    pub fn remaining(&self) -> usize {
        self.data.len() - self.pos
    }

    fn take(&mut self, n: usize) -> Result<&'a [u8], DecodeError> {
        if n > self.remaining() {
            return Err(DecodeError(format!(
                "truncated: needed {n} bytes at offset {}, {} left",
                self.pos,
                self.remaining()
            )));
        }
        let s = &self.data[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }

    /// A `u32`.
    pub fn u32(&mut self) -> Result<u32, DecodeError> {
        Ok(u32::from_le_bytes(
            self.take(4)?.try_into().expect("4 bytes"),
        ))
    }
    /// A `u64`.
    pub fn u64(&mut self) -> Result<u64, DecodeError> {
        Ok(u64::from_le_bytes(
            self.take(8)?.try_into().expect("8 bytes"),
        ))
    }
    /// An `f32`.
    pub fn f32(&mut self) -> Result<f32, DecodeError> {
        Ok(f32::from_le_bytes(
            self.take(4)?.try_into().expect("4 bytes"),
        ))
    }
    fn len(&mut self, elem: usize) -> Result<usize, DecodeError> {
        let n = self.u64()?;
        if n.saturating_mul(elem as u64) > self.remaining() as u64 {
            return Err(DecodeError(format!(
                "truncated: an array of {n} × {elem} bytes at offset {} exceeds the {} bytes left",
                self.pos,
                self.remaining()
            )));
        }
        Ok(n as usize)
    }
    /// A length-prefixed byte string.
    pub fn bytes(&mut self) -> Result<&'a [u8], DecodeError> {
        let n = self.len(1)?;
        self.take(n)
    }
    /// A length-prefixed UTF-8 string.
    pub fn str(&mut self) -> Result<String, DecodeError> {
        let b = self.bytes()?;
        String::from_utf8(b.to_vec()).map_err(|_| DecodeError("string is not UTF-8".into()))
    }
    /// A length-prefixed `u32` array.
    pub fn u32s(&mut self) -> Result<Vec<u32>, DecodeError> {
        let n = self.len(4)?;
        (0..n).map(|_| self.u32()).collect()
    }
    /// A length-prefixed `f32` array.
    pub fn f32s(&mut self) -> Result<Vec<f32>, DecodeError> {
        let n = self.len(4)?;
        (0..n).map(|_| self.f32()).collect()
    }
    /// Fails unless every byte was read.
    pub fn finish(self) -> Result<(), DecodeError> {
        if self.remaining() != 0 {
            return Err(DecodeError(format!(
                "{} unexpected bytes after the payload",
                self.remaining()
            )));
        }
        Ok(())
    }
}

/// A baked asset's payload: written by [`Codec::encode`], read back by [`Codec::decode`] with
/// every length, count and range checked (a payload that decodes is safe to draw).
pub trait Codec: Sized {
    /// Serialises the asset.
    fn encode(&self) -> Vec<u8>;
    /// Reads an asset back.
    fn decode(bytes: &[u8]) -> Result<Self, DecodeError>;
}

/// FNV-1a, 64 bit: a stable content hash (same value on every platform and Rust version),
/// used for cache keys and payload checksums. Not cryptographic.
#[derive(Debug, Clone, Copy)]
pub struct Fnv64(u64);

impl Default for Fnv64 {
    fn default() -> Self {
        Self(0xcbf2_9ce4_8422_2325)
    }
}

impl Fnv64 {
    /// Mixes in bytes.
    pub fn write(&mut self, bytes: &[u8]) -> &mut Self {
        for &b in bytes {
            self.0 ^= b as u64;
            self.0 = self.0.wrapping_mul(0x0100_0000_01b3);
        }
        self
    }
    /// Mixes in a length-tagged byte string (so `ab`,`c` and `a`,`bc` differ).
    pub fn field(&mut self, bytes: &[u8]) -> &mut Self {
        self.write(&(bytes.len() as u64).to_le_bytes()).write(bytes)
    }
    /// Mixes in `f32` values bit for bit.
    pub fn f32s(&mut self, v: &[f32]) -> &mut Self {
        self.write(&(v.len() as u64).to_le_bytes());
        for x in v {
            self.write(&x.to_bits().to_le_bytes());
        }
        self
    }
    /// Mixes in `u32` values.
    pub fn u32s(&mut self, v: &[u32]) -> &mut Self {
        self.write(&(v.len() as u64).to_le_bytes());
        for x in v {
            self.write(&x.to_le_bytes());
        }
        self
    }
    /// The hash.
    pub fn finish(&self) -> u64 {
        self.0
    }
}

/// The FNV-1a hash of `bytes`.
pub fn fnv64(bytes: &[u8]) -> u64 {
    Fnv64::default().write(bytes).finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip() {
        let mut e = Encoder::default();
        e.u32(7);
        e.str("pine");
        e.f32s(&[1.5, -2.0]);
        e.u32s(&[3, 4, 5]);
        e.bytes(&[9, 8]);
        let mut d = Decoder::new(&e.buf);
        assert_eq!(d.u32().unwrap(), 7);
        assert_eq!(d.str().unwrap(), "pine");
        assert_eq!(d.f32s().unwrap(), vec![1.5, -2.0]);
        assert_eq!(d.u32s().unwrap(), vec![3, 4, 5]);
        assert_eq!(d.bytes().unwrap(), &[9, 8]);
        d.finish().unwrap();
    }

    #[test]
    fn truncation_and_huge_lengths_are_errors() {
        let mut e = Encoder::default();
        e.u32s(&[1, 2, 3]);
        for cut in 0..e.buf.len() {
            assert!(Decoder::new(&e.buf[..cut]).u32s().is_err(), "cut at {cut}");
        }
        // A length claiming 2^60 elements must not allocate.
        let mut e = Encoder::default();
        e.u64(1 << 60);
        assert!(Decoder::new(&e.buf).u32s().is_err());
    }

    #[test]
    fn fnv_known_value() {
        // FNV-1a 64 of "a" (published test vector).
        assert_eq!(fnv64(b"a"), 0xaf63_dc4c_8601_ec8c);
        assert_ne!(
            Fnv64::default().field(b"ab").field(b"c").finish(),
            Fnv64::default().field(b"a").field(b"bc").finish()
        );
    }
}
