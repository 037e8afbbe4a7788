//! `swarmshot merge OUT SHARD…`: join the folders of `--shard K/N` runs into
//! the dataset one process would have written (docs/scale.md).
//!
//! The shards must be every shard 0..N-1 of one run (the same locked preset,
//! frame count and N), each finished (`!done` in its ledger). OUT is written
//! like a batch's folder (docs/reliability.md: claimed in its own ledger,
//! never through a link, atomic files) and ends as a finished run of the
//! preset, so `batch` on OUT with the same preset finds nothing to do.
//! Shards are appended in index order, one checkpoint each: images, label
//! and MOT files are hard-linked (copied when OUT is on another file
//! system), manifest lines and COCO records appended as they are, COCO
//! annotation ids numbered on, statistics added. A killed merge run again
//! continues after the last complete shard. Nothing is written into a shard.

use std::path::{Path, PathBuf};

use serde_json::Value;

use super::folder::{LEDGER, fnv1a64, read_run};
use super::{DatasetStats, DatasetWriter, OutputError, ShardRun, WriterOptions};
use crate::preset::Preset;

/// What [`merge`] did.
#[derive(Clone, Debug)]
pub struct MergeReport {
    pub stats: DatasetStats,
    pub frames: u64,
    pub shards: u64,
    /// Shards an earlier, interrupted merge had already joined.
    pub shards_before: u64,
    pub linked: u64,
    pub copied: u64,
}

/// Why shards cannot be merged.
#[derive(Debug, thiserror::Error)]
pub enum MergeError {
    #[error("no shard folders given: swarmshot merge OUT SHARD_0 SHARD_1 …")]
    NoShards,
    #[error("{}: not a shard: {reason}", path.display())]
    NotAShard { path: PathBuf, reason: String },
    #[error(
        "{}: shard {shard} is incomplete (its ledger has no !done); finish it with the same `swarmshot batch … --shard {shard}` (it continues where it stopped), then merge",
        path.display()
    )]
    Incomplete { path: PathBuf, shard: String },
    #[error(
        "{} and {} are shards of different runs ({what}); merge only the shards of one `--shard K/N` run",
        a.display(),
        b.display()
    )]
    DifferentRuns {
        a: PathBuf,
        b: PathBuf,
        what: String,
    },
    #[error("{} and {} are both shard {shard}: shards overlap", a.display(), b.display())]
    Overlap {
        a: PathBuf,
        b: PathBuf,
        shard: String,
    },
    #[error(
        "{} missing: every shard 0/{count} … {}/{count} of the run is needed",
        if missing.len() > 1 { format!("shards {} are", missing.join(", ")) } else { format!("shard {} is", missing.join(", ")) },
        count - 1
    )]
    Missing { missing: Vec<String>, count: u64 },
    #[error("{}: the shard ranges do not tile the frames ({reason})", path.display())]
    Ranges { path: PathBuf, reason: String },
    #[error("{}: {reason}", path.display())]
    Lock { path: PathBuf, reason: String },
    #[error("{}: the output folder is one of the shards; choose a new folder for the merged dataset", path.display())]
    OutIsShard { path: PathBuf },
    #[error(
        "{}: it holds a run stopped at frame {next}, which is not where a shard starts; choose another folder, or pass --overwrite",
        path.display()
    )]
    NotAtShard { path: PathBuf, next: u64 },
    #[error("{}: the statistics cannot be added: {reason}", path.display())]
    Stats { path: PathBuf, reason: String },
    #[error(transparent)]
    Output(#[from] OutputError),
}

struct ShardDir {
    path: PathBuf,
    run: ShardRun,
    frames: u64,
    preset_hash: u64,
}

