//! `-o`, `--format`, `--overwrite`: where a command writes its model.

use skylod::export::Format;
use std::path::{Path, PathBuf};

/// `--format` values.
pub fn parse_format(s: &str) -> Result<Format, String> {
    s.parse()
}

/// Where a command writes its model (`lod`, `rough`).
#[derive(clap::Args, Debug, Clone)]
pub struct OutputArgs {
    /// Output file for one input (`-` for standard output; `.gz` compresses; the format
    /// follows the name: .gml/.xml CityGML, .obj OBJ, .city.json CityJSON, .city.jsonl
    /// CityJSONSeq, DIR/tileset.json 3D Tiles); a directory that mirrors the input tree (created if missing); or, for
    /// several inputs, one file (or `-`) that merges them (lod: CityGML, OBJ or CityJSON, one
    /// origin for all; rough: CityGML).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Output format when the output's name does not tell it (in a directory: the format of
    /// every output, named after its input with the format's ending).
    #[arg(long, value_name = "citygml|obj|cityjson|cityjsonseq|3dtiles", value_parser = parse_format)]
    pub format: Option<Format>,
    /// Replace existing output files.
    #[arg(long)]
    pub overwrite: bool,
}

impl OutputArgs {
    /// `(-o, --format, --overwrite)`, as [`skylod::pipeline::batch::Batch::new`] takes them.
    pub fn target(&self) -> (&Path, Option<Format>, bool) {
        (&self.output, self.format, self.overwrite)
    }
}
