//! `skylod subset`: keep the top-level city objects of CityGML or CityJSON documents that match
//! a box, ids, types, a radius or a random draw (citygml-tools' and cjio's `subset`; CityJSON: `skylod::export::transform::cityjson`),
//! streamed: memory follows the largest city object.

use crate::args::citygml_io::EditArgs;
use crate::Outcome;
use anyhow::Context;
use skylod::export::transform::{BboxMode, Subset};
use skylod::model::crs::Crs;
use skylod::pipeline::batch::Transform;

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    edit: EditArgs,
    /// Keep city objects whose box meets X0,Y0,X1,Y1 (in the document's CRS, or --bbox-crs).
    #[arg(
        long,
        value_name = "X0,Y0,X1,Y1",
        value_delimiter = ',',
        allow_hyphen_values = true
    )]
    bbox: Option<Vec<f64>>,
    /// How a city object is tested against --bbox: its box meets it or lies within it
    /// (citygml-tools), or the centroid of its own vertices lies in it, half-open (cjio).
    #[arg(long, value_enum, default_value_t = BboxMode::Intersects, requires = "bbox")]
    bbox_mode: BboxMode,
    /// Keep city objects whose centroid lies closer than R to (X, Y), in the document's CRS
    /// (cjio's --radius).
    #[arg(
        long,
        value_name = "X,Y,R",
        value_delimiter = ',',
        allow_hyphen_values = true
    )]
    radius: Option<Vec<f64>>,
    /// CRS of --bbox (EPSG:n, in that CRS's axis order), converted into each document's CRS.
    #[arg(long, value_name = "CRS", requires = "bbox")]
    bbox_crs: Option<String>,
    /// Keep the top-level city objects with these gml:ids.
    #[arg(long, value_name = "ID", num_args = 1.., value_delimiter = ',')]
    id: Vec<String>,
    /// Keep the top-level city objects of these types (local names: Building, CityFurniture, ...).
    #[arg(long = "type", value_name = "TYPE", num_args = 1.., value_delimiter = ',')]
    types: Vec<String>,
    /// Keep what does not match instead.
    #[arg(long)]
    invert: bool,
    /// Keep at most N city objects per input (the first N that match, in document order).
    #[arg(long, value_name = "N")]
    limit: Option<usize>,
    /// Keep N of the top-level city objects that match, drawn at random per input (cjio's
    /// --random); the same N for the same --seed, in CityGML and CityJSON alike.
    #[arg(long, value_name = "N")]
    random: Option<usize>,
    /// Seed of --random: another seed draws other objects.
    #[arg(long, value_name = "S", default_value_t = 0, requires = "random")]
    seed: u64,
}

pub fn run(args: Args) -> anyhow::Result<Outcome> {
    let bbox_crs = match &args.bbox_crs {
        Some(s) => Some(
            Crs::parse_named(s)
                .map_err(anyhow::Error::msg)
                .context("--bbox-crs")?,
        ),
        None => None,
    };
    let bbox = match args.bbox.as_deref() {
        Some(&[x0, y0, x1, y1]) if x0 <= x1 && y0 <= y1 => Some([x0, y0, x1, y1]),
        Some(_) => anyhow::bail!("--bbox: X0,Y0,X1,Y1 with X0 <= X1 and Y0 <= Y1"),
        None => None,
    };
    let radius = match args.radius.as_deref() {
        Some(&[x, y, r]) if r >= 0.0 && r.is_finite() => Some([x, y, r]),
        Some(_) => anyhow::bail!("--radius: X,Y,R with R >= 0"),
        None => None,
    };
    let rule = Subset {
        bbox,
        mode: args.bbox_mode,
        bbox_crs,
        ids: args.id,
        types: args.types,
        invert: args.invert,
        limit: args.limit,
        radius,
        random: args.random,
        seed: args.seed,
    };
    crate::outputs::per_input_jobs(
        &args.edit.io,
        "subset",
        &args.edit.jobs,
        Transform::Subset(Box::new(rule)),
    )
}
