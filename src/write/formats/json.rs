//! Compact JSON written straight into a byte buffer, the bytes serde_json
//! writes for the same values: numbers through serde_json's own
//! [`CompactFormatter`] (the same float and integer printers), non-finite
//! floats as `null` (as serde_json's serializer), strings unescaped when
//! they need no escape and through serde_json otherwise. The manifest and
//! COCO records of every frame are written with it (no `Value`, no
//! intermediate `String`); their tests compare it with serde's output.
//!
//! Kept instead of serializing the records with serde_json because it is
//! measurably faster where it counts: a labels-only plan of
//! `presets/bench/plan15.ron` (50 000 frames, 15 drones each, to tmpfs, on a
//! loaded 2-core machine) took 0.82× the user CPU and 0.80× the wall time
//! (medians of 5 pairs) of the same binary writing the manifest and COCO
//! records through the serde reference structs of `manifest.rs` and
//! `coco.rs` (`reference`), whose bytes were identical. Measured with a
//! build whose `SERDE_RECORDS` variable made `write_manifest_line` and
//! `write_frame_records_with` append the `reference` records instead:
//! `scripts/bench_pair.py -n 5 --warmup 1 --vs "env SERDE_RECORDS=1 swarmshot
//! batch presets/bench/plan15.ron --labels-only --out /dev/shm/b --limit 50000
//! --overwrite" -- swarmshot batch presets/bench/plan15.ron --labels-only
//! --out /dev/shm/a --limit 50000 --overwrite`.

use serde_json::ser::{CompactFormatter, Formatter};

/// A JSON writer appending to `out`. Writing into a `Vec` cannot fail.
pub(crate) struct Json<'a> {
    pub out: &'a mut Vec<u8>,
}

impl Json<'_> {
    /// Raw bytes (punctuation, pre-written JSON).
    pub fn raw(&mut self, bytes: &[u8]) {
        self.out.extend_from_slice(bytes);
    }

    pub fn f64(&mut self, v: f64) {
        if v.is_finite() {
            let _ = CompactFormatter.write_f64(self.out, v);
        } else {
            self.out.extend_from_slice(b"null");
        }
    }

    /// `x` rounded to `k` decimals (`(x · 10^k).round() / 10^k`, the
    /// manifest's r6, r9 and r12) as [`Json::f64`] writes that value. Where
    /// the rounded value is at least 1e-5 (serde_json's fixed notation) and
    /// small enough that no two k-decimal numbers share a float, its
    /// shortest form is the decimal n / 10^k itself: written from the
    /// integer n without a float printer. Anything else takes [`Json::f64`].
    pub fn rounded(&mut self, x: f64, k: Decimals) {
        let y = x * k.scale();
        // ≥ 1e-5 · 10^k, and below 2^51: the float's spacing is under half of 10^-k.
        let Some(n) = round_below_2_51(y).filter(|n| n.unsigned_abs() >= k.fixed_from()) else {
            self.f64(y.round() / k.scale());
            return;
        };
        let u = n.unsigned_abs();
        // Digits written in place as whole words over a zeroed tail (the
        // numbers are ≤ 19 bytes long: sign, ten digits, point, six; or
        // four digits, point, twelve), then cut back: no copy through a
        // stack buffer, whose small stores a wide load would wait for.
        let len = self.out.len();
        self.out.resize(len + 32, 0);
        let buf = &mut self.out[len..];
        let mut at = usize::from(n < 0);
        buf[0] = b'-';
        // Constant divisors: multiplications, not divisions.
        let (int, frac) = match k {
            Decimals::Six => (u / 1_000_000, u % 1_000_000),
            Decimals::Nine => (u / 1_000_000_000, u % 1_000_000_000),
            Decimals::Twelve => (u / 1_000_000_000_000, u % 1_000_000_000_000),
        };
        at += integer_digits(&mut buf[at..], int);
        buf[at] = b'.';
        at += 1;
        if frac == 0 {
            buf[at] = b'0';
            at += 1;
        } else {
            // Six digits at a time (10^6 < 2^32); the last run's trailing
            // zeros cut off.
            let (hi, lo) = ((frac / 1_000_000) as u32, (frac % 1_000_000) as u32);
            let (head, head_len) = match k {
                Decimals::Six => (0, 0),
                Decimals::Nine => (three_digit_word(hi), 3),
                Decimals::Twelve => (six_digit_word(hi), 6),
            };
            if lo == 0 {
                at += put_trimmed(&mut buf[at..], head, head_len);
            } else {
                buf[at..at + 8].copy_from_slice(&head.to_le_bytes());
                at += head_len;
                at += put_trimmed(&mut buf[at..], six_digit_word(lo), 6);
            }
        }
        self.out.truncate(len + at);
    }

    /// `[a,b,…]` of floats, each [`Json::rounded`].
    pub fn rounded_all(&mut self, xs: &[f64], k: Decimals) {
        self.out.push(b'[');
        for (i, &x) in xs.iter().enumerate() {
            if i > 0 {
                self.out.push(b',');
            }
            self.rounded(x, k);
        }
        self.out.push(b']');
    }

    pub fn u64(&mut self, v: u64) {
        let _ = CompactFormatter.write_u64(self.out, v);
    }

    pub fn bool(&mut self, v: bool) {
        self.raw(if v { b"true" } else { b"false" });
    }

    pub fn str(&mut self, s: &str) {
        write_str(self.out, s);
    }
}

