//! The summary table of the domain-gap report as plain data: each statistic's
//! [`Summary`] per side, its [`StatRow`] with the verdict, the [`Proposal`]s made
//! from the rows, and how numbers and cells are printed. [`super::report`] fills
//! it; [`super::propose`] reads it; neither imports the other for it.

use serde::Serialize;

/// A statistic summarised on one side.
#[derive(Clone, Copy, Debug, Serialize, PartialEq)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Summary {
    /// Median and inter-quartile range of `n` values.
    Distribution {
        n: usize,
        median: f64,
        q25: f64,
        q75: f64,
    },
    /// `k` of `n` with a 50 % Wilson interval.
    Share {
        n: usize,
        k: usize,
        share: f64,
        low: f64,
        high: f64,
    },
}

impl Summary {
    /// The median, or the share.
    pub(super) fn centre(&self) -> f64 {
        match *self {
            Summary::Distribution { median, .. } => median,
            Summary::Share { share, .. } => share,
        }
    }
    /// The inter-quartile range, or the share's 50 % Wilson interval.
    pub(super) fn range(&self) -> (f64, f64) {
        match *self {
            Summary::Distribution { q25, q75, .. } => (q25, q75),
            Summary::Share { low, high, .. } => (low, high),
        }
    }
    /// How many values it summarises.
    pub fn n(&self) -> usize {
        match *self {
            Summary::Distribution { n, .. } | Summary::Share { n, .. } => n,
        }
    }
}

/// Below this many real values a statistic's real range is flagged in the
/// table: the quartiles of a handful of values move with every value added.
pub const FEW_REAL_VALUES: usize = 20;

#[derive(Clone, Debug, Serialize)]
pub struct StatRow {
    pub key: &'static str,
    pub name: &'static str,
    pub unit: &'static str,
    /// `frame` or `drone`: what one value is.
    pub per: &'static str,
    pub real: Option<Summary>,
    pub synthetic: Option<Summary>,
    /// `inside` (the synthetic median or share lies in the real IQR or interval),
    /// `below`, `above`, or `n/a` when a side has no value.
    pub verdict: &'static str,
    /// How far the synthetic median (share) lies outside the real IQR (interval), in
    /// widths of it ([`iqr_distance`]): 0 inside; `None` when a side has no value.
    pub iqr_distance: Option<f64>,
    /// Counted among the statistics inside (the report's original fourteen); `false`
    /// for the rows added for fitting (background texture, box size, what lies behind).
    pub counted: bool,
}

/// The distance of the synthetic centre `c` outside the real range `[lo, hi]` in units
/// of its width: 0 inside, `(lo − c) / (hi − lo)` below, `(c − hi) / (hi − lo)` above. A
/// range narrower than 0.1 % of `|c|` (or 10⁻⁶) counts as that wide, so an all-equal
/// real side (every frame JPEG 85) gives a large, finite distance.
pub fn iqr_distance(real: Option<Summary>, synthetic: Option<Summary>) -> Option<f64> {
    let (lo, hi) = real?.range();
    let c = synthetic?.centre();
    let width = (hi - lo).max(1e-3 * c.abs()).max(1e-6);
    Some(if c < lo {
        (lo - c) / width
    } else if c > hi {
        (c - hi) / width
    } else {
        0.0
    })
}

/// A camera-model (or scene) change that would move a statistic inside the real range.
#[derive(Clone, Debug, Serialize)]
pub struct Proposal {
    pub key: &'static str,
    pub text: String,
    /// The proposed parameter range, in the unit the text names.
    pub range: Option<[f64; 2]>,
}

/// A number with three significant figures or so.
pub fn fmt(v: f64) -> String {
    let a = v.abs();
    if a >= 100.0 {
        format!("{v:.0}")
    } else if a >= 10.0 {
        format!("{v:.1}")
    } else if a >= 1.0 {
        format!("{v:.2}")
    } else {
        format!("{v:.3}")
    }
}

/// A summary cell of the table: median [IQR] (n), or share [interval] (n).
pub fn cell(s: Option<Summary>) -> String {
    match s {
        None => "–".into(),
        Some(Summary::Distribution {
            n,
            median,
            q25,
            q75,
        }) => format!("{} [{} – {}] (n={n})", fmt(median), fmt(q25), fmt(q75)),
        Some(Summary::Share {
            n,
            share,
            low,
            high,
            ..
        }) => format!(
            "{:.0} % [{:.0} – {:.0}] (n={n})",
            share * 100.0,
            low * 100.0,
            high * 100.0
        ),
    }
}

/// Linear-interpolated percentile of sorted data (`q` in 0–1; 0 when empty).
pub fn percentile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return 0.0;
    }
    let pos = q * (sorted.len() - 1) as f64;
    let i = pos.floor() as usize;
    let f = pos - i as f64;
    if i + 1 < sorted.len() {
        sorted[i] + f * (sorted[i + 1] - sorted[i])
    } else {
        sorted[i]
    }
}
