//! The library's errors and warnings in the words of the command line: each error says what
//! is wrong in the library's terms (its `Display` names no flag); this module adds the flag
//! that fixes it (`--poi-crs`, `--source-crs`, `--allow-mixed-crs`, `--overwrite`, `--poi`,
//! `--shard`, `--shards`, `--weather`, `--lat`/`--lon`, `-o`, `--format`, `--no-lod2`).

use skylod::export::UnknownFormat;
use skylod::io::citygml::WriteError;
use skylod::io::TargetError;
use skylod::lod::poi::RegionError;
use skylod::lod::poi::TrustError;
use skylod::lod::BoundError;
use skylod::model::crs::FrameWarning;
use skylod::pipeline::batch::ConvertError;
use skylod::pipeline::batch::PlanError;
use skylod::pipeline::batch::SynthFilesError;
use skylod::pipeline::batch::{LevelsError, LevelsTargetError};
use skylod::pipeline::batch::{Setting, ShardError, ENV_VARS};
use skylod::pipeline::session::Error;
use skylod::pipeline::session::SiteError;
use skylod::pipeline::AttributesError;
use skylod::pipeline::PoiCrsError;
use std::error::Error as StdError;

/// The text of `e` with the CLI's flags named where the library has a flag's equivalent
/// (one cause of a chain: [`crate::io::message::chain_message`] joins them).
pub(crate) fn cli_text(e: &(dyn StdError + 'static)) -> String {
    // A full disk in plain words, as the library's file errors say it.
    (TEXTS.iter().find_map(|text| text(e))).unwrap_or_else(|| skylod::io::plain_text(e))
}

/// The wording of one kind of error, `None` for an error of another kind (or a variant
/// that keeps the library's words).
type Text = fn(&(dyn StdError + 'static)) -> Option<String>;

/// Every kind of error with words of its own, each with its wording (the kinds are
/// distinct types: at most one applies).
const TEXTS: [Text; 14] = [
    |e| e.downcast_ref().map(library),
    |e| e.downcast_ref().map(shard_text),
    |e| e.downcast_ref().map(plan),
    |e| e.downcast_ref().map(levels_target),
    |e| e.downcast_ref().map(bound),
    |e| e.downcast_ref().map(trust),
    |e| e.downcast_ref().map(write),
    |e| match e.downcast_ref() {
        Some(AttributesError::Target(t)) => Some(cli_text(t)),
        _ => None,
    },
    |e| match e.downcast_ref() {
        Some(ConvertError::Write(w)) => Some(write(w)),
        _ => None,
    },
    |e| match e.downcast_ref() {
        Some(SynthFilesError::Write(w)) => Some(write(w)),
        _ => None,
    },
    |e| match e.downcast_ref() {
        Some(RegionError::DuplicateId(id)) => Some(format!(
            "POI id {id:?} is given twice (a region POI and a --poi/--pois one?)"
        )),
        _ => None,
    },
    |e| match e.downcast_ref() {
        Some(LevelsError::Options { first, other }) => Some(format!(
            "{} and {} were made with different options (rays, seed, threshold, roof tolerance, \
             angle, thickness or --no-lod2)",
            first.display(),
            other.display()
        )),
        _ => None,
    },
    |e| {
        let text = e.downcast_ref::<UnknownFormat>()?.to_string();
        let named = "give --format citygml|obj|cityjson|cityjsonseq|3dtiles";
        Some(text.replace("give the format", named))
    },
    |e| match e.downcast_ref() {
        Some(TargetError::Exists(p)) => {
            Some(format!("{}: output exists (use --overwrite)", p.display()))
        }
        _ => None,
    },
];

/// The library's one error: its sub-errors with a flag.
fn library(e: &Error) -> String {
    match e {
        Error::Trust(t) => trust(t),
        Error::PoiCrs(e) => poi_crs(e),
        Error::Write(w) => write(w),
        Error::Bound(b) => bound(b),
        e => e.to_string(),
    }
}

/// An output layout error in the words of `-o DIR` and `-o FILE`.
fn plan(e: &PlanError) -> String {
    match e {
        PlanError::NotADirectory { output, inputs } => format!(
            "{}: is a file; {inputs} inputs are written to a directory (-o DIR) or merged into \
             one CityGML file (-o FILE.gml)",
            output.display()
        ),
        PlanError::NotMergeable { format, inputs } => format!(
            "{inputs} inputs cannot be merged into one {format} file by this command: give -o \
             DIR for one output per input, or a CityGML name (.gml, .xml, .gz) to merge"
        ),
        PlanError::ShardedMerge { shard, target } => format!(
            "shard {shard} cannot merge into {}: a merge needs every input (give -o DIR to the \
             shards, then merge their outputs with `skylod convert DIR -o FILE`)",
            target.display()
        ),
        PlanError::Format(e) => cli_text(e),
        PlanError::Target(w) => write(w),
        PlanError::Merge(e) => cli_text(e),
        e => e.to_string(),
    }
}

/// A shard's levels file target in the words of `-o` and `--reduce`.
fn levels_target(e: &LevelsTargetError) -> String {
    match e {
        LevelsTargetError::NotLevels { shard } => format!(
            "shard {shard} writes its levels, not a model: -o names its levels file (e.g. -o \
             levels-{}.jsonl); then `skylod lod INPUTS -o OUT --reduce levels-*.jsonl` writes \
             the model",
            shard.index()
        ),
        LevelsTargetError::Target(w) => write(w),
        e => e.to_string(),
    }
}

/// A site error in the words of `--lat` and `--lon`, for `cmd` (e.g. `sun-hours`).
pub(crate) fn site_text(e: &SiteError, cmd: &str) -> String {
    match e {
        SiteError::OutOfRange { lat, lon } => {
            format!("--lat must be in -90..90 and --lon in -180..180 (got {lat}, {lon})")
        }
        SiteError::Half => {
            format!("{cmd} needs both --lat and --lon of the site, in degrees (WGS84)")
        }
        e => format!("{cmd} needs the site's --lat and --lon (WGS84 degrees): {e}"),
    }
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
        TrustError::LatLonSwapped { message, crs } => format!(
            "{message} the order is probably swapped: {crs}'s axis order is latitude, longitude \
             (--poi LAT,LON,H; CSV columns lat, lon), not longitude, latitude"
        ),
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
        WriteError::NotOnGlobe { crs, .. } if crs.is_empty() => {
            format!("{w} (give it with --source-crs EPSG:n)")
        }
        w => w.to_string(),
    }
}

fn bound(b: &BoundError) -> String {
    match b {
        BoundError::NoWeather => format!("{b} (--weather)"),
        b => b.to_string(),
    }
}

/// A shard setting as the flags give it.
fn setting(s: &Setting) -> String {
    match s {
        Setting::Given(s) => format!("--shard {s}"),
        Setting::Count(n) => format!("--shards {n}"),
        s => s.to_string(),
    }
}

/// A shard error in the words of `--shard` and `--shards`.
pub(crate) fn shard_text(e: &ShardError) -> String {
    const CONFLICT: &str = "conflicting shard settings";
    match e {
        ShardError::Syntax(s) => format!("--shard {s:?}: expected I/N with 0 <= I < N (e.g. 0/4)"),
        ShardError::OutOfRange { from, index, count } => format!(
            "{}: shard index {index} is not below the shard count {count}",
            setting(from)
        ),
        ShardError::ZeroCount(from) => {
            format!("{}: the shard count must be at least 1", setting(from))
        }
        ShardError::NoCount(from) => {
            format!("{from} gives the shard index but not the count: add --shards N")
        }
        ShardError::CountDisagrees { env, given } => {
            format!("{CONFLICT}: SLURM_ARRAY_TASK_COUNT={env} but --shards {given}")
        }
        ShardError::CountWithoutIndex(n) => format!(
            "{CONFLICT}: --shards {n} without an index: give --shard I/{n}, or run under a \
             scheduler that sets one of {}",
            ENV_VARS.join(", ")
        ),
        ShardError::ShardCountDisagrees { shard, count } => {
            format!("{CONFLICT}: --shard {shard} but --shards {count}")
        }
        ShardError::EnvDisagrees { shard, env, says } => format!(
            "{CONFLICT}: --shard {shard} but the scheduler's environment ({env}) says {says}"
        ),
        ShardError::EnvUnusable { shard: s, error } => format!(
            "{CONFLICT}: --shard {s} but the scheduler's environment is not usable: {}",
            shard_text(error)
        ),
        e => e.to_string(),
    }
}

/// The frame's warnings `said` as the command line says them: the one that is the
/// structured warning `fw` in its words ([`frame_warning_text`]), the others as they are.
pub(crate) fn frame_said(said: &[String], fw: Option<&FrameWarning>) -> Vec<String> {
    let frame = fw.map(|w| (w.to_string(), frame_warning_text(w)));
    (said.iter())
        .map(|w| match &frame {
            Some((lib, cli)) if lib == w => cli.clone(),
            _ => w.clone(),
        })
        .collect()
}

/// The frame's warning with the flag that fixes it.
pub(crate) fn frame_warning_text(w: &FrameWarning) -> String {
    let metres = "coordinates are taken as metres";
    match w {
        FrameWarning::NoCrs => {
            format!("the input names no CRS (srsName): {metres} (give --source-crs)")
        }
        FrameWarning::UnknownCrs(n) => {
            format!("CRS {n:?} is not one skylod knows: {metres} (give --source-crs EPSG:n)")
        }
        FrameWarning::NotDegrees(n) => format!(
            "CRS {n:?} is geographic but the coordinates are not degrees: taken as metres \
             (give --source-crs)"
        ),
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
        let p = skylod::Error::from(PoiCrsError::UnknownModelCrs {
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
        let s = "5/4".parse::<skylod::pipeline::batch::Shard>().unwrap_err();
        assert!(!s.to_string().contains("--"), "{s}");
        assert_eq!(
            cli_text(&s),
            "--shard 5/4: shard index 5 is not below the shard count 4"
        );
        let s = skylod::pipeline::batch::Shard::resolve(None, Some(0), |_| None).unwrap_err();
        assert_eq!(
            shard_text(&s),
            "--shards 0: the shard count must be at least 1"
        );
        let w = FrameWarning::UnknownCrs("X".into());
        assert!(!w.to_string().contains("--"), "{w}");
        assert!(frame_warning_text(&w).ends_with("(give --source-crs EPSG:n)"));
        let d = RegionError::DuplicateId("p1".into());
        assert!(!d.to_string().contains("--"), "{d}");
        assert!(cli_text(&d).ends_with("(a region POI and a --poi/--pois one?)"));
        assert!(cli_text(&BoundError::NoWeather).ends_with("weather year (--weather)"));
        let p = PlanError::NotADirectory {
            output: "out.gml".into(),
            inputs: 3,
        };
        assert!(!p.to_string().contains("-o"), "{p}");
        assert!(cli_text(&p).contains("(-o DIR)"));
        let p = PlanError::Target(WriteError::Exists("o.gml".into()));
        assert_eq!(cli_text(&p), "o.gml: output exists (use --overwrite)");
        let h = SiteError::Half;
        assert!(!h.to_string().contains("--"), "{h}");
        let s = "1/4".parse().unwrap();
        let l = LevelsTargetError::NotLevels { shard: s };
        assert!(!l.to_string().contains("-o"), "{l}");
        assert!(cli_text(&l).contains("(e.g. -o levels-1.jsonl)"));
        assert!(site_text(&h, "sun-hours").starts_with("sun-hours needs both --lat and --lon"));
    }
}
