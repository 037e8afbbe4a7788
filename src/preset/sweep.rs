//! Start/end/step sweeps and the frame index ↔ sweep value mapping: the
//! preset's sweep axes and the radices of its frame index
//! ([`super::Preset::frame_radices`], [`super::Preset::frame_count`]).
//!
//! A range yields `start + i·step` for `i = 0..=n` with
//! `n = floor((end − start)/step + 1e-9)`. Values are computed from the index,
//! never by repeated addition, so `0..1 step 0.1` is exactly 11 values and the
//! last one is `0 + 10·0.1`, not the sum of ten `0.1`s.

use serde::{Deserialize, Serialize};

use super::{Placement, Volume};

/// Tolerance added before `floor` so that `(end − start)/step` landing a hair
/// below an integer (0.9999999999) still counts the end value.
const COUNT_EPSILON: f64 = 1e-9;

/// The largest number of values one sweep axis may have.
pub const MAX_AXIS_VALUES: u64 = 1_000_000;

/// One swept parameter: `start`, `end`, `step` (the paper's start/end/step triplets).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SweepRange {
    pub start: f64,
    pub end: f64,
    pub step: f64,
}

impl Default for SweepRange {
    fn default() -> Self {
        Self::fixed(0.0)
    }
}

/// Why a range cannot be enumerated.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SweepError {
    #[error(
        "start, end and step must be finite numbers (got start={start}, end={end}, step={step})"
    )]
    NotFinite { start: f64, end: f64, step: f64 },
    #[error(
        "step is 0 but start ({start}) differs from end ({end}); use a step with the sign of end − start"
    )]
    ZeroStep { start: f64, end: f64 },
    #[error(
        "step {step} points away from end (start={start}, end={end}); the step must have the sign of end − start"
    )]
    WrongSign { start: f64, end: f64, step: f64 },
    #[error("range has {count} values, more than the limit of {limit}")]
    TooMany { count: f64, limit: u64 },
}

impl SweepRange {
    /// A range with a single value.
    pub const fn fixed(value: f64) -> Self {
        Self {
            start: value,
            end: value,
            step: 0.0,
        }
    }

    pub const fn new(start: f64, end: f64, step: f64) -> Self {
        Self { start, end, step }
    }

    /// Number of values, or why the range is invalid.
    pub fn count(&self) -> Result<u64, SweepError> {
        let Self { start, end, step } = *self;
        if !(start.is_finite() && end.is_finite() && step.is_finite()) {
            return Err(SweepError::NotFinite { start, end, step });
        }
        if start == end {
            return Ok(1);
        }
        if step == 0.0 {
            return Err(SweepError::ZeroStep { start, end });
        }
        let steps = (end - start) / step;
        if steps < 0.0 {
            return Err(SweepError::WrongSign { start, end, step });
        }
        let n = (steps + COUNT_EPSILON).floor() + 1.0;
        if !n.is_finite() || n > MAX_AXIS_VALUES as f64 {
            return Err(SweepError::TooMany {
                count: n,
                limit: MAX_AXIS_VALUES,
            });
        }
        Ok(n as u64)
    }

    /// The `i`-th value: `start + i·step` (no accumulation).
    pub fn value(&self, i: u64) -> f64 {
        if self.start == self.end {
            self.start
        } else {
            self.start + (i as f64) * self.step
        }
    }

    /// All values; empty if the range is invalid.
    pub fn values(&self) -> Vec<f64> {
        let n = self.count().unwrap_or(0);
        (0..n).map(|i| self.value(i)).collect()
    }
}

/// A mixed-radix decomposition of a frame index over several axes; the last
/// axis varies fastest.
pub fn decode_mixed_radix(mut index: u64, radices: &[u64]) -> Vec<u64> {
    let mut digits = vec![0; radices.len()];
    for (digit, &radix) in digits.iter_mut().zip(radices).rev() {
        let radix = radix.max(1);
        *digit = index % radix;
        index /= radix;
    }
    digits
}

