//! One module per subcommand: its arguments (the shared groups of [`crate::args`]
//! flattened) and its `run`; below, what their messages and tables share.

use crate::log::warning;
use anyhow::Context;
use skylod::export::report::{Document, TextContext};
use skylod::lod::poi::Poi;
use skylod::lod::poi::PoiFlag;
use std::io::Write;

pub mod completions;
pub mod convert;
pub mod evaluate;
pub mod filter_lods;
pub mod fisheye;
pub mod horizon;
pub mod irradiance;
pub mod lod;
pub mod reproject;
pub mod rough;
pub mod stats;
pub mod subset;
pub mod sun_hours;
pub mod svf;
pub mod synth;
pub mod upgrade;

/// Context helper for writing to stdout.
pub fn out_err<T>(r: std::io::Result<T>) -> anyhow::Result<T> {
    r.context("writing to standard output")
}

/// A tracing command's document on standard output: its JSON with `json`, else its table,
/// with its summary lines on stderr.
pub fn emit(doc: &impl Document, json: bool, cx: &TextContext) -> anyhow::Result<()> {
    let mut out = std::io::stdout().lock();
    if json {
        out_err(writeln!(out, "{}", serde_json::to_string_pretty(doc)?))?;
    } else {
        out_err(doc.write_table(&mut out, cx))?;
        for line in doc.summary(cx) {
            crate::log::summary!("{line}");
        }
    }
    Ok(())
}

/// Print each POI's flags as a warning on stderr.
pub fn warn_flags(pois: &[Poi], flags: &[Vec<PoiFlag>]) {
    for (p, fl) in pois.iter().zip(flags) {
        for f in fl {
            warning!("warning: {}", f.message(p));
        }
    }
}
