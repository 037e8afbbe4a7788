//! Shards: a deterministic partition of a dataset's frames, so that N
//! processes on N machines each render a part and `swarmshot merge` joins
//! the parts into the dataset a single run makes (docs/scale.md).
//!
//! Shard K of N (`--shard K/N`, K from 0) makes one contiguous range of frame
//! indices. The frames are cut in units (one frame; in sequence mode one
//! whole sequence, so a sequence never spans two shards): with U units,
//! shard K gets units ⌊U·K/N⌋ .. ⌊U·(K+1)/N⌋. The ranges depend only on the
//! frame count (after `--limit`), N and the unit, so every shard of one
//! dataset agrees on them without talking to the others, and a frame is a
//! pure function of (preset, index), so its bytes do not depend on which
//! shard made it.
//!
//! `--shard auto` takes K and N from the scheduler: a Slurm job array
//! (`SLURM_ARRAY_TASK_ID` minus `SLURM_ARRAY_TASK_MIN`, divided by
//! `SLURM_ARRAY_TASK_STEP`; N from `SLURM_ARRAY_TASK_COUNT`, or from MIN/MAX
//! when an older Slurm does not set it), or a Kubernetes Indexed Job
//! (`JOB_COMPLETION_INDEX`; the Job's completions are not in its pods'
//! environment, so N is given: `--shard auto/N`). With `auto/N` and Slurm, N
//! must agree with the array.

use std::fmt;
use std::ops::Range;

/// Shard `index` of `count` (0-based).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Shard {
    pub index: u64,
    pub count: u64,
}