/// The preset's frame index: its sweep axes and radices (the frame count
/// is their product).
impl super::Preset {
    /// The sweep axes in nesting order (outermost first): CameraX, CameraY,
    /// CameraZ, PlaneRX, PlaneRY, PlaneRZ, then the density ρ of a
    /// `DensitySweep` volume (one value, unused, otherwise).
    pub fn sweep_axes(&self) -> [(&'static str, SweepRange); 7] {
        [
            ("camera.x", self.camera.x),
            ("camera.y", self.camera.y),
            ("camera.z", self.camera.z),
            ("plane.rx", self.plane.rx),
            ("plane.ry", self.plane.ry),
            ("plane.rz", self.plane.rz),
            (
                "placement.volume.per_m3",
                self.density_sweep().unwrap_or(SweepRange::fixed(0.0)),
            ),
        ]
    }

    /// The density sweep of a `DensitySweep` volume.
    pub fn density_sweep(&self) -> Option<SweepRange> {
        match &self.placement {
            Placement::Randomized {
                volume: Volume::DensitySweep { per_m3, .. },
                ..
            } => Some(*per_m3),
            _ => None,
        }
    }

    /// Radices of the frame index: the seven sweep axes, the repeat count,
    /// then the step t of a sequence (T + 1 frames; 1 without sequences).
    pub fn frame_radices(&self) -> Result<[u64; 9], SweepError> {
        let mut r = [1u64; 9];
        for (slot, (_, range)) in r.iter_mut().zip(self.sweep_axes()) {
            *slot = range.count()?;
        }
        r[7] = u64::from(self.repeats.max(1));
        r[8] = self.sequence_len();
        Ok(r)
    }

    /// Frames per sequence: T + 1 in sequence mode, else 1.
    pub fn sequence_len(&self) -> u64 {
        self.sequence
            .as_ref()
            .map_or(1, |s| u64::from(s.steps.max(1)) + 1)
    }

    /// Total number of frames (0 if a sweep is invalid).
    pub fn frame_count(&self) -> u64 {
        self.frame_radices()
            .map(|r| r.iter().fold(1u64, |acc, &n| acc.saturating_mul(n)))
            .unwrap_or(0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zero_to_one_by_tenths_has_eleven_values() {
        let r = SweepRange::new(0.0, 1.0, 0.1);
        assert_eq!(r.count(), Ok(11));
        let v = r.values();
        assert_eq!(v[10], 10.0 * 0.1);
        assert!((v[10] - 1.0).abs() < 1e-12);
    }

    #[test]
    fn accumulating_steps_still_count_the_end() {
        // 0.3/0.1 = 2.9999999999999996 in binary floating point.
        assert_eq!(SweepRange::new(0.0, 0.3, 0.1).count(), Ok(4));
        assert_eq!(SweepRange::new(0.7, 0.1, -0.2).count(), Ok(4));
        assert_eq!(SweepRange::new(1.0, 2.0, 0.3).count(), Ok(4)); // 1.0 1.3 1.6 1.9
        assert_eq!(SweepRange::new(-180.0, 180.0, 45.0).count(), Ok(9));
    }

    #[test]
    fn invalid_ranges_are_rejected() {
        assert!(matches!(
            SweepRange::new(0.0, 1.0, 0.0).count(),
            Err(SweepError::ZeroStep { .. })
        ));
        assert!(matches!(
            SweepRange::new(0.0, 1.0, -0.1).count(),
            Err(SweepError::WrongSign { .. })
        ));
        assert!(matches!(
            SweepRange::new(f64::NAN, 1.0, 0.1).count(),
            Err(SweepError::NotFinite { .. })
        ));
        assert!(matches!(
            SweepRange::new(0.0, 1e12, 1e-3).count(),
            Err(SweepError::TooMany { .. })
        ));
        assert_eq!(SweepRange::new(2.0, 2.0, 0.0).count(), Ok(1));
    }

    #[test]
    fn mixed_radix_round_trips() {
        let radices = [3, 1, 4, 2];
        let total: u64 = radices.iter().product();
        let mut seen = std::collections::BTreeSet::new();
        for i in 0..total {
            let d = decode_mixed_radix(i, &radices);
            let back = d.iter().zip(&radices).fold(0, |acc, (d, r)| acc * r + d);
            assert_eq!(back, i);
            seen.insert(d);
        }
        assert_eq!(seen.len() as u64, total);
        assert_eq!(decode_mixed_radix(1, &radices), vec![0, 0, 0, 1]);
    }
}