/// `y.round()` (half away from zero) as an integer when |y| rounds below
/// 2^51, without the C library's `round` call: a conversion that drops the
/// fraction, the fraction itself (exact: `y` and its integer part share an
/// exponent or `y` is an integer), and a step away from zero at a half or
/// more. `None` at or past 2^51 and for NaN.
fn round_below_2_51(y: f64) -> Option<i64> {
    const LIMIT: i64 = 1 << 51;
    let below = y.abs() < LIMIT as f64;
    if !below {
        return None;
    }
    let t = y as i64;
    let f = y - t as f64;
    let n = t + i64::from(f >= 0.5) - i64::from(f <= -0.5);
    (n.abs() < LIMIT).then_some(n)
}

/// The decimals the records round to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Decimals {
    Six = 6,
    Nine = 9,
    Twelve = 12,
}

impl Decimals {
    /// 10^k, what the rounding multiplies by.
    fn scale(self) -> f64 {
        match self {
            Self::Six => 1e6,
            Self::Nine => 1e9,
            Self::Twelve => 1e12,
        }
    }

    /// The least integer n with `n as f64 ≥ 1e-5 · 10^k` (serde_json writes
    /// n / 10^k in fixed notation from there on).
    fn fixed_from(self) -> u64 {
        const fn least_at_or_above(c: f64) -> u64 {
            let t = c as u64;
            if (t as f64) < c { t + 1 } else { t }
        }
        const SIX: u64 = least_at_or_above(1e6 * 1e-5);
        const NINE: u64 = least_at_or_above(1e9 * 1e-5);
        const TWELVE: u64 = least_at_or_above(1e12 * 1e-5);
        match self {
            Self::Six => SIX,
            Self::Nine => NINE,
            Self::Twelve => TWELVE,
        }
    }
}

/// "00" … "99", each as the little-endian word of its two ASCII digits.
const PAIRS: [u16; 100] = {
    let mut t = [0u16; 100];
    let mut i = 0;
    while i < 100 {
        t[i] = (b'0' + (i / 10) as u8) as u16 | ((b'0' + (i % 10) as u8) as u16) << 8;
        i += 1;
    }
    t
};

/// `v` < 100 as two ASCII digits, first digit in the low byte.
fn pair(v: u32) -> u64 {
    u64::from(PAIRS[v as usize % 100])
}

/// `v` < 1000 as three ASCII digits in the low bytes of a word, first digit lowest.
fn three_digit_word(v: u32) -> u64 {
    u64::from(b'0' + (v / 100 % 10) as u8) | pair(v % 100) << 8
}

/// `v` < 10^6 as six ASCII digits in the low bytes of a word, first digit lowest.
fn six_digit_word(v: u32) -> u64 {
    pair(v / 10_000) | pair(v / 100 % 100) << 16 | pair(v % 100) << 32
}

/// The first `digits` (≤ 8) bytes of `word` less its trailing '0's (at
/// least one digit is not '0'), written as a whole word at the start of
/// `buf` (at least 8 long); returns how many count.
fn put_trimmed(buf: &mut [u8], word: u64, digits: usize) -> usize {
    let ascii_zeros = 0x3030_3030_3030_3030u64 >> (64 - 8 * digits);
    // The digits' values, the last one in the top byte: a zero byte for each '0'.
    let values = (word ^ ascii_zeros) << (64 - 8 * digits);
    buf[..8].copy_from_slice(&word.to_le_bytes());
    digits - (values.leading_zeros() / 8) as usize
}

