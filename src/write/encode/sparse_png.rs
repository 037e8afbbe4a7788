//! A 16-bit grey PNG of an image that is zero almost everywhere (the
//! instance images of `output.masks`), written in time proportional to its
//! non-zero pixels and rows rather than to its size: the zlib stream is
//! built straight from the sorted non-zero pixels, each run of zero bytes
//! one literal and distance-1 copies of up to 258 bytes, each run of a
//! pixel value repeated along a row (a drone's span in the instance image)
//! its first pixel and distance-2 copies (one fixed-Huffman DEFLATE block,
//! RFC 1951 §3.2.6), the Adler-32 of a zero run in closed form. A library
//! encoder (the `png` crate, any compression level) has to walk all 4 MB of
//! a 1080p frame: about 6–9 ms, against well under 1 ms here. Any PNG
//! reader reads it; the tests decode it with `image`.

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
    // The row of the pixel before (a division only where a pixel starts another row).
    let (mut y, mut row_first) = (0u32, 0u32);
    let mut k = 0;
    while let Some(&(i, v)) = pixels.get(k) {
        if u64::from(i) >= pixel_count {
            break;
        }
        // Past the check above, width ≥ 1.
        if i < row_first || i - row_first >= width {
            y = i / width;
            row_first = y * width;
        }
        let x = i - row_first;
        // Where its two bytes start in the raw (filtered) stream.
        let p = u64::from(y) * row + 1 + 2 * u64::from(x);
        if p < at {
            k += 1;
            continue;
        }
        // The pixels right after it in its row with its value.
        let mut run = 1;
        while let Some(&(j, u)) = pixels.get(k + run) {
            let next = u64::from(i) + run as u64;
            if u != v || u64::from(j) != next || u64::from(x) + run as u64 >= u64::from(width) {
                break;
            }
            run += 1;
        }
        z.zeros(p - at);
        let pair = v.to_be_bytes();
        z.byte(pair[0]);
        z.byte(pair[1]);
        z.pair_repeated(pair, 2 * (run as u64 - 1));
        at = p + 2 * run as u64;
        k += run;
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

/// Each byte's fixed-Huffman literal code, bits reversed for [`Deflate::bits`],
/// and its length: 0x30 + b in 8 bits below 144, 0x190 + b − 144 in 9 above.
const LITERALS: [(u16, u8); 256] = {
    let mut t = [(0u16, 0u8); 256];
    let mut b = 0;
    while b < 256 {
        let (code, len) = if b < 144 {
            (0x30 + b as u32, 8)
        } else {
            (0x190 + b as u32 - 144, 9)
        };
        t[b] = ((code.reverse_bits() >> (32 - len)) as u16, len as u8);
        b += 1;
    }
    t
};

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
    #[inline(always)]
    fn bits(&mut self, value: u32, len: u32) {
        self.bits64(u64::from(value), len);
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
        let (code, len) = LITERALS[usize::from(b)];
        self.bits(u32::from(code), u32::from(len));
    }

    /// A copy of `len` (3..=258) bytes from distance 1.
    fn repeat(&mut self, len: u64) {
        self.copy(len, 1);
    }

    /// A copy of `len` (3..=258) bytes from `distance` (1 or 2: distance
    /// codes 0 and 1, no extra bits).
    fn copy(&mut self, len: u64, distance: u32) {
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
        self.code(distance - 1, 5); // distance codes 0 and 1: distances 1 and 2
    }

    /// `n` more bytes repeating the last two written, `pair` (its first
    /// byte next): distance-2 copies of 3 to 258 bytes (literals below 3).
    fn pair_repeated(&mut self, pair: [u8; 2], n: u64) {
        if n < 3 {
            for k in 0..n {
                self.byte(pair[(k % 2) as usize]);
            }
            return;
        }
        // The two bytes the copies read are written, zeros included.
        self.flush_zeros();
        let mut left = n;
        while left > 0 {
            // 258 at a time, but never leaving one or two bytes: 259 and
            // 260 as 256 or 257 and then 3.
            let len = if left > 258 && left < 261 {
                left - 3
            } else {
                left.min(258)
            };
            self.copy(len, 2);
            left -= len;
        }
        for k in 0..n {
            self.adler(pair[(k % 2) as usize]);
        }
    }

    /// The Adler-32 of the raw bytes with `b` added.
    fn adler(&mut self, b: u8) {
        let wrap = |v: u32| if v >= ADLER_MOD { v - ADLER_MOD } else { v };
        self.adler_a = wrap(self.adler_a + u32::from(b));
        self.adler_b = wrap(self.adler_b + self.adler_a);
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

    /// `len` (at most 56) bits of `value`, least significant first: the
    /// accumulator's eight bytes appended and its whole bytes kept, with no
    /// branch on how many there are (fewer than 8 bits wait in it).
    #[inline(always)]
    fn bits64(&mut self, value: u64, len: u32) {
        self.acc |= value << self.n;
        self.n += len;
        let whole = self.n / 8;
        let kept = self.out.len() + whole as usize;
        self.out.extend_from_slice(&self.acc.to_le_bytes());
        self.out.truncate(kept);
        // At most 7 + 56 bits: whole ≤ 7, so the shift is under 64.
        self.acc >>= 8 * whole;
        self.n -= 8 * whole;
    }

    fn zeros(&mut self, n: u64) {
        self.zeros += n;
    }

    #[inline(always)]
    fn byte(&mut self, b: u8) {
        if b == 0 {
            self.zeros += 1;
            return;
        }
        if self.zeros > 0 {
            self.flush_zeros();
        }
        self.literal(b);
        self.adler(b);
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
    fn runs_of_a_value_along_a_row_decode_whole() {
        // Runs whose repeats are 0, 2, 4 and around a copy's 258 bytes (the
        // 259 and 260 a copy may not leave 1 or 2 of), values with a zero
        // byte either side, runs that reach the row's end with the next row
        // starting on the same value, and runs broken by another value.
        let (w, h) = (700u32, 12u32);
        let mut want = vec![0u16; (w * h) as usize];
        let runs: [(u32, u32, u32, u16); 11] = [
            (0, 0, 1, 7),
            (0, 5, 2, 0x0100),
            (1, 3, 3, 0x00ff),
            (2, 10, 129, 3),
            (3, 0, 130, 0x1234),
            (4, 1, 131, 0x0100),
            (5, 2, 260, 9),
            (6, 600, 100, 5),
            (7, 0, 700, 5),
            (8, 0, 699, 0xff00),
            (9, 40, 261, 2),
        ];
        for (y, x0, n, v) in runs {
            for x in x0..x0 + n {
                want[(y * w + x) as usize] = v;
            }
        }
        // A break inside a run: one pixel of another value.
        want[(9 * w + 100) as usize] = 4;
        let pixels: Vec<(u32, u16)> = (want.iter().enumerate())
            .filter(|p| *p.1 != 0)
            .map(|(i, &v)| (i as u32, v))
            .collect();
        let img = decode(&grey16(w, h, &pixels));
        assert_eq!(img.into_raw(), want);
    }

    #[test]
    fn a_drones_span_costs_its_first_pixel_and_copies() {
        // A 40-pixel span of one id is 2 literals and a copy, not 80 literals.
        let blob = |v: u16| -> Vec<(u32, u16)> {
            (0..30u32)
                .flat_map(|y| (0..40u32).map(move |x| ((100 + y) * 1920 + 500 + x, v)))
                .collect()
        };
        let one = grey16(1920, 1080, &blob(1)).len();
        let empty = grey16(1920, 1080, &[]).len();
        assert!(one - empty < 30 * 8, "{one} bytes against {empty} empty");
        assert_eq!(
            decode(&grey16(1920, 1080, &blob(300))).as_raw()[100 * 1920 + 539],
            300
        );
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
