//! What a run is ([`RunId`]): the ledger's header line, written and read.

use super::*;

/// What a run is: its frame count, its locked preset's hash, for a
/// shard (`--shard K/N`) which shard and its frame range, and for a trial
/// of every Kth frame (`--every K`) its step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RunId {
    /// One past the last frame index the run may make (its frame count
    /// when `every` is 1).
    pub frames: u64,
    pub preset_hash: u64,
    pub shard: Option<ShardRun>,
    /// The run makes frames `0, every, 2·every, …` below `frames` (1: all).
    pub every: u64,
}

/// A shard's part of a run: shard K of N makes frames `start..end`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ShardRun {
    pub shard: Shard,
    pub start: u64,
    pub end: u64,
}

/// How a run with `--shard` cuts its frames: the shard and the unit
/// (one frame, or a sequence) its range is made of.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ShardPlan {
    pub shard: Shard,
    pub unit: u64,
}

impl ShardPlan {
    pub(super) fn run(self, frames: u64) -> ShardRun {
        let r = self.shard.range(frames, self.unit);
        ShardRun {
            shard: self.shard,
            start: r.start,
            end: r.end,
        }
    }
}

impl RunId {
    /// The first frame this run makes.
    pub fn start(&self) -> u64 {
        self.shard.map_or(0, |s| s.start)
    }

    /// One past the last frame this run makes.
    pub fn end(&self) -> u64 {
        self.shard.map_or(self.frames, |s| s.end)
    }

    pub(super) fn header(&self) -> String {
        let shard = self.shard.map_or(String::new(), |s| {
            format!(" shard={} range={}..{}", s.shard, s.start, s.end)
        });
        // A run of every frame writes the header it always wrote.
        let every = match self.every {
            0 | 1 => String::new(),
            k => format!(" every={k}"),
        };
        format!(
            "swarmshot-ledger {LEDGER_VERSION} frames={} preset=fnv1a64:{:016x}{shard}{every}\n",
            self.frames, self.preset_hash
        )
    }

    pub(super) fn parse(line: &str) -> Option<Self> {
        let mut words = line.split(' ');
        if words.next()? != "swarmshot-ledger" || words.next()? != "1" {
            return None;
        }
        let frames = words.next()?.strip_prefix("frames=")?.parse().ok()?;
        let hash = words.next()?.strip_prefix("preset=fnv1a64:")?;
        let preset_hash = u64::from_str_radix(hash, 16).ok()?;
        let mut word = words.next();
        let shard = match word.filter(|w| w.starts_with("shard=")) {
            None => None,
            Some(w) => {
                let (index, count) = w.strip_prefix("shard=")?.split_once('/')?;
                let (start, end) = words.next()?.strip_prefix("range=")?.split_once("..")?;
                let shard = Some(ShardRun {
                    shard: Shard {
                        index: index.parse().ok()?,
                        count: count.parse().ok()?,
                    },
                    start: start.parse().ok()?,
                    end: end.parse().ok()?,
                });
                word = words.next();
                shard
            }
        };
        let every = match word {
            None => 1,
            Some(w) => {
                let k: u64 = w.strip_prefix("every=")?.parse().ok()?;
                if k < 2 || words.next().is_some() {
                    return None;
                }
                k
            }
        };
        Some(Self {
            frames,
            preset_hash,
            shard,
            every,
        })
    }

    /// What a refusal says this run is.
    pub(super) fn describe(&self) -> String {
        match self.shard {
            None if self.every > 1 => format!(
                "--every {} over the first {} frames ({} frames)",
                self.every,
                self.frames,
                self.frames.div_ceil(self.every)
            ),
            None => format!("{} frames", self.frames),
            Some(s) => format!(
                "{} frames, shard {} (frames {}..{})",
                self.frames, s.shard, s.start, s.end
            ),
        }
    }
}

/// What the ledger of `root` says the run is (`None`: no ledger).
pub fn read_run(root: &Path) -> Result<Option<(RunId, bool)>, OutputError> {
    if lstat(&root.join(LEDGER))?.is_none() {
        return Ok(None);
    }
    let scan = Folder::scan(root)?;
    Ok(Some((scan.run, scan.done)))
}

/// FNV-1a, 64 bit: a stable hash of the locked preset's text.
pub fn fnv1a64(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}
