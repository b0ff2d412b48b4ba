//! `stats` and `convert` (to OBJ, CityJSON, CityJSONSeq) on a large file: read a chunk of whole top-level members at a time
//! ([`skylod::citygml::read::stream`]), the same output as from the whole model, memory that
//! follows the chunk. Where the stream declines, the commands read the file whole.

use crate::args::crs::SourceCrsArgs;
use crate::log::summary;
use crate::outputs::Done;
use skylod::citygml::read::{stream, Streamed};
use skylod::citygml::write::WriteOptions;
use skylod::citygml::ReadOptions;
use skylod::export::Format;
use skylod::model::Warning;
use skylod::output::stats::Stats;
use skylod::runtime::progress::{Progress, Stage};
use std::path::Path;

/// The stats and warnings of `path` read a chunk at a time (the whole read's, see
/// [`skylod::citygml::read::stream`]); `None` where the stream declines. Warnings are kept
/// for `--verbose` only (else counted).
pub fn stats(
    path: &Path,
    crs: &SourceCrsArgs,
    verbose: bool,
    chunk: u64,
    passed: &(dyn Fn(u64) + Sync),
) -> Option<(Stats, Vec<Warning>)> {
    let mut total = Stats::default();
    let mut warnings = Vec::new();
    let end = stream(path, &ReadOptions::default(), chunk, passed, |mut c| {
        total.add(&Stats::of(&c.model));
        if verbose {
            warnings.append(&mut c.model.warnings);
        }
        Ok::<(), ()>(())
    })
    .ok()?;
    let sum = match end {
        Streamed::Done(sum) => sum,
        Streamed::Declined(why) => {
            crate::log::info!("{}: read whole ({why})", skylod::model::shown(path));
            return None;
        }
    };
    sum.patch_warnings(&mut warnings);
    total.warnings += sum.trailing.len();
    total.citygml_version = sum.version.map(|v| v.to_string());
    total.srs_name = match &crs.source_crs {
        Some(c) => Some(c.name.clone()),
        None => sum.srs_name,
    };
    Some((total, warnings))
}

/// `input` written as OBJ, CityJSON or CityJSONSeq to `out` from a streamed read
/// ([`skylod::export::write_streamed`]: the same bytes, memory that follows a chunk);
/// `Ok(None)` where the stream declines. The bar's bytes move through every pass.
pub fn export(
    format: Format,
    input: &Path,
    out: &Path,
    chunk: u64,
    opts: &WriteOptions,
    mirror: bool,
    progress: &crate::log::Reporter,
) -> anyhow::Result<Option<Done>> {
    // the bar's share of each pass: OBJ origin 1/2, objects 1/2; CityJSONSeq plan 1/2,
    // buildings 1/2; CityJSON plan, vertex uses and objects 1/3 each (the passes over the
    // objects outside buildings, when a file has them, are not counted)
    let thirds = format == Format::CityJson;
    let passed = |pass, n: u64| {
        let share = match (thirds, pass) {
            (false, 0) => n.div_ceil(2),
            (false, 1) => n / 2,
            (true, 0) => n.div_ceil(3),
            (true, 1 | 3) => n / 3,
            _ => 0,
        };
        if share > 0 {
            progress.advance(Stage::Read, 0, share, None);
        }
    };
    if mirror {
        crate::outputs::create_parent(out)?;
    }
    let ropts = ReadOptions::default();
    if format == Format::CityGml {
        return document(input, out, chunk, opts, &passed);
    }
    let Some((s, sum)) =
        skylod::export::write_streamed(format, input, &ropts, chunk, &passed, out, opts)
            .map_err(|e| anyhow::anyhow!("writing {}: {e}", out.display()))?
    else {
        crate::log::info!(
            "{}: read whole (the stream declined)",
            skylod::model::shown(input)
        );
        return Ok(None);
    };
    summary!("{}", s.describe(format, input, out));
    Ok(Some(Done {
        line: None,
        warnings: sum.warnings,
        polygons: (0, 0),
    }))
}

/// `input` written back as CityGML to `out` (envelopes recomputed) from two streamed reads
/// ([`skylod::citygml::write::write_document_streamed`]: the same bytes as from the whole
/// read); `Ok(None)` where the stream declines.
fn document(
    input: &Path,
    out: &Path,
    chunk: u64,
    opts: &WriteOptions,
    passed: &dyn Fn(usize, u64),
) -> anyhow::Result<Option<Done>> {
    let ropts = ReadOptions::default();
    let r =
        skylod::citygml::write::write_document_streamed(input, &ropts, chunk, passed, out, opts)?;
    let Some(d) = r else {
        crate::log::info!(
            "{}: read whole (the stream declined)",
            skylod::model::shown(input)
        );
        return Ok(None);
    };
    Ok(Some(Done {
        line: Some(format!(
            "{} -> {}: {}, {} envelope(s) recomputed, {} warning(s)",
            skylod::model::shown(input),
            out.display(),
            crate::outputs::size_note(out, d.summary.bytes),
            d.summary.edits,
            d.stream.warnings
        )),
        warnings: d.stream.warnings,
        polygons: (d.polygons, d.polygons),
    }))
}
