//! The report's proposals (`swarmshot gap`, moved out of `report.rs`):
//! camera-model ranges (read noise and PSF added in quadrature, JPEG quality),
//! an exposure factor, a factor on camera distances, and hints for the
//! drones' materials and the sky's saturation, each from a statistic whose
//! synthetic median lies outside the real inter-quartile range.

use super::table::{Proposal, StatRow, fmt};

/// A statistic's real IQR (lo, hi), the dataset's centre and the verdict.
fn dist(rows: &[StatRow], key: &str) -> Option<(f64, f64, f64, &'static str)> {
    let r = row(rows, key)?;
    let (Some(real), Some(syn)) = (r.real, r.synthetic) else {
        return None;
    };
    let (lo, hi) = real.range();
    Some((lo, hi, syn.centre(), r.verdict))
}

/// The read noise's and the PSF's proposals (added in quadrature when below).
fn noise_and_blur(rows: &[StatRow], out: &mut Vec<Proposal>) {
    for (key, what, unit) in [
        ("noise_sigma", "noise: read σ", "levels"),
        ("blur_sigma_px", "optics blur: Gaussian PSF σ", "px"),
    ] {
        if let Some((lo, hi, s, v)) = dist(rows, key) {
            let p = match v {
                "below" => {
                    let (a, b) = (add_in_quadrature(lo, s), add_in_quadrature(hi, s));
                    Proposal {
                        key: if key == "noise_sigma" {
                            "noise"
                        } else {
                            "blur"
                        },
                        text: format!(
                            "{what} {} – {} {unit} added (the dataset measures {} against the real {} – {}; added in quadrature{})",
                            fmt(a),
                            fmt(b),
                            fmt(s),
                            fmt(lo),
                            fmt(hi),
                            if key == "noise_sigma" {
                                "; the encoder smooths some noise away, so aim at the upper end and measure again"
                            } else {
                                ""
                            }
                        ),
                        range: Some([a, b]),
                    }
                }
                "above" => Proposal {
                    key: if key == "noise_sigma" {
                        "noise"
                    } else {
                        "blur"
                    },
                    text: format!(
                        "{what}: the dataset measures {} {unit}, above the real {} – {}: lower it",
                        fmt(s),
                        fmt(lo),
                        fmt(hi)
                    ),
                    range: None,
                },
                _ => Proposal {
                    key: if key == "noise_sigma" {
                        "noise"
                    } else {
                        "blur"
                    },
                    text: format!("{what}: inside the real range ({} {unit}): keep", fmt(s)),
                    range: None,
                },
            };
            out.push(p);
        }
    }
}

pub(super) fn row<'a>(rows: &'a [StatRow], key: &str) -> Option<&'a StatRow> {
    rows.iter().find(|r| r.key == key)
}

/// Added Gaussian σ that takes `have` (in quadrature) to `want`; 0 when already there.
pub(super) fn add_in_quadrature(want: f64, have: f64) -> f64 {
    (want * want - have * have).max(0.0).sqrt()
}

/// The camera-model and preset changes that bring each statistic outside the real
/// IQR inside it.
pub(super) fn propose(rows: &[StatRow]) -> Vec<Proposal> {
    let mut out = Vec::new();
    let dist = |key: &str| dist(rows, key);
    noise_and_blur(rows, &mut out);
    if let Some(r) = row(rows, "jpeg_quality")
        && let Some(real) = r.real
    {
        let (lo, hi) = real.range();
        out.push(Proposal {
            key: "jpeg_quality",
            text: format!(
                "JPEG quality {} – {} (the real files' IQR)",
                lo.round(),
                hi.round()
            ),
            range: Some([lo.round(), hi.round()]),
        });
    }
    if let Some((lo, hi, s, v)) = dist("mean_brightness")
        && v != "inside"
        && s > 0.0
    {
        out.push(Proposal {
            key: "exposure",
            text: format!(
                "exposure: scale brightness by ×{} – ×{} (real IQR {} – {} levels over the dataset's {}; a ratio of 8-bit levels: in linear light about its 2.2th power)",
                fmt(lo / s),
                fmt(hi / s),
                fmt(lo),
                fmt(hi),
                fmt(s)
            ),
            range: Some([lo / s, hi / s]),
        });
    }
    if let Some((lo, hi, s, v)) = dist("drone_core_px")
        && v != "inside"
        && lo > 0.0
    {
        out.push(Proposal {
            key: "distance",
            text: format!(
                "drone size: cores of {} – {} px (real IQR) against the dataset's {}: scale camera distances by ×{} – ×{}",
                fmt(lo),
                fmt(hi),
                fmt(s),
                fmt(s / hi),
                fmt(s / lo)
            ),
            range: Some([s / hi, s / lo]),
        });
    }
    if let Some(r) = row(rows, "drone_darker")
        && let (Some(real), Some(syn), "below" | "above") = (r.real, r.synthetic, r.verdict)
    {
        out.push(Proposal {
            key: "appearance",
            text: format!(
                "appearance: {} % of the dataset's drones are darker than the sky behind them, against {} % of the real ones: {} light or sunlit drone materials",
                (syn.centre() * 100.0).round(),
                (real.centre() * 100.0).round(),
                if r.verdict == "above" { "more" } else { "fewer" }
            ),
            range: None,
        });
    }
    if let Some((lo, hi, s, v)) = dist("sky_saturation")
        && v != "inside"
        && s > 0.0
    {
        out.push(Proposal {
            key: "sky_saturation",
            text: format!(
                "sky saturation: ×{} – ×{} (real {} – {} against the dataset's {})",
                fmt(lo / s),
                fmt(hi / s),
                fmt(lo),
                fmt(hi),
                fmt(s)
            ),
            range: Some([lo / s, hi / s]),
        });
    }
    out
}