/// Merge the finished shards `shards` into `out` (created if missing;
/// `overwrite` deletes an earlier run's own files there first, as the batch's does).
pub fn merge(out: &Path, shards: &[PathBuf], overwrite: bool) -> Result<MergeReport, MergeError> {
    let mut dirs = Vec::new();
    for path in shards {
        let not = |reason: &str| MergeError::NotAShard {
            path: path.clone(),
            reason: reason.into(),
        };
        let Some((run, done)) = read_run(path)? else {
            return Err(not(&format!("it holds no swarmshot run (no {LEDGER})")));
        };
        let Some(shard) = run.shard else {
            return Err(not(
                "its run was made without --shard (a whole dataset needs no merge)",
            ));
        };
        if !done {
            return Err(MergeError::Incomplete {
                path: path.clone(),
                shard: shard.shard.to_string(),
            });
        }
        dirs.push(ShardDir {
            path: path.clone(),
            run: shard,
            frames: run.frames,
            preset_hash: run.preset_hash,
        });
    }
    let first = dirs.first().ok_or(MergeError::NoShards)?;
    for d in &dirs[1..] {
        let what = if d.preset_hash != first.preset_hash {
            "their preset.lock.ron differ".to_owned()
        } else if d.frames != first.frames {
            format!("{} and {} frames: --limit differs", first.frames, d.frames)
        } else if d.run.shard.count != first.run.shard.count {
            format!(
                "cut in {} and {} shards",
                first.run.shard.count, d.run.shard.count
            )
        } else {
            continue;
        };
        return Err(MergeError::DifferentRuns {
            a: first.path.clone(),
            b: d.path.clone(),
            what,
        });
    }
    dirs.sort_by_key(|d| d.run.shard.index);
    for w in dirs.windows(2) {
        if w[0].run.shard.index == w[1].run.shard.index {
            return Err(MergeError::Overlap {
                a: w[0].path.clone(),
                b: w[1].path.clone(),
                shard: w[0].run.shard.to_string(),
            });
        }
    }
    let count = dirs[0].run.shard.count;
    let (frames, preset_hash) = (dirs[0].frames, dirs[0].preset_hash);
    let missing: Vec<String> = (0..count)
        .filter(|k| !dirs.iter().any(|d| d.run.shard.index == *k))
        .map(|k| format!("{k}/{count}"))
        .collect();
    if !missing.is_empty() {
        return Err(MergeError::Missing { missing, count });
    }
    let mut next = 0;
    for d in &dirs {
        if d.run.start != next || d.run.end < d.run.start {
            return Err(MergeError::Ranges {
                path: d.path.clone(),
                reason: format!(
                    "shard {} holds frames {}..{}, but the shards before it end at {next}",
                    d.run.shard, d.run.start, d.run.end
                ),
            });
        }
        next = d.run.end;
    }
    if next != frames {
        return Err(MergeError::Ranges {
            path: dirs[dirs.len() - 1].path.clone(),
            reason: format!("the last shard ends at frame {next}, the run has {frames}"),
        });
    }
    let out_abs = std::fs::canonicalize(out).ok();
    for d in &dirs {
        if out_abs.is_some() && std::fs::canonicalize(&d.path).ok() == out_abs {
            return Err(MergeError::OutIsShard { path: out.into() });
        }
    }
    let preset = locked_preset(&dirs[0].path, preset_hash)?;
    let mut writer = DatasetWriter::open(
        out,
        &preset,
        Vec::new(),
        WriterOptions {
            frames: Some(frames),
            overwrite,
            resume: false,
            shard: None,
            labels_only: false,
        },
    )?;
    let resumed_at = writer.next_frame();
    if resumed_at < frames && !dirs.iter().any(|d| d.run.start == resumed_at) {
        return Err(MergeError::NotAtShard {
            path: out.into(),
            next: resumed_at,
        });
    }
    let mut report = MergeReport {
        stats: DatasetStats::default(),
        frames,
        shards: count,
        shards_before: 0,
        linked: 0,
        copied: 0,
    };
    for d in &dirs {
        if d.run.start < resumed_at || resumed_at == frames {
            report.shards_before += 1;
            continue;
        }
        let stats = add_stats(writer.stats(), &d.path)?;
        let (linked, copied) = writer.merge_shard(&d.path, d.run.start, d.run.end, &stats)?;
        report.linked += linked;
        report.copied += copied;
    }
    report.stats = writer.finish()?;
    Ok(report)
}

/// The shard's locked preset, checked against its ledger's hash and
/// against the text a batch of it would lock (so OUT's lock is the same bytes).
fn locked_preset(shard: &Path, hash: u64) -> Result<Preset, MergeError> {
    let path = shard.join("preset.lock.ron");
    let bad = |reason: String| MergeError::Lock {
        path: path.clone(),
        reason,
    };
    let text = std::fs::read_to_string(&path).map_err(|e| bad(e.to_string()))?;
    if fnv1a64(text.as_bytes()) != hash {
        return Err(bad("does not match the hash in the shard's ledger".into()));
    }
    let preset = Preset::from_ron(&text).map_err(bad)?;
    if preset.to_ron() != text {
        return Err(bad(
            "was locked by another swarmshot version (it does not read back to the same text); merge with the version that made the shards".into(),
        ));
    }
    Ok(preset)
}

