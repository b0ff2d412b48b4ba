//! `--source-crs`, `--jobs`, `--shard`/`--shards` of the commands that read file by file
//! (`stats`, `rough`).

/// The CRS, threads and shard of a command that reads file by file.
#[derive(clap::Args, Debug)]
pub struct PerFileArgs {
    #[command(flatten)]
    pub crs: crate::args::crs::SourceCrsArgs,
    #[command(flatten)]
    pub jobs: crate::args::jobs::JobsArgs,
    #[command(flatten)]
    pub shard: crate::args::shard::ShardArgs,
}