/// A `--shard` value that cannot be used, or scheduler variables that are missing or disagree.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum ShardError {
    #[error("--shard {0}: expected K/N (shard K of N, K from 0, e.g. 0/4), auto or auto/N")]
    Syntax(String),
    #[error("--shard {index}/{count}: K must be below N (shards are numbered 0..N-1)")]
    OutOfRange { index: u64, count: u64 },
    #[error("--shard {0}: N must be at least 1")]
    NoShards(String),
    #[error(
        "--shard auto: neither SLURM_ARRAY_TASK_ID (a Slurm job array, sbatch --array) nor JOB_COMPLETION_INDEX (a Kubernetes Indexed Job) is set; run it as an array task, or give the shard as --shard K/N"
    )]
    NoScheduler,
    #[error(
        "--shard auto: JOB_COMPLETION_INDEX={0} is set (a Kubernetes Indexed Job) but the number of shards is not; give it as --shard auto/N, N the Job's completions"
    )]
    NoCount(String),
    #[error(
        "--shard auto: both SLURM_ARRAY_TASK_ID and JOB_COMPLETION_INDEX are set; give the shard as --shard K/N"
    )]
    Ambiguous,
    #[error("--shard auto: {name}={value:?} is not a whole number")]
    NotANumber { name: &'static str, value: String },
    #[error("--shard auto: SLURM_ARRAY_TASK_ID is set but {0} is not; is this a Slurm job array?")]
    MissingSlurm(&'static str),
    #[error("--shard auto: the Slurm array variables disagree: {0}")]
    Inconsistent(String),
}

/// The frames of a dataset cut into shards.
impl Shard {
    /// Parse `K/N`, `auto` or `auto/N`; `auto` reads the scheduler's
    /// variables through `env` (`std::env::var` in the binary, a table in tests).
    pub fn parse(text: &str, env: impl Fn(&str) -> Option<String>) -> Result<Self, ShardError> {
        let number = |s: &str| -> Result<u64, ShardError> {
            s.trim()
                .parse()
                .map_err(|_| ShardError::Syntax(text.to_owned()))
        };
        let (k, n) = match text.trim().split_once('/') {
            Some((k, n)) => (k.trim(), Some(number(n)?)),
            None => (text.trim(), None),
        };
        if n == Some(0) {
            return Err(ShardError::NoShards(text.to_owned()));
        }
        let shard = if k == "auto" {
            Self::from_scheduler(n, env)?
        } else {
            let Some(count) = n else {
                return Err(ShardError::Syntax(text.to_owned()));
            };
            Self {
                index: number(k)?,
                count,
            }
        };
        if shard.index >= shard.count {
            return Err(ShardError::OutOfRange {
                index: shard.index,
                count: shard.count,
            });
        }
        Ok(shard)
    }

    fn from_scheduler(
        count: Option<u64>,
        env: impl Fn(&str) -> Option<String>,
    ) -> Result<Self, ShardError> {
        let var = |name: &'static str| -> Result<Option<u64>, ShardError> {
            match env(name) {
                None => Ok(None),
                Some(v) if v.trim().is_empty() => Ok(None),
                Some(value) => value
                    .trim()
                    .parse()
                    .map(Some)
                    .map_err(|_| ShardError::NotANumber { name, value }),
            }
        };
        let slurm_id = var("SLURM_ARRAY_TASK_ID")?;
        let k8s_index = var("JOB_COMPLETION_INDEX")?;
        match (slurm_id, k8s_index) {
            (Some(_), Some(_)) => Err(ShardError::Ambiguous),
            (None, None) => Err(ShardError::NoScheduler),
            (None, Some(index)) => match count {
                Some(count) => Ok(Self { index, count }),
                None => Err(ShardError::NoCount(index.to_string())),
            },
            (Some(id), None) => {
                let min = var("SLURM_ARRAY_TASK_MIN")?
                    .ok_or(ShardError::MissingSlurm("SLURM_ARRAY_TASK_MIN"))?;
                let step = var("SLURM_ARRAY_TASK_STEP")?.unwrap_or(1).max(1);
                let max = var("SLURM_ARRAY_TASK_MAX")?;
                let slurm_count = match (var("SLURM_ARRAY_TASK_COUNT")?, max) {
                    (Some(c), _) => c,
                    (None, Some(max)) if max >= min => (max - min) / step + 1,
                    (None, Some(max)) => {
                        return Err(ShardError::Inconsistent(format!(
                            "SLURM_ARRAY_TASK_MAX={max} is below SLURM_ARRAY_TASK_MIN={min}"
                        )));
                    }
                    (None, None) => {
                        return Err(ShardError::MissingSlurm(
                            "SLURM_ARRAY_TASK_COUNT (or SLURM_ARRAY_TASK_MAX)",
                        ));
                    }
                };
                let bad = |why: String| Err(ShardError::Inconsistent(why));
                if id < min || (id - min) % step != 0 {
                    return bad(format!(
                        "task {id} is not in the array {min}..{} step {step}",
                        max.map_or("?".to_owned(), |m| m.to_string())
                    ));
                }
                if let Some(max) = max
                    && (max < min || (max - min) / step + 1 != slurm_count)
                {
                    return bad(format!(
                        "SLURM_ARRAY_TASK_COUNT={slurm_count} but MIN={min}, MAX={max}, STEP={step} give {} tasks (only a range a-b or a-b:s is a set of shards, not a list)",
                        if max >= min {
                            (max - min) / step + 1
                        } else {
                            0
                        }
                    ));
                }
                if let Some(n) = count
                    && n != slurm_count
                {
                    return bad(format!(
                        "--shard auto/{n} but the array has {slurm_count} tasks"
                    ));
                }
                Ok(Self {
                    index: (id - min) / step,
                    count: slurm_count,
                })
            }
        }
    }

    /// The frame indices of this shard among `frames` frames cut in units of
    /// `unit` frames (1, or a sequence's length).
    pub fn range(self, frames: u64, unit: u64) -> Range<u64> {
        let unit = unit.max(1);
        let units = frames.div_ceil(unit);
        let cut = |k: u64| {
            let u = u128::from(units) * u128::from(k) / u128::from(self.count.max(1));
            // u ≤ units, so u·unit ≤ frames + unit − 1: it fits.
            (u64::try_from(u).unwrap_or(units).saturating_mul(unit)).min(frames)
        };
        cut(self.index)..cut(self.index + 1)
    }
}

