//! A 16-bit grey PNG of an image that is zero almost everywhere (the
//! instance images of `output.masks`), written in time proportional to its
//! non-zero pixels and rows rather than to its size: the zlib stream is
//! built straight from the sorted non-zero pixels, each run of zero bytes
//! one literal and distance-1 copies of up to 258 bytes (one fixed-Huffman
//! DEFLATE block, RFC 1951 §3.2.6), the Adler-32 of a zero run in closed
//! form. A library encoder (the `png` crate, any compression level) has to
//! walk all 4 MB of a 1080p frame: about 6–9 ms, against well under 1 ms
//! here. Any PNG reader reads it; the tests decode it with `image`.

/// PNG bytes of a `width`×`height` 16-bit grey image that is 0 except at
/// `pixels`: (row-major index `y · width + x`, value), ascending, no
/// repeats; indices past the image are ignored.
pub fn grey16(width: u32, height: u32, pixels: &[(u32, u16)]) -> Vec<u8> {
    let row = 1 + 2 * u64::from(width); // filter byte + samples
    let total = row * u64::from(height);
    let mut z = Deflate::default();
    z.out.extend([0x78, 0x01]); // zlib: deflate, 32 KiB window, no dictionary
    z.bits(1, 1); // BFINAL
    z.bits(1, 2); // BTYPE 01: fixed Huffman codes
    let mut at = 0u64; // raw bytes covered so far (all filter bytes are 0: no filter)
    let pixel_count = u64::from(width) * u64::from(height);
    for &(i, v) in pixels {
        if u64::from(i) >= pixel_count {
            break;
        }
        let (y, x) = (u64::from(i / width.max(1)), u64::from(i % width.max(1)));
        let p = y * row + 1 + 2 * x;
        if p < at {
            continue;
        }
        z.zeros(p - at);
        for b in v.to_be_bytes() {
            z.byte(b);
        }
        at = p + 2;
    }
    z.zeros(total - at);
    z.flush_zeros();
    z.code(0, 7); // end of block (256)
    let adler = (z.adler_b << 16) | z.adler_a;
    z.align();
    z.out.extend(adler.to_be_bytes());

    let mut png = Vec::with_capacity(z.out.len() + 64);
    png.extend([0x89, b'P', b'N', b'G', 0x0D, 0x0A, 0x1A, 0x0A]);
    let mut ihdr = Vec::with_capacity(13);
    ihdr.extend(width.to_be_bytes());
    ihdr.extend(height.to_be_bytes());
    ihdr.extend([16, 0, 0, 0, 0]); // 16-bit, grey, deflate, adaptive filtering method, no interlace
    chunk(&mut png, b"IHDR", &ihdr);
    chunk(&mut png, b"IDAT", &z.out);
    chunk(&mut png, b"IEND", &[]);
    png
}

fn chunk(png: &mut Vec<u8>, kind: &[u8; 4], data: &[u8]) {
    png.extend((data.len() as u32).to_be_bytes());
    png.extend(kind);
    png.extend(data);
    let mut crc = crc32fast::Hasher::new();
    crc.update(kind);
    crc.update(data);
    png.extend(crc.finalize().to_be_bytes());
}

const ADLER_MOD: u32 = 65_521;

/// A fixed-Huffman DEFLATE stream being written, with the Adler-32 of the raw bytes.
struct Deflate {
    out: Vec<u8>,
    acc: u64,
    n: u32,
    /// Zero bytes not yet written.
    zeros: u64,
    adler_a: u32,
    adler_b: u32,
}

impl Default for Deflate {
    fn default() -> Self {
        Self {
            out: Vec::new(),
            acc: 0,
            n: 0,
            zeros: 0,
            adler_a: 1,
            adler_b: 0,
        }
    }
}

impl Deflate {
    /// `len` bits of `value`, least significant first (header fields, extra bits).
    fn bits(&mut self, value: u32, len: u32) {
        self.acc |= u64::from(value) << self.n;
        self.n += len;
        while self.n >= 8 {
            self.out.push(self.acc as u8);
            self.acc >>= 8;
            self.n -= 8;
        }
    }