/// `v` < 10^6 as exactly six digits.
fn six_digits(buf: &mut [u8], v: u32) {
    buf[..6].copy_from_slice(&six_digit_word(v).to_le_bytes()[..6]);
}

/// `v` in decimal at the start of `buf` (at least 8 longer than `v`'s
/// digits); returns its length. Below 10^4 (nearly every number of the
/// records) one word of four digits, shifted past its leading zeros.
fn integer_digits(buf: &mut [u8], v: u64) -> usize {
    if v < 10_000 {
        let len = 1 + usize::from(v >= 10) + usize::from(v >= 100) + usize::from(v >= 1000);
        let v = v as u32;
        let word = pair(v / 100) | pair(v % 100) << 16;
        buf[..8].copy_from_slice(&(word >> (8 * (4 - len))).to_le_bytes());
        return len;
    }
    let mut len = 1;
    let mut rest = v;
    while rest >= 10 {
        rest /= 10;
        len += 1;
    }
    let (mut at, mut v) = (len, v);
    while v >= 100 {
        at -= 2;
        buf[at..at + 2].copy_from_slice(&PAIRS[(v % 100) as usize].to_le_bytes());
        v /= 100;
    }
    if v >= 10 {
        buf[..2].copy_from_slice(&PAIRS[v as usize].to_le_bytes());
    } else {
        buf[0] = b'0' + v as u8;
    }
    len
}

/// Whether serde_json escapes any byte of `s` (`"`, `\` and controls below 0x20).
fn needs_escape(s: &str) -> bool {
    s.bytes().any(|b| b < 0x20 || b == b'"' || b == b'\\')
}

/// `s` as a JSON string.
pub(crate) fn write_str(out: &mut Vec<u8>, s: &str) {
    if needs_escape(s) {
        let _ = serde_json::to_writer(&mut *out, s);
    } else {
        out.push(b'"');
        out.extend_from_slice(s.as_bytes());
        out.push(b'"');
    }
}

/// `n` in decimal, as `{n}` formats it, appended to `out`.
pub(crate) fn decimal(out: &mut Vec<u8>, n: u64) {
    let _ = CompactFormatter.write_u64(out, n);
}

