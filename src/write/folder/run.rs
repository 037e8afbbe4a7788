//! What a run is ([`RunId`]): the ledger's header line, written and read;
//! and what it read ([`InputRecord`]): the records after the header.

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
        // What no run writes: more frames than any preset makes, a shard
        // past its run's end or outside its count (a forged header would
        // otherwise set the bound the ledger is read within).
        let plausible = frames <= crate::preset::MAX_FRAMES
            && shard.as_ref().is_none_or(|s| {
                s.start <= s.end && s.end <= frames && s.shard.index < s.shard.count
            });
        plausible.then_some(Self {
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

/// One file or folder the run's preset reads (`Preset::input_paths`), as
/// the run recorded it in its ledger (`^FIELD blake3:HEX PATH`, after the
/// header): a run is continued, finished again or merged only from inputs
/// of the same content, so a model, sky or plate replaced between a kill
/// and `--resume` cannot leave a dataset made of both.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct InputRecord {
    /// The preset field naming it (`models`, `sky`, `backplate.folder`).
    pub field: String,
    /// BLAKE3 of its content, hex (a model with the files its URIs name; a
    /// backplate folder with every plate and sidecar and their names).
    pub blake3: String,
    /// Its path as this run named it, for messages (never compared: shards
    /// made on other machines read the same files at other paths).
    pub path: String,
}

/// The most inputs a run records (each model file, sky image and backplate
/// folder once); a preset naming more is refused.
pub const MAX_INPUT_RECORDS: usize = 4096;

/// The most characters of an input's path a record keeps (it is for messages).
const RECORD_PATH_CHARS: usize = 240;

/// The most bytes an input record's line takes: its field, hash and path
/// (each path character at most a 10-byte escape).
pub(super) const INPUT_RECORD_BYTES: u64 = 128 + 10 * RECORD_PATH_CHARS as u64;

impl InputRecord {
    /// The record of the input `field` at `path` whose content hashed to `blake3`.
    pub fn new(field: &str, blake3: String, path: &Path) -> Self {
        let path = crate::text::printable(&path.to_string_lossy());
        Self {
            field: field.to_owned(),
            blake3,
            path: match path.char_indices().nth(RECORD_PATH_CHARS) {
                Some((end, _)) => format!("{}…", &path[..end]),
                None => path,
            },
        }
    }

    /// Its ledger line.
    pub(super) fn line(&self) -> String {
        format!("^{} blake3:{} {}\n", self.field, self.blake3, self.path)
    }

    /// The record a ledger line holds after its `^`.
    pub(super) fn parse(text: &str) -> Option<Self> {
        let (field, rest) = text.split_once(' ')?;
        let (hash, path) = rest.split_once(' ')?;
        let blake3 = hash.strip_prefix("blake3:")?;
        let hex = blake3.len() == 64 && blake3.bytes().all(|b| b.is_ascii_hexdigit());
        (hex && !field.is_empty()).then(|| Self {
            field: field.to_owned(),
            blake3: blake3.to_owned(),
            path: path.to_owned(),
        })
    }
}

/// How the inputs `now` differ from those an earlier run recorded, one
/// phrase each; empty when they match or `earlier` recorded none (a ledger
/// written before the record).
pub fn changed_inputs(earlier: &[InputRecord], now: &[InputRecord]) -> Vec<String> {
    if earlier.is_empty() {
        return Vec::new();
    }
    if earlier.len() != now.len() {
        return vec![format!(
            "the preset reads {} files or folders, the run read {}",
            now.len(),
            earlier.len()
        )];
    }
    (earlier.iter().zip(now))
        .filter(|(e, n)| e.field != n.field || e.blake3 != n.blake3)
        .map(|(e, n)| match e.path == n.path {
            true => format!("{} {}", n.field, n.path),
            false => format!("{} {} (the run read {})", n.field, n.path, e.path),
        })
        .collect()
}

/// What a folder's ledger says of the run that wrote it.
#[derive(Clone, Debug)]
pub struct EarlierRun {
    pub run: RunId,
    /// The run finished (its done mark is trusted).
    pub done: bool,
    /// What it recorded of its inputs (none: a ledger written before the record).
    pub inputs: Vec<InputRecord>,
}

/// What the ledger of `root` says the run is (`None`: no ledger).
pub fn read_run(root: &Path) -> Result<Option<EarlierRun>, OutputError> {
    if lstat(&root.join(LEDGER))?.is_none() {
        return Ok(None);
    }
    let scan = Folder::scan(root)?;
    Ok(Some(EarlierRun {
        run: scan.run,
        done: scan.done,
        inputs: scan.inputs,
    }))
}

/// FNV-1a, 64 bit: a stable hash of the locked preset's text.
pub fn fnv1a64(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}