    /// A Huffman code of `len` bits, most significant bit first.
    fn code(&mut self, code: u32, len: u32) {
        let reversed = code.reverse_bits() >> (32 - len);
        self.bits(reversed, len);
    }

    fn align(&mut self) {
        if self.n > 0 {
            self.bits(0, 8 - self.n);
        }
    }

    fn literal(&mut self, b: u8) {
        match b {
            0..=143 => self.code(0x30 + u32::from(b), 8),
            _ => self.code(0x190 + u32::from(b) - 144, 9),
        }
    }

    /// A copy of `len` (3..=258) bytes from distance 1.
    fn repeat(&mut self, len: u64) {
        const BASE: [u64; 29] = [
            3, 4, 5, 6, 7, 8, 9, 10, 11, 13, 15, 17, 19, 23, 27, 31, 35, 43, 51, 59, 67, 83, 99,
            115, 131, 163, 195, 227, 258,
        ];
        const EXTRA: [u32; 29] = [
            0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2, 2, 3, 3, 3, 3, 4, 4, 4, 4, 5, 5, 5, 5, 0,
        ];
        let k = BASE.iter().rposition(|&b| b <= len).unwrap_or(0);
        let symbol = 257 + k as u32;
        match symbol {
            256..=279 => self.code(symbol - 256, 7),
            _ => self.code(0xC0 + symbol - 280, 8),
        }
        self.bits((len - BASE[k]) as u32, EXTRA[k]);
        self.code(0, 5); // distance code 0: distance 1
    }

    /// `count` copies of 258 bytes from distance 1, as `count` calls of
    /// `repeat(258)` write them: each is the same 13 bits (length symbol
    /// 285, code 0xC5 in 8 bits, no extra bits; distance code 0 in 5 bits),
    /// so eight are 13 whole bytes that leave the bit position where it was,
    /// and from the second group of eight on every group is the same 13
    /// bytes. A 1080p frame's zero runs are about 16 000 such copies.
    fn repeats_258(&mut self, mut count: u64) {
        const ONE: u64 = 0xA3; // 0xC5's 8 bits reversed, then 5 zero bits
        const FOUR: u64 = ONE | ONE << 13 | ONE << 26 | ONE << 39;
        if count >= 16 {
            for _ in 0..2 {
                self.bits64(FOUR, 52);
                self.bits64(FOUR, 52);
            }
            let group: [u8; 13] = self.out[self.out.len() - 13..]
                .try_into()
                .unwrap_or_default();
            count -= 16;
            for _ in 0..count / 8 {
                self.out.extend_from_slice(&group);
            }
            count %= 8;
        }
        for _ in 0..count / 4 {
            self.bits64(FOUR, 52);
        }
        for _ in 0..count % 4 {
            self.bits64(ONE, 13);
        }
    }

    /// `len` (at most 56) bits of `value`, least significant first.
    fn bits64(&mut self, value: u64, len: u32) {
        self.acc |= value << self.n;
        self.n += len;
        while self.n >= 8 {
            self.out.push(self.acc as u8);
            self.acc >>= 8;
            self.n -= 8;
        }
    }

    fn zeros(&mut self, n: u64) {
        self.zeros += n;
    }

    fn byte(&mut self, b: u8) {
        if b == 0 {
            self.zeros += 1;
            return;
        }
        self.flush_zeros();
        self.literal(b);
        self.adler_a = (self.adler_a + u32::from(b)) % ADLER_MOD;
        self.adler_b = (self.adler_b + self.adler_a) % ADLER_MOD;
    }

