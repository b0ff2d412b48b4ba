//! `skylod reproject`: every coordinate of CityGML documents into another CRS through PROJ
//! (citygml-tools' option names `-t` / `-s`). Needs the cargo feature `proj`; a build without
//! it knows the command and refuses it with a usage error naming the feature.

use crate::Outcome;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// CityGML files (.gml, .xml, .gz), CityJSON (.city.json, .city.jsonl: written as
    /// CityJSON), directories, glob patterns, or - for standard input.
    #[arg(required = true)]
    inputs: Vec<PathBuf>,
    /// Target CRS: EPSG:n, EPSG:h+v (compound), or an OGC URN. A 2-D target keeps the
    /// source's vertical CRS (heights are never changed).
    #[arg(short = 't', long = "target-crs", value_name = "CRS")]
    target: String,
    /// Source CRS, overriding the documents' srsName.
    #[arg(short = 's', long = "source-crs", value_name = "CRS")]
    source: Option<String>,
    /// Output file for one input (.gz to compress; `-` for standard output); a directory that
    /// mirrors the input tree; or, for several inputs, one CityGML file that merges them.
    #[arg(short, long)]
    output: PathBuf,
    /// Replace existing output files.
    #[arg(long)]
    overwrite: bool,
    #[command(flatten)]
    shard: crate::args::shard::ShardArgs,
}

#[cfg(not(feature = "proj"))]
pub fn run(_args: Args) -> anyhow::Result<Outcome> {
    anyhow::bail!(
        "reproject needs PROJ: this skylod was built without the cargo feature `proj`; \
         build it with `cargo build --release --features proj` (bundled PROJ; needs cmake, \
         sqlite3 and libsqlite3-dev)"
    )
}

#[cfg(feature = "proj")]
pub fn run(mut args: Args) -> anyhow::Result<Outcome> {
    use anyhow::Context;
    let (inputs, _spool) = crate::inputs::expand_inputs_relative(&args.inputs)?;
    args.inputs = inputs.iter().map(|i| i.path.clone()).collect();
    use skylod::export::transform::reproject_cityjson;
    use skylod::export::transform::{reproject_file, ReprojectError};
    use skylod::io::citygml::WriteOptions;
    use skylod::model::crs::Crs;
    use skylod::model::crs::CrsName;
    use skylod::pipeline::batch::{Plan, Targets};

    let parse = |flag: &str, text: &str| {
        CrsName::parse(text)
            .ok_or_else(|| ReprojectError::UnknownCrs(text.to_string()))
            .with_context(|| flag.to_string())
    };
    let target = parse("-t", &args.target)?;
    let source = args.source.as_deref().map(|s| parse("-s", s)).transpose()?;
    // Both CRSs known to PROJ before any file is touched (usage error otherwise).
    skylod::model::crs::crs_info(target.horizontal).context("-t")?;
    if let Some(s) = source {
        skylod::model::crs::crs_info(s.horizontal).context("-s")?;
    }
    let shard = args.shard.resolve()?;
    let citygml = Some(skylod::export::Format::CityGml);
    let (plan, _) = skylod::pipeline::batch::plan(&inputs, &args.output, citygml)?;
    let wopts = WriteOptions {
        overwrite: args.overwrite,
        protect: skylod::io::Protected::new(&args.inputs),
        keep_envelopes: true,
        ..Default::default()
    };
    // Every target is checked before any work; a merge reprojects each input into a staging
    // directory, then merges them.
    let (
        Targets {
            todo,
            staging,
            mirror,
            write_opts,
            ..
        },
        refused,
    ) = crate::outputs::targets(
        &plan,
        &args.inputs,
        &wopts,
        shard,
        "reproject",
        false,
        |e| {
            crate::log::error!("{e}");
        },
    )?;
    let mut failed = refused;
    let total = todo.len() + refused;
    let target_name = args.output.as_path();
    let (mut parts, mut names) = (Vec::new(), Vec::new());
    for (k, out) in &todo {
        let input = &args.inputs[*k];
        if mirror {
            skylod::pipeline::batch::create_parent(out)?;
        }
        // A staged part's path means nothing to the user: the merge line follows.
        let shown = if staging.is_some() {
            target_name
        } else {
            out.as_path()
        };
        if skylod::export::is_json_file(input) {
            // CityJSON / CityJSONSeq: vertices through PROJ, the same format written.
            let (from, to) = (
                args.source.as_deref().map(Crs::parse),
                Crs::parse(&args.target),
            );
            let t = skylod::model::crs::ProjTransform;
            let r = reproject_cityjson(input, out, from.as_ref(), &to, &t, &write_opts)
                .map_err(|e| anyhow::anyhow!(crate::flags::cli_text(&e)));
            if r.is_ok() {
                parts.push(out.clone());
                names.push(input.clone());
            }
            match r {
                Ok(s) => crate::log::summary!("{}", s.line(input, shown)),
                Err(e) => {
                    crate::log::error!("{}: {e}", skylod::model::shown(input));
                    failed += 1;
                }
            }
            continue;
        }
        match reproject_file(input, out, source, target, &write_opts) {
            Ok(s) => {
                parts.push(out.clone());
                names.push(input.clone());
                crate::log::summary!("{}", s.line(input, shown));
                for w in &s.rewrite.warnings {
                    crate::log::warning!("warning: {}: {w}", skylod::model::shown(input));
                }
            }
            Err(e) => {
                crate::log::error!("{}: {e}", skylod::model::shown(input));
                failed += 1;
            }
        }
    }
    if let (Some(st), Plan::Merge(t)) = (&staging, &plan) {
        let to = (t.as_path(), skylod::export::Format::CityGml);
        let (merged, said) =
            skylod::pipeline::batch::merge_parts(&parts, &names, to, st, &wopts, total);
        crate::outputs::say(said);
        if !merged {
            failed = total;
        }
    }
    if failed > 0 {
        crate::log::summary!("{failed} of {total} input(s) failed");
        Ok(Outcome::SomeFailed)
    } else {
        Ok(Outcome::Ok)
    }
}
