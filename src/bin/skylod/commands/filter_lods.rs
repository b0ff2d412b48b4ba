//! `skylod filter-lods`: keep or remove LoD representations of the city objects of CityGML or
//! CityJSON documents (citygml-tools' `filter-lods`; CityJSON: `skylod::export::transform::cityjson`),
//! streamed: memory follows the largest city object.

use crate::args::citygml_io::EditArgs;
use crate::Outcome;
use skylod::export::transform::{LodMode, Lods};
use skylod::pipeline::batch::Transform;

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    edit: EditArgs,
    /// LoDs (0 to 4) the mode applies to.
    #[arg(short, long, required = true, num_args = 1.., value_delimiter = ',',
          value_parser = clap::value_parser!(u8).range(0..=4))]
    lod: Vec<u8>,
    /// keep or remove the listed LoDs; minimum / maximum: keep only the lowest / highest listed
    /// LoD of each top-level city object.
    #[arg(short, long, value_enum, default_value_t = LodMode::Keep)]
    mode: LodMode,
    /// Keep city objects left without any LoD representation (default: remove them).
    #[arg(short, long)]
    keep_empty: bool,
}

pub fn run(args: Args) -> anyhow::Result<Outcome> {
    let rule = Lods {
        lods: args.lod,
        mode: args.mode,
        keep_empty: args.keep_empty,
    };
    crate::outputs::per_input_jobs(
        &args.edit.io,
        "filter-lods",
        &args.edit.jobs,
        Transform::FilterLods(rule),
    )
}