impl fmt::Display for Shard {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn env<'a>(vars: &'a [(&'a str, &'a str)]) -> impl Fn(&str) -> Option<String> + 'a {
        move |name| {
            vars.iter()
                .find(|(k, _)| *k == name)
                .map(|(_, v)| (*v).to_owned())
        }
    }

    #[test]
    fn explicit_shards_parse_and_bad_ones_are_named() {
        let none = env(&[]);
        assert_eq!(Shard::parse("1/3", &none), Ok(Shard { index: 1, count: 3 }));
        assert_eq!(
            Shard::parse("3/3", &none),
            Err(ShardError::OutOfRange { index: 3, count: 3 })
        );
        assert!(matches!(
            Shard::parse("1/0", &none),
            Err(ShardError::NoShards(_))
        ));
        for bad in ["1", "a/3", "1/b", "", "1/3/4", "-1/3"] {
            assert!(
                matches!(Shard::parse(bad, &none), Err(ShardError::Syntax(_))),
                "{bad}"
            );
        }
        assert_eq!(Shard::parse("auto", &none), Err(ShardError::NoScheduler));
    }

    #[test]
    fn slurm_arrays_and_indexed_jobs_give_the_shard() {
        let slurm = [
            ("SLURM_ARRAY_TASK_ID", "2"),
            ("SLURM_ARRAY_TASK_MIN", "0"),
            ("SLURM_ARRAY_TASK_MAX", "2"),
            ("SLURM_ARRAY_TASK_COUNT", "3"),
            ("SLURM_ARRAY_TASK_STEP", "1"),
        ];
        assert_eq!(
            Shard::parse("auto", env(&slurm)),
            Ok(Shard { index: 2, count: 3 })
        );
        assert_eq!(
            Shard::parse("auto/3", env(&slurm)),
            Ok(Shard { index: 2, count: 3 })
        );
        assert!(matches!(
            Shard::parse("auto/4", env(&slurm)),
            Err(ShardError::Inconsistent(_))
        ));
        // --array=1-7:2 is tasks 1, 3, 5, 7: shards 0..4.
        let stepped = [
            ("SLURM_ARRAY_TASK_ID", "5"),
            ("SLURM_ARRAY_TASK_MIN", "1"),
            ("SLURM_ARRAY_TASK_MAX", "7"),
            ("SLURM_ARRAY_TASK_STEP", "2"),
        ];
        assert_eq!(
            Shard::parse("auto", env(&stepped)),
            Ok(Shard { index: 2, count: 4 })
        );
        // A list (--array=1,5,7) is not a range of shards.
        let list = [
            ("SLURM_ARRAY_TASK_ID", "5"),
            ("SLURM_ARRAY_TASK_MIN", "1"),
            ("SLURM_ARRAY_TASK_MAX", "7"),
            ("SLURM_ARRAY_TASK_COUNT", "3"),
        ];
        assert!(matches!(
            Shard::parse("auto", env(&list)),
            Err(ShardError::Inconsistent(_))
        ));
        assert_eq!(
            Shard::parse("auto", env(&[("SLURM_ARRAY_TASK_ID", "1")])),
            Err(ShardError::MissingSlurm("SLURM_ARRAY_TASK_MIN"))
        );
        // A MAX below MIN is named as such, not as a missing count.
        let e = Shard::parse(
            "auto",
            env(&[
                ("SLURM_ARRAY_TASK_ID", "7"),
                ("SLURM_ARRAY_TASK_MIN", "9"),
                ("SLURM_ARRAY_TASK_MAX", "5"),
            ]),
        )
        .expect_err("max below min");
        assert!(
            e.to_string()
                .contains("MAX=5 is below SLURM_ARRAY_TASK_MIN=9"),
            "{e}"
        );
        assert!(matches!(
            Shard::parse("auto", env(&[("SLURM_ARRAY_TASK_ID", "x")])),
            Err(ShardError::NotANumber { .. })
        ));
        let k8s = [("JOB_COMPLETION_INDEX", "4")];
        assert_eq!(
            Shard::parse("auto/5", env(&k8s)),
            Ok(Shard { index: 4, count: 5 })
        );
        assert_eq!(
            Shard::parse("auto", env(&k8s)),
            Err(ShardError::NoCount("4".into()))
        );
        assert_eq!(
            Shard::parse("auto/4", env(&k8s)),
            Err(ShardError::OutOfRange { index: 4, count: 4 })
        );
        let both = [("JOB_COMPLETION_INDEX", "1"), ("SLURM_ARRAY_TASK_ID", "1")];
        assert_eq!(
            Shard::parse("auto/4", env(&both)),
            Err(ShardError::Ambiguous)
        );
    }

    #[test]
    fn ranges_partition_the_frames_in_whole_units() {
        for frames in [0u64, 1, 7, 10, 99, 100, 1001] {
            for unit in [1u64, 3, 4] {
                for count in [1u64, 2, 3, 7, 50] {
                    let mut next = 0;
                    for index in 0..count {
                        let r = Shard { index, count }.range(frames, unit);
                        assert_eq!(r.start, next, "{frames} {unit} {count}");
                        assert!(r.start <= r.end);
                        assert!(r.start.is_multiple_of(unit), "a sequence is cut");
                        next = r.end;
                    }
                    assert_eq!(next, frames);
                }
            }
        }
        // Even: 10 frames in 3 shards are 3, 3, 4 frames.
        let sizes: Vec<u64> = (0..3)
            .map(|index| Shard { index, count: 3 }.range(10, 1))
            .map(|r| r.end - r.start)
            .collect();
        assert_eq!(sizes, [3, 3, 4]);
    }
}
