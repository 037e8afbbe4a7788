//! Content records: a finished shard's files' sizes and BLAKE3 hashes, in its ledger.

use super::*;

/// A file's size and BLAKE3 hash (hex), read from its start.
pub fn content_record(file: &mut File) -> std::io::Result<(u64, String)> {
    file.seek(SeekFrom::Start(0))?;
    let mut hasher = blake3::Hasher::new();
    let len = std::io::copy(file, &mut hasher)?;
    Ok((len, hasher.finalize().to_hex().to_string()))
}

/// What a finished shard's ledger records of one file.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ContentRecord {
    /// Size in bytes.
    pub len: u64,
    /// BLAKE3 hash of the contents, hex.
    pub blake3: String,
}

/// The content records of the finished run in `root` (empty when the run
/// recorded none: not a shard, or made by a swarmshot before records).
pub fn content_records(root: &Path) -> Result<BTreeMap<String, ContentRecord>, OutputError> {
    let path = root.join(LEDGER);
    let bytes = super::ledger::read_ledger(open_checked(root, LEDGER, false)?, &path)?;
    let mut records = BTreeMap::new();
    for line in String::from_utf8_lossy(&bytes).lines() {
        if line.starts_with('=') {
            // Records come after the last checkpoint; earlier ones belong to an older finish.
            records.clear();
        }
        let Some(rest) = line.strip_prefix('%') else {
            continue;
        };
        let bad = || OutputError::Ledger {
            path: path.clone(),
            reason: format!("it holds a malformed content record {line:?}"),
        };
        let (len, rest) = rest.split_once(' ').ok_or_else(bad)?;
        let (hash, rel) = rest.split_once(' ').ok_or_else(bad)?;
        let blake3 = hash.strip_prefix("blake3:").ok_or_else(bad)?;
        records.insert(
            rel.to_owned(),
            ContentRecord {
                len: len.parse().map_err(|_| bad())?,
                blake3: blake3.to_owned(),
            },
        );
    }
    Ok(records)
}
