//! Inputs and `-o` of the commands that rewrite CityGML as CityGML (`subset`, `filter-lods`).

use std::path::PathBuf;

/// CityGML in, CityGML out.
#[derive(clap::Args, Debug)]
pub struct CityGmlIoArgs {
    /// CityGML files (.gml, .xml, .gz), directories, glob patterns, or - for standard input.
    #[arg(required = true)]
    pub inputs: Vec<PathBuf>,
    /// Output file for one input (.gz to compress; `-` for standard output); a directory that
    /// mirrors the input tree; or, for several inputs, one CityGML file that merges them.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Replace existing output files.
    #[arg(long)]
    pub overwrite: bool,
    #[command(flatten)]
    pub shard: crate::args::shard::ShardArgs,
}

/// [`CityGmlIoArgs`], then `--jobs` (`subset`, `filter-lods`).
#[derive(clap::Args, Debug)]
pub struct EditArgs {
    #[command(flatten)]
    pub io: CityGmlIoArgs,
    #[command(flatten)]
    pub jobs: crate::args::jobs::JobsArgs,
}
