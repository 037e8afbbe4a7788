//! COCO run-length encoding of masks, as pycocotools reads it
//! (`maskApi.c`): runs over the image in column-major order (down each
//! column, then the next column), alternating background and object,
//! starting with a (possibly empty) background run; and the compressed
//! string form `rleToString` writes (each count as the difference from the
//! count two before, from the third on, in 5-bit groups with a continue
//! bit, offset by 48).

/// The run lengths of a mask given by its pixels' column-major indices
/// (`x · height + y`, ascending, no repeats) in an image of `len` pixels.
/// Indices at or past `len` are ignored.
pub fn counts(indices: &[u32], len: u64) -> Vec<u64> {
    let mut out = Vec::with_capacity(2 * indices.len().min(64) + 2);
    let mut at = 0u64; // the first pixel not yet in a run
    let mut run_end: Option<u64> = None; // end of the open object run
    let mut run_start = 0u64;
    for &i in indices {
        let i = u64::from(i);
        if i >= len || i < at {
            continue;
        }
        match run_end {
            Some(end) if end == i => run_end = Some(i + 1),
            _ => {
                if let Some(end) = run_end {
                    out.push(end - run_start);
                    at = end;
                }
                out.push(i - at);
                run_start = i;
                run_end = Some(i + 1);
            }
        }
    }
    if let Some(end) = run_end {
        out.push(end - run_start);
        at = end;
    }
    if out.is_empty() || at < len {
        out.push(len - at);
    }
    out
}

/// pycocotools' compressed string of `counts` (`rleToString`).
pub fn to_coco_string(counts: &[u64]) -> String {
    let mut s = String::with_capacity(counts.len() * 2);
    for (i, &c) in counts.iter().enumerate() {
        // pycocotools takes differences from the count two before for i > 2.
        let mut x = c as i64;
        if i > 2 {
            x -= counts[i - 2] as i64;
        }
        loop {
            let mut ch = (x & 0x1f) as u8;
            x >>= 5;
            let more = if ch & 0x10 != 0 { x != -1 } else { x != 0 };
            if more {
                ch |= 0x20;
            }
            s.push(char::from(ch + 48));
            if !more {
                break;
            }
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// pycocotools' `rleFrString`, written from its C source.
    fn from_coco_string(s: &str) -> Vec<u64> {
        let b = s.as_bytes();
        let mut out: Vec<i64> = Vec::new();
        let mut p = 0;
        while p < b.len() {
            let (mut x, mut k, mut more) = (0i64, 0, true);
            while more {
                let c = i64::from(b[p]) - 48;
                x |= (c & 0x1f) << (5 * k);
                more = c & 0x20 != 0;
                p += 1;
                k += 1;
                if !more && c & 0x10 != 0 {
                    x |= -1i64 << (5 * k);
                }
            }
            if out.len() > 2 {
                x += out[out.len() - 2];
            }
            out.push(x);
        }
        out.into_iter().map(|v| v as u64).collect()
    }

    #[test]
    fn runs_alternate_from_background() {
        // A 3×3 image (len 9): pixels 0, 1, 4 and 8.
        assert_eq!(counts(&[0, 1, 4, 8], 9), vec![0, 2, 2, 1, 3, 1]);
        assert_eq!(counts(&[], 9), vec![9]);
        assert_eq!(counts(&[3, 4, 5], 6), vec![3, 3]);
        assert_eq!(counts(&[0, 1, 2], 3), vec![0, 3]);
        assert_eq!(counts(&[2, 9], 6), vec![2, 1, 3], "past the end is ignored");
    }

    #[test]
    fn the_string_form_round_trips_as_pycocotools_reads_it() {
        for c in [
            vec![9u64],
            vec![0, 2, 2, 1, 3, 1],
            vec![1_000_000, 3, 1077, 5, 1075, 7, 2_000_000],
            vec![5, 100, 3, 2, 40_000, 1, 1, 1],
        ] {
            assert_eq!(from_coco_string(&to_coco_string(&c)), c);
        }
        // A known string: pycocotools encodes counts [1, 2, 3] as "123" offset by 48.
        assert_eq!(to_coco_string(&[1, 2, 3]), "123");
        // 31 has its 0x10 bit set, so it needs a second group: "o" then "0".
        assert_eq!(to_coco_string(&[0, 31]), "0o0");
    }
}
