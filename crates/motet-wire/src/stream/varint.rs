//! LEB128 varints and zigzag, as postcard writes them, over plain byte slices.

/// Appends `v` as a LEB128 varint; `false` when `out` has no room.
pub fn put_u64<const N: usize>(out: &mut heapless::Vec<u8, N>, mut v: u64) -> bool {
    loop {
        let byte = (v & 0x7f) as u8;
        v >>= 7;
        let more = v != 0;
        if out.push(byte | if more { 0x80 } else { 0 }).is_err() {
            return false;
        }
        if !more {
            return true;
        }
    }
}

pub fn put_i64<const N: usize>(out: &mut heapless::Vec<u8, N>, v: i64) -> bool {
    put_u64(out, ((v << 1) ^ (v >> 63)) as u64)
}

pub fn put_f64<const N: usize>(out: &mut heapless::Vec<u8, N>, v: f64) -> bool {
    out.extend_from_slice(&v.to_le_bytes()).is_ok()
}

/// Reads bytes in order; every read fails (`None`) past the end or on a
/// varint longer than 64 bits.
pub struct Reader<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl<'a> Reader<'a> {
    pub fn new(bytes: &'a [u8]) -> Self {
        Reader { bytes, pos: 0 }
    }

    pub fn at_end(&self) -> bool {
        self.pos >= self.bytes.len()
    }

    pub fn u8(&mut self) -> Option<u8> {
        let b = *self.bytes.get(self.pos)?;
        self.pos += 1;
        Some(b)
    }

    pub fn u64(&mut self) -> Option<u64> {
        let mut v = 0u64;
        for shift in (0..64).step_by(7) {
            let b = self.u8()?;
            let part = (b & 0x7f) as u64;
            // The tenth byte may only carry the top bit.
            if shift == 63 && part > 1 {
                return None;
            }
            v |= part << shift;
            if b & 0x80 == 0 {
                return Some(v);
            }
        }
        None
    }

    pub fn i64(&mut self) -> Option<i64> {
        let z = self.u64()?;
        Some(((z >> 1) as i64) ^ -((z & 1) as i64))
    }

    pub fn f64(&mut self) -> Option<f64> {
        let end = self.pos.checked_add(8)?;
        let b: [u8; 8] = self.bytes.get(self.pos..end)?.try_into().ok()?;
        self.pos = end;
        Some(f64::from_le_bytes(b))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    proptest::proptest! {
        #[test]
        fn varints_round_trip(u in proptest::num::u64::ANY, i in proptest::num::i64::ANY, f in proptest::num::f64::ANY) {
            let mut v: heapless::Vec<u8, 32> = heapless::Vec::new();
            assert!(put_u64(&mut v, u) && put_i64(&mut v, i) && put_f64(&mut v, f));
            let mut r = Reader::new(&v);
            proptest::prop_assert_eq!(r.u64(), Some(u));
            proptest::prop_assert_eq!(r.i64(), Some(i));
            proptest::prop_assert_eq!(r.f64().map(f64::to_bits), Some(f.to_bits()));
            proptest::prop_assert!(r.at_end());
        }
    }

    #[test]
    fn overlong_varint_is_refused() {
        let mut r = Reader::new(&[0xff; 11]);
        assert_eq!(r.u64(), None);
        let mut r = Reader::new(&[0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0x02]);
        assert_eq!(r.u64(), None);
    }
}