/// `v` as `format!("{v:.6}")` writes it, appended to `out`: exact decimal
/// arithmetic on the float's binary value, rounded half to even as the
/// standard library rounds; values it does not cover (non-finite, |v| ≥ 1e9,
/// or too small to matter) go through `format!` itself.
pub(crate) fn fixed6(out: &mut Vec<u8>, v: f64) {
    const SCALE: u128 = 1_000_000;
    if !v.is_finite() || v.abs() >= 1e9 {
        use std::io::Write as _;
        let _ = write!(out, "{v:.6}");
        return;
    }
    let bits = v.to_bits();
    let negative = bits >> 63 == 1;
    let biased = ((bits >> 52) & 0x7ff) as i32;
    let fraction = bits & ((1 << 52) - 1);
    // |v| = m · 2^e exactly.
    let (m, e) = if biased == 0 {
        (fraction, -1074)
    } else {
        (fraction | (1 << 52), biased - 1075)
    };
    let n = u128::from(m) * SCALE;
    let q = if e >= 0 {
        // |v| < 1e9 < 2^30, so m · 2^e · 1e6 < 2^50.
        n << e
    } else {
        let s = (-e) as u32;
        if s >= 127 {
            // n < 2^73: the product is far below half a millionth.
            0
        } else {
            let q = n >> s;
            let rem = n & ((1u128 << s) - 1);
            let half = 1u128 << (s - 1);
            if rem > half || (rem == half && q & 1 == 1) {
                q + 1
            } else {
                q
            }
        }
    };
    if negative {
        out.push(b'-');
    }
    // |v| < 1e9: q < 1e15 + 1, so 64 bits hold it (no 128-bit division).
    let q = q as u64;
    decimal(out, q / SCALE as u64);
    out.push(b'.');
    let mut digits = [b'0'; 6];
    six_digits(&mut digits, (q % SCALE as u64) as u32);
    out.extend_from_slice(&digits);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::annotate::visibility::Visibility;
    use crate::annotate::{DroneLabel, LabelStatus, PixelBox};
    use crate::preset::Preset;
    use crate::scene::FrameScene;

    /// Odd floats: signed zeros, subnormals, extremes, non-finite, ties.
    pub(crate) fn odd_floats() -> Vec<f64> {
        let mut v = vec![
            0.0,
            -0.0,
            1.0,
            -1.0,
            0.1,
            0.2,
            1.0 / 3.0,
            1e-7,
            -1e-7,
            5e-7,
            4.9999999e-7,
            1e-6,
            1.5e-6,
            2.5e-6,
            0.0078125,
            0.5,
            1e15,
            1e16,
            1e17,
            1.7976931348623157e308,
            -1.7976931348623157e308,
            5e-324,
            -5e-324,
            2.2250738585072014e-308,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            123_456_789.123_456_5,
            999_999_999.999_999_5,
            1e9,
            -1e9,
            4503599627370496.5,
            960.0,
            1_919.999_999_5,
            0.000_000_5,
            0.000_001_5,
        ];
        // Exact ties of the sixth decimal: k/2^7 · 1/15625 with odd and even neighbours.
        for k in 0..200u32 {
            v.push(f64::from(k) + f64::from(2 * k + 1) / 128.0);
            v.push(f64::from(2 * k + 1) / 128.0);
            v.push(-f64::from(2 * k + 1) / 2048.0);
        }
        // A spread of magnitudes and bit patterns.
        let mut x: u64 = 0x9e37_79b9_7f4a_7c15;
        for _ in 0..20_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            v.push(f64::from_bits(x));
            let scale = 10f64.powi((x % 24) as i32 - 12);
            v.push((x >> 11) as f64 / (1u64 << 53) as f64 * scale * 3000.0);
            v.push(crate::write::r6(
                (x >> 11) as f64 / (1u64 << 40) as f64 - 4000.0,
            ));
        }
        v
    }

    #[test]
    fn numbers_and_strings_are_serde_jsons_bytes() {
        for v in odd_floats() {
            let mut out = Vec::new();
            Json { out: &mut out }.f64(v);
            let serde = serde_json::to_vec(&v).expect("a float serialises");
            assert_eq!(out, serde, "{v:e}");
        }
        for n in [0, 1, 9, 10, 99, 100, 12_345, 1_000_000, u64::MAX] {
            let mut out = Vec::new();
            Json { out: &mut out }.u64(n);
            assert_eq!(out, n.to_string().as_bytes());
        }
        for s in [
            "",
            "plain",
            "quad_x",
            "say \"hi\"",
            "back\\slash",
            "tab\there",
            "nl\n",
            "\u{0}\u{1}\u{1f}\u{7f}",
            "ünïcødé ✈ 🚁",
            "images/train/00000001.jpg",
            "</script>",
        ] {
            let mut out = Vec::new();
            Json { out: &mut out }.str(s);
            assert_eq!(
                out,
                serde_json::to_vec(s).expect("a string serialises"),
                "{s:?}"
            );
        }
    }

    #[test]
    fn rounded_numbers_are_serde_jsons_bytes_of_the_rounded_value() {
        let r = |x: f64, scale: f64| (x * scale).round() / scale;
        let mut xs = odd_floats();
        // Every magnitude about each threshold: 1e-5, 2^51 / 10^k, and integers.
        for e in -20..20 {
            let p = 10f64.powi(e);
            for m in [
                1.0,
                0.999_999_9,
                1.000_000_1,
                0.5,
                2.5,
                9.999_999_5,
                1.234_567_890_123_4,
            ] {
                xs.extend([m * p, -m * p]);
            }
        }
        for k in [
            2_251_799_813_685_248.0,
            2_251_799_813_685_247.0,
            4_503_599_627_370_496.0,
        ] {
            for scale in [1e6, 1e9, 1e12] {
                xs.extend([k / scale, (k + 3.0) / scale, -(k - 1.0) / scale]);
            }
        }
        for (k, scale) in [
            (Decimals::Six, 1e6),
            (Decimals::Nine, 1e9),
            (Decimals::Twelve, 1e12),
        ] {
            for &x in &xs {
                let mut out = Vec::new();
                Json { out: &mut out }.rounded(x, k);
                let serde = serde_json::to_vec(&r(x, scale)).expect("a float serialises");
                assert_eq!(
                    String::from_utf8_lossy(&out),
                    String::from_utf8_lossy(&serde),
                    "{x:e} to {k:?} decimals"
                );
            }
        }
    }

    #[test]
    fn fixed6_is_std_formatting() {
        for v in odd_floats() {
            let mut out = Vec::new();
            fixed6(&mut out, v);
            assert_eq!(
                String::from_utf8(out).expect("ascii"),
                format!("{v:.6}"),
                "{v:e}"
            );
        }
    }

    /// A frame, its labels, the model names and the classes.
    type VariedFrame = (FrameScene, Vec<DroneLabel>, Vec<String>, Vec<String>);

    /// Varied frames: three presets (one with sequences), every label status,
    /// with and without visibility, odd and non-finite numbers, names that
    /// need escapes, out-of-range model indices, labels out of drone order.
    fn varied_frames() -> Vec<VariedFrame> {
        let presets = [
            include_str!("../../../presets/quickstart.ron"),
            include_str!("../../../presets/formation_sequence.ron"),
            include_str!("../../../presets/bench/plan15.ron"),
        ];
        let odd = odd_floats();
        let mut pick = {
            let mut k = 0usize;
            move || {
                k = (k * 7 + 13) % odd.len();
                odd[k]
            }
        };
        let mut frames = Vec::new();
        for (p, text) in presets.iter().enumerate() {
            let preset = Preset::from_ron(text).expect("shipped preset parses");
            for index in [0, 1, 7, 30] {
                let Ok(mut scene) = crate::scene::build_frame(&preset, index) else {
                    continue;
                };
                let n = scene.drones.len();
                let mut labels: Vec<DroneLabel> = (0..n)
                    .filter(|i| i % 4 != 3)
                    .map(|i| {
                        let x = i as f64 * 37.25 + index as f64;
                        let b = PixelBox {
                            x0: x,
                            y0: x / 3.0,
                            x1: x + 10.123_456_789,
                            y1: x / 3.0 + 5.5e-7,
                        };
                        DroneLabel {
                            drone: i,
                            class_id: i % 2,
                            bbox: b,
                            amodal: PixelBox { x0: -x, ..b },
                            paper_aabb: PixelBox { y1: 1e300, ..b },
                            truncated: i % 3 == 0,
                            distance_m: 1.0 / (i as f64 + 0.3),
                            visibility: (i % 2 == 1).then_some(Visibility {
                                visible_box: (i % 3 != 1).then_some(b),
                                visible_pixels: i as u64 * 11,
                                unoccluded_pixels: if i == 5 { 0 } else { i as u64 * 13 },
                            }),
                            status: [LabelStatus::Kept, LabelStatus::Crowd, LabelStatus::Filtered]
                                [i % 3],
                        }
                    })
                    .collect();
                let mut names = vec!["quad_x".to_owned(), "say \"hi\"\n\\ ✈".to_owned()];
                let mut classes = vec!["uav".to_owned(), "c\u{1}\"lass".to_owned()];
                match index {
                    1 => {
                        // Odd numbers everywhere a number is written.
                        scene.camera.fov_y_deg = pick();
                        scene.camera.near_m = f64::NAN;
                        scene.camera.position.x = f64::INFINITY;
                        scene.look_at.y = -0.0;
                        scene.volume_radius_m = pick();
                        scene.sweep.CameraX = f64::NEG_INFINITY;
                        scene.sweep.PlaneRY = pick();
                        scene.sweep.density_per_m3 = Some(pick());
                        scene.environment.cloud_cover = f64::NAN;
                        scene.environment.exposure_offset_ev = pick();
                        scene.environment.sun_offset_ev = -pick();
                        scene.environment.turbidity = pick();
                        scene.environment_name = "sky \"x\"\t\\".to_owned();
                        scene.camera_absolute = true;
                        scene.redraw = 3;
                        scene.camera_model = Some(crate::sensor::CameraDraw {
                            exposure_ev: pick(),
                            auto_exposure: Some(crate::sensor::AutoExposureDraw {
                                target_level: pick(),
                                metered_ev: -0.0,
                            }),
                            white_balance_red: f64::NAN,
                            white_balance_blue: pick(),
                            psf: crate::sensor::PsfDraw::Gaussian { sigma_px: pick() },
                            vignetting: -0.0,
                            ca_red_scale: pick(),
                            ca_blue_scale: 1.000_000_7,
                            shot_noise_gain: pick(),
                            read_noise_levels: f64::INFINITY,
                            sensor_scale: Some(pick()),
                            jpeg_quality: Some(73),
                            recompress_quality: None,
                            noise_seed: u64::MAX,
                            exposure_time_s: 0.0,
                            saturation: pick(),
                            sharpen: pick(),
                            lens: None,
                            rolling_shutter: None,
                        });
                        scene.placement_shortfall = 2;
                        // Drawn looks for all but the last drone (it has none).
                        use crate::preset::appearance::DroneColor;
                        let colors = [
                            DroneColor::White,
                            DroneColor::LightGrey,
                            DroneColor::DarkGrey,
                            DroneColor::Black,
                            DroneColor::Coloured,
                        ];
                        let n = scene.drones.len().saturating_sub(1);
                        scene.looks = (0..n)
                            .map(|i| crate::scene::realism::DroneLook {
                                color: colors[i % colors.len()],
                                albedo: [pick() as f32, 0.8, f32::NAN],
                                roughness: pick() as f32,
                                metalness: -0.0,
                                emissive: pick() as f32,
                                rotor_opacity: 1.0,
                            })
                            .collect();
                        for d in &mut scene.drones {
                            d.size_m = pick();
                            d.position.z = pick();
                            d.euler_deg.yaw = pick();
                            d.rotation.w = pick();
                        }
                        for l in &mut labels {
                            l.distance_m = pick();
                            l.bbox.x1 = pick();
                            l.amodal.y0 = pick();
                        }
                    }
                    7 => {
                        // A model index past the names, a class past the classes,
                        // labels out of drone order and twice for one drone.
                        if let Some(d) = scene.drones.first_mut() {
                            d.model = 9;
                        }
                        if let Some(d) = scene.drones.get_mut(1) {
                            d.model = 1;
                        }
                        classes.truncate(1);
                        scene.camera_model = Some(crate::sensor::CameraDraw {
                            psf: crate::sensor::PsfDraw::Disc { radius_px: pick() },
                            sensor_scale: None,
                            jpeg_quality: None,
                            recompress_quality: Some(40),
                            ..crate::sensor::draw(&Default::default(), 3, index)
                        });
                        for l in &mut labels {
                            l.class_id = 0;
                        }
                        labels.reverse();
                        if let Some(l) = labels.first().cloned() {
                            labels.push(DroneLabel {
                                truncated: !l.truncated,
                                ..l
                            });
                        }
                    }
                    30 => {
                        names.clear();
                    }
                    _ => {}
                }
                if p == 2 && index == 0 {
                    // The plan benchmark's frames as they are.
                    names.truncate(1);
                    classes.truncate(1);
                    for l in &mut labels {
                        l.class_id = 0;
                    }
                }
                frames.push((scene, labels, names, classes));
            }
        }
        assert!(frames.iter().any(|f| f.0.sequence.is_some()));
        assert!(frames.len() >= 10);
        frames
    }

    #[test]
    fn a_field_of_view_a_bit_apart_writes_the_same_manifest_line() {
        // A backplate's field of view comes from libm's `atan`, whose last
        // bit may differ between machines; it was written unrounded.
        use crate::write::formats::manifest;
        let (mut scene, labels, names, classes) = varied_frames().swap_remove(0);
        let line = |scene: &crate::scene::FrameScene| {
            let mut line = Vec::new();
            manifest::write_manifest_line(&mut line, scene, &labels, "a.png", &names, &classes);
            String::from_utf8(line).expect("utf-8")
        };
        scene.camera.fov_y_deg = 40.915_670_839_718_985;
        let a = line(&scene);
        scene.camera.fov_y_deg = scene.camera.fov_y_deg.next_up();
        assert_eq!(a, line(&scene));
        assert!(a.contains("\"fov_y_deg\":40.91567084,"), "{a}");
    }

    #[test]
    fn manifest_coco_and_yolo_records_are_the_serde_and_std_bytes() {
        use crate::write::formats::{coco, manifest, yolo};
        let mut texts = crate::write::FrameTexts::default();
        for (scene, labels, names, classes) in varied_frames() {
            let image = format!("images/{}/{:08}.png", scene.split.as_str(), scene.index);
            let mut line = Vec::new();
            manifest::write_manifest_line(&mut line, &scene, &labels, &image, &names, &classes);
            let reference =
                manifest::reference::manifest_line(&scene, &labels, &image, &names, &classes);
            assert_eq!(
                String::from_utf8_lossy(&line),
                reference,
                "frame {}",
                scene.index
            );
            let (mut img, mut anns) = (Vec::new(), Vec::new());
            coco::write_frame_records(&mut img, &mut anns, &scene, &labels, &image, &names);
            let (ref_img, ref_anns) =
                coco::reference::frame_records(&scene, &labels, &image, &names);
            assert_eq!(
                String::from_utf8_lossy(&img),
                ref_img,
                "frame {}",
                scene.index
            );
            assert_eq!(
                String::from_utf8_lossy(&anns),
                ref_anns,
                "frame {}",
                scene.index
            );
            assert_eq!(
                yolo::label_text(&scene, &labels),
                reference::label_text(&scene, &labels),
                "frame {}",
                scene.index
            );
            // The chunk buffers hold the same records, frame after frame.
            let context = crate::write::TextContext {
                model_names: names.clone(),
                classes: classes.clone(),
                image_format: crate::preset::ImageFormat::Png,
                yolo: true,
                coco: true,
            };
            context.push_frame(&mut texts, &scene, &labels);
            let got = texts.get(texts.len() - 1);
            assert_eq!(got.manifest, line.as_slice());
            assert_eq!(got.coco_image, img.as_slice());
            assert_eq!(got.coco_annotations, anns.as_slice());
            assert_eq!(got.yolo, yolo::label_text(&scene, &labels).as_bytes());
        }
        assert!(texts.get(0).manifest.starts_with(b"{\"camera\""));
        assert!(texts.get(texts.len()).manifest.is_empty());
    }

    /// A plan's workers count chunks and its writer merges them: the same
    /// statistics, to the byte, as counting every frame in turn.
    #[test]
    fn chunk_statistics_merged_are_the_frame_by_frame_statistics() {
        use crate::write::DatasetStats;
        let frames = varied_frames();
        for size in [1, 2, 3, 5, frames.len()] {
            let mut one_by_one = DatasetStats::default();
            let mut merged = DatasetStats::default();
            for chunk in frames.chunks(size) {
                let mut part = DatasetStats::default();
                for (scene, labels, names, _) in chunk {
                    one_by_one.add(scene, labels, names, &[]);
                    part.add(scene, labels, names, &[]);
                }
                merged.merge(&part);
            }
            merged.merge(&DatasetStats::default());
            assert_eq!(merged, one_by_one, "chunks of {size}");
            assert_eq!(
                serde_json::to_string_pretty(&merged).expect("stats serialise"),
                serde_json::to_string_pretty(&one_by_one).expect("stats serialise")
            );
        }
        // The varied frames reach every kind of count.
        let mut all = DatasetStats::default();
        for (scene, labels, names, _) in &frames {
            all.add(scene, labels, names, &[]);
        }
        assert!(all.crowd > 0 && all.filtered > 0 && all.truncated > 0 && all.per_model.len() > 1);
    }

    /// An unknown class, which the serde reference cannot write (it indexes), is null.
    #[test]
    fn a_class_past_the_classes_is_null() {
        let (scene, mut labels, names, classes) =
            varied_frames().into_iter().next().expect("a frame");
        labels[0].class_id = 5;
        let mut line = Vec::new();
        crate::write::formats::manifest::write_manifest_line(
            &mut line, &scene, &labels, "i", &names, &classes,
        );
        let value: serde_json::Value = serde_json::from_slice(&line).expect("valid JSON");
        assert_eq!(
            value["drones"][labels[0].drone]["class"],
            serde_json::Value::Null
        );
        assert_eq!(value["drones"][labels[2].drone]["class"], "uav");
    }

    mod reference {
        use std::fmt::Write as _;

        use crate::annotate::DroneLabel;
        use crate::scene::FrameScene;

        /// The YOLO text as `format!` wrote it.
        pub fn label_text(scene: &FrameScene, labels: &[DroneLabel]) -> String {
            let (w, h) = (
                f64::from(scene.camera.width),
                f64::from(scene.camera.height),
            );
            let mut text = String::new();
            for l in labels.iter().filter(|l| l.is_kept()) {
                let b = &l.bbox;
                let cx = (b.x0 + b.x1) * 0.5 / w;
                let cy = (b.y0 + b.y1) * 0.5 / h;
                let _ = writeln!(
                    text,
                    "{} {:.6} {:.6} {:.6} {:.6}",
                    l.class_id,
                    cx,
                    cy,
                    b.width() / w,
                    b.height() / h
                );
            }
            text
        }
    }
}
