//! `skylod upgrade`: CityGML 1.0 / 2.0 → 3.0 (citygml-tools' `upgrade`); CityJSON → CityGML 3.0
//! (a `.gml` output) or CityJSON 1.0 / 1.1 → 2.0 (`cjio upgrade`); streamed: memory
//! follows the largest city object; files in parallel (`--jobs`), the same bytes whatever
//! the number.

use crate::args::citygml_io::CityGmlIoArgs;
use crate::Outcome;
use skylod::export::transform::UpgradeOptions;
use skylod::pipeline::batch::Transform;

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    io: CityGmlIoArgs,
    /// Use the LoD4 representation of city objects as LoD3, replacing an existing LoD3
    /// (without it LoD4 geometry is dropped: CityGML 3.0 has no LoD4).
    #[arg(short = 'u', long)]
    use_lod4_as_lod3: bool,
    /// Map the LoD0 roof edge of buildings onto a roof surface (else dropped).
    #[arg(short = 'r', long)]
    map_lod0_roof_edge: bool,
    /// Map the LoD1 multi-surface of city objects onto a generic thematic surface (else
    /// dropped: 3.0 spaces have no LoD1 multi-surface).
    #[arg(short = 'm', long)]
    map_lod1_multi_surfaces: bool,
    #[command(flatten)]
    jobs: crate::args::jobs::JobsArgs,
}

pub fn run(args: Args) -> anyhow::Result<Outcome> {
    let options = UpgradeOptions::new(
        args.use_lod4_as_lod3,
        args.map_lod0_roof_edge,
        args.map_lod1_multi_surfaces,
    );
    crate::outputs::per_input_jobs(&args.io, "upgrade", &args.jobs, Transform::Upgrade(options))
}