/// `so_far` plus the shard's `stats.json`: every count added (numbers in
/// arrays and maps alike), so fields added to the statistics later are
/// carried without a change here, as long as they are counts.
fn add_stats(so_far: &DatasetStats, shard: &Path) -> Result<DatasetStats, MergeError> {
    let path = shard.join("stats.json");
    let bad = |reason: String| MergeError::Stats {
        path: path.clone(),
        reason,
    };
    let text = std::fs::read_to_string(&path).map_err(|e| bad(e.to_string()))?;
    let theirs: Value = serde_json::from_str(&text).map_err(|e| bad(e.to_string()))?;
    let mut sum = serde_json::to_value(so_far).map_err(|e| bad(e.to_string()))?;
    add_counts(&mut sum, &theirs, "").map_err(bad)?;
    serde_json::from_value(sum).map_err(|e| bad(e.to_string()))
}

fn add_counts(sum: &mut Value, add: &Value, at: &str) -> Result<(), String> {
    match (sum, add) {
        (Value::Number(a), Value::Number(b)) => {
            let (Some(x), Some(y)) = (a.as_u64(), b.as_u64()) else {
                return Err(format!("{at} is not a count ({a} + {b})"));
            };
            let total = x.checked_add(y).ok_or_else(|| format!("{at} overflows"))?;
            *a = total.into();
            Ok(())
        }
        // Histograms: bin by bin (a bin one side lacks counts 0).
        (Value::Array(a), Value::Array(b)) => {
            for (i, y) in b.iter().enumerate() {
                match a.get_mut(i) {
                    Some(x) => add_counts(x, y, &format!("{at}[{i}]"))?,
                    None => a.push(y.clone()),
                }
            }
            Ok(())
        }
        (Value::Object(a), Value::Object(b)) => {
            for (k, y) in b {
                match a.get_mut(k) {
                    Some(x) => add_counts(x, y, &format!("{at}.{k}"))?,
                    None => {
                        a.insert(k.clone(), y.clone());
                    }
                }
            }
            Ok(())
        }
        // Labels of the whole run (how boxes were made, …): the same in every
        // shard; the empty running sum takes the first shard's.
        (a @ (Value::String(_) | Value::Bool(_) | Value::Null), b) if a == b => Ok(()),
        (a, b) if *a == Value::String(String::new()) || *a == Value::Bool(false) || a.is_null() => {
            if b.is_string() || b.is_boolean() {
                *a = b.clone();
                Ok(())
            } else {
                Err(format!("{at} differs in shape ({a} and {b})"))
            }
        }
        (a, b) => Err(format!("{at} differs between shards ({a} and {b})")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_add_in_arrays_and_maps_and_other_numbers_are_refused() {
        let mut a = serde_json::json!({"frames": 2, "per": [1, 2, 3], "by": {"x": 1}});
        let b = serde_json::json!({"frames": 3, "per": [1, 1, 1], "by": {"x": 1, "y": 4}});
        add_counts(&mut a, &b, "").expect("counts add");
        assert_eq!(
            a,
            serde_json::json!({"frames": 5, "per": [2, 3, 4], "by": {"x": 2, "y": 4}})
        );
        let mut c = serde_json::json!({"mean": 1.5});
        assert!(add_counts(&mut c, &serde_json::json!({"mean": 2.0}), "").is_err());
        // Histograms of different lengths add bin by bin.
        let mut d = serde_json::json!({"per": [1, 2]});
        add_counts(&mut d, &serde_json::json!({"per": [1, 0, 5]}), "").expect("bins add");
        assert_eq!(d, serde_json::json!({"per": [2, 2, 5]}));
        // Labels of the run: taken when empty, equal afterwards, else refused.
        let mut e = serde_json::json!({"from": "", "plan": false});
        let f = serde_json::json!({"from": "Visible", "plan": false});
        add_counts(&mut e, &f, "").expect("labels");
        add_counts(&mut e, &f, "").expect("labels again");
        assert_eq!(e, f);
        assert!(add_counts(&mut e, &serde_json::json!({"from": "Amodal"}), "").is_err());
    }
}