    fn flush_zeros(&mut self) {
        let mut n = std::mem::take(&mut self.zeros);
        if n == 0 {
            return;
        }
        // Adler-32 over n zeros: a stays, b grows by n·a.
        let grow = (n % u64::from(ADLER_MOD)) * u64::from(self.adler_a);
        self.adler_b = ((u64::from(self.adler_b) + grow) % u64::from(ADLER_MOD)) as u32;
        self.literal(0);
        n -= 1;
        self.repeats_258(n / 258);
        n %= 258;
        if n >= 3 {
            self.repeat(n);
        } else {
            for _ in 0..n {
                self.literal(0);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    fn decode(png: &[u8]) -> image::ImageBuffer<image::Luma<u16>, Vec<u16>> {
        match image::load_from_memory_with_format(png, image::ImageFormat::Png) {
            Ok(image::DynamicImage::ImageLuma16(g)) => g,
            Ok(other) => panic!("decoded as {:?}", other.color()),
            Err(e) => panic!("not a valid PNG: {e}"),
        }
    }

    #[test]
    fn any_reader_gets_the_pixels_back() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        for (w, h, n) in [
            (1u32, 1u32, 0usize),
            (1, 1, 1),
            (7, 3, 5),
            (300, 40, 900),
            (640, 360, 5000),
        ] {
            let mut pixels: Vec<(u32, u16)> = (0..n)
                .map(|_| {
                    let v = match rng.random_range(0..4) {
                        0 => rng.random_range(1..256),
                        1 => rng.random_range(256..=u16::MAX),
                        _ => rng.random_range(1..20),
                    };
                    (rng.random_range(0..w * h), v)
                })
                .collect();
            pixels.sort_unstable_by_key(|p| p.0);
            pixels.dedup_by_key(|p| p.0);
            let img = decode(&grey16(w, h, &pixels));
            assert_eq!(img.dimensions(), (w, h));
            let mut want = vec![0u16; (w * h) as usize];
            for &(i, v) in &pixels {
                want[i as usize] = v;
            }
            assert_eq!(img.into_raw(), want, "{w}×{h}, {n} pixels");
        }
    }

    #[test]
    fn zero_runs_have_the_bytes_of_one_copy_at_a_time() {
        // Each run as the encoder wrote it before (a `repeat(258)` per copy), from every bit offset.
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let (mut fast, mut slow) = (Deflate::default(), Deflate::default());
        for k in 0..400 {
            let run = match k % 4 {
                0 => rng.random_range(1..600),
                1 => rng.random_range(258 * 15..258 * 40),
                2 => rng.random_range(1..5_000_000),
                _ => 258 * rng.random_range(1..40) + 1,
            };
            let b = rng.random_range(1..=255); // a literal: another bit offset
            fast.byte(b);
            slow.byte(b);
            fast.zeros(run);
            fast.flush_zeros();
            slow.literal(0);
            let mut n = run - 1;
            while n >= 258 {
                slow.repeat(258);
                n -= 258;
            }
            slow.zeros = n;
            slow.flush_rest();
            assert_eq!(
                (&fast.out, fast.acc, fast.n),
                (&slow.out, slow.acc, slow.n),
                "run {run}"
            );
        }
    }

    impl Deflate {
        /// The end of a zero run under 258 bytes, as `flush_zeros` writes it.
        fn flush_rest(&mut self) {
            let n = std::mem::take(&mut self.zeros);
            if n >= 3 {
                self.repeat(n);
            } else {
                for _ in 0..n {
                    self.literal(0);
                }
            }
        }
    }

    #[test]
    fn long_zero_runs_and_a_full_frame_decode() {
        // Runs of every length around the copy limits, and a 1080p frame with two pixels.
        for gap in [1u32, 2, 3, 4, 257, 258, 259, 260, 516, 517] {
            let pixels = [(0, 9), (gap, 0x0102), (2 * gap + 1, 0x0100)];
            let img = decode(&grey16(2000, 2, &pixels));
            for &(i, v) in &pixels {
                assert_eq!(img.as_raw()[i as usize], v, "gap {gap}");
            }
            assert_eq!(img.as_raw().iter().filter(|&&v| v != 0).count(), 3);
        }
        let png = grey16(1920, 1080, &[(5, 1), (1920 * 1080 - 1, 2)]);
        assert!(png.len() < 40_000, "{} bytes", png.len());
        let img = decode(&png);
        assert_eq!((img.as_raw()[5], img.as_raw()[1920 * 1080 - 1]), (1, 2));
    }
}
