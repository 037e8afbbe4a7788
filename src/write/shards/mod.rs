//! Datasets past one process: the deterministic partition of a run's frames
//! (`--shard K/N`, [`shard`]) and `swarmshot merge`, which joins finished
//! shards into the dataset one run writes ([`merge`]); docs/scale.md.

pub mod merge;
pub mod shard;
