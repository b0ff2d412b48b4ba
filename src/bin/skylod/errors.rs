//! Library errors in the command line's words: the library says what is wrong in its own
//! terms, the CLI adds the flag that fixes it (`--poi-crs`, `--source-crs`,
//! `--allow-mixed-crs`, `--overwrite`).

use skylod::citygml::WriteError;
use skylod::io::TargetError;
use skylod::pipeline::{PipelineError, PoiCrsError};
use skylod::poi::checks::TrustError;
use skylod::Error;
use std::error::Error as StdError;

/// The text of `e` with the CLI's flags named where the library has a flag's equivalent.
pub fn cli_text(e: &(dyn StdError + 'static)) -> String {
    if let Some(e) = e.downcast_ref::<Error>() {
        return match e {
            Error::Trust(t) => trust(t),
            Error::PoiCrs(e) => poi_crs(e),
            Error::Write(w) => write(w),
            e => e.to_string(),
        };
    }
    if let Some(e) = e.downcast_ref::<PipelineError>() {
        return match e {
            PipelineError::Trust(t) => trust(t),
            PipelineError::PoiCrs(e) => poi_crs(e),
            e => e.to_string(),
        };
    }
    if let Some(t) = e.downcast_ref::<TrustError>() {
        return trust(t);
    }
    if let Some(w) = e.downcast_ref::<WriteError>() {
        return write(w);
    }
    if let Some(TargetError::Exists(p)) = e.downcast_ref::<TargetError>() {
        return format!("{}: output exists (use --overwrite)", p.display());
    }
    // A full disk in plain words, as the library's file errors say it.
    if let Some(io) = e.downcast_ref::<std::io::Error>() {
        return skylod::io::describe_io(io);
    }
    e.to_string()
}

fn poi_crs(e: &PoiCrsError) -> String {
    match e {
        PoiCrsError::Convert { from, source } => format!("--poi-crs {from}: {source}"),
        PoiCrsError::UnknownModelCrs { from, model } => format!(
            "--poi-crs {from}: the model's CRS ({model}) is not known, so POIs cannot be \
             converted to it (give --source-crs)"
        ),
        e => e.to_string(),
    }
}

fn trust(t: &TrustError) -> String {
    match t {
        TrustError::PoiOutside(far) => far.message("--poi-crs EPSG:4326"),
        TrustError::MixedCrs { listing } => format!(
            "the inputs are in different CRSs and would be merged into one scene: {listing}. \
             Reproject them to one CRS first, or give --allow-mixed-crs if the names differ \
             but the CRS is the same"
        ),
        t => t.to_string(),
    }
}

fn write(w: &WriteError) -> String {
    match w {
        WriteError::Exists(p) => format!("{}: output exists (use --overwrite)", p.display()),
        w => w.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flags_named_for_the_library_s_errors() {
        let w = WriteError::Exists("out.gml".into());
        assert!(!w.to_string().contains("--"));
        assert_eq!(cli_text(&w), "out.gml: output exists (use --overwrite)");
        let e = Error::from(WriteError::Exists("o.gml".into()));
        assert!(cli_text(&e).ends_with("(use --overwrite)"));
        let p = PipelineError::from(PoiCrsError::UnknownModelCrs {
            from: "EPSG:4326".into(),
            model: "none".into(),
        });
        assert!(cli_text(&p).starts_with("--poi-crs EPSG:4326: "));
        assert!(cli_text(&p).ends_with("(give --source-crs)"));
        let m = TrustError::MixedCrs {
            listing: "a (EPSG:1); b (EPSG:2)".into(),
        };
        assert!(cli_text(&m).contains("--allow-mixed-crs"));
        assert!(!m.to_string().contains("--"));
    }
}
