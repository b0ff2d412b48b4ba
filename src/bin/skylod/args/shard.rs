//! `--shard I/N` and `--shards N`: the part of an array job this run does
//! ([`skylod::pipeline::batch::shard`]), flattened into every command that reads inputs.

use crate::flags::shard_text;
use skylod::lod::poi::Poi;
use skylod::pipeline::batch::Shard;

/// The shard options of a command.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct ShardArgs {
    /// Do part I of N (I from 0) of the work, for an array job: files in path order, or
    /// POIs grouped by place. Default: from the scheduler's environment
    /// (JOB_COMPLETION_INDEX, SLURM_ARRAY_TASK_ID - SLURM_ARRAY_TASK_MIN with
    /// SLURM_ARRAY_TASK_COUNT, AWS_BATCH_JOB_ARRAY_INDEX), else all of it.
    #[arg(long, value_name = "I/N", value_parser = parse_shard)]
    pub shard: Option<Shard>,
    /// Number of shards where the scheduler gives only the index (Kubernetes `completions`,
    /// AWS Batch array `size`).
    #[arg(long, value_name = "N")]
    pub shards: Option<usize>,
}

/// Parse `--shard I/N`, its errors in the flag's words.
fn parse_shard(s: &str) -> Result<Shard, String> {
    s.parse().map_err(|e| shard_text(&e))
}

impl ShardArgs {
    /// The shard of this run: the options, else the scheduler's environment; `None` when
    /// neither says anything. Invalid or conflicting settings are usage errors.
    pub fn resolve(&self) -> anyhow::Result<Option<Shard>> {
        Shard::resolve(self.shard, self.shards, |k| std::env::var(k).ok())
            .map_err(|e| anyhow::anyhow!(shard_text(&e)))
    }
}

/// The POIs of `shard` (all without one), in their order; says on stderr which.
pub fn pois(shard: Option<Shard>, pois: Vec<Poi>, cmd: &str) -> Vec<Poi> {
    let Some(s) = shard else { return pois };
    let at: Vec<glam::DVec3> = pois.iter().map(|p| p.position).collect();
    let range = s.pois(&at);
    keep(pois, range, s, cmd, "POIs")
}

/// The files of `shard` (all without one) among `files`, one per input in path order (the
/// inputs, or (input, output) pairs laid out for all inputs): a contiguous run; says on
/// stderr which.
pub fn files<T>(shard: Option<Shard>, files: Vec<T>, cmd: &str) -> Vec<T> {
    let Some(s) = shard else { return files };
    let range = s.files(files.len());
    keep(files, range, s, cmd, "files")
}

/// The `range` of `items` (shard `s`'s part); says on stderr which.
fn keep<T>(
    items: Vec<T>,
    range: std::ops::Range<usize>,
    s: Shard,
    cmd: &str,
    what: &str,
) -> Vec<T> {
    let total = items.len();
    let mine: Vec<T> = items
        .into_iter()
        .skip(range.start)
        .take(range.len())
        .collect();
    say(s, range, total, cmd, what);
    mine
}

/// Say on stderr that shard `s` does `range` of `total` items.
pub fn say(s: Shard, range: std::ops::Range<usize>, total: usize, cmd: &str, what: &str) {
    crate::log::summary!("{cmd}: {}", s.part_line(range, total, what));
}

/// Whether this run prints a table's header: always without a shard, else shard 0 only, so
/// the shards' outputs concatenated in shard order are the serial run's.
pub fn header(shard: Option<Shard>) -> bool {
    shard.is_none_or(|s| s.is_first())
}
