//! `stats` of several inputs: each file's counts ([`file_stats`], in parallel on the current
//! rayon pool), their total, and what to tell the user in input order (each file's warnings
//! when asked for, each failure, the closing line of a batch) — never printed.

use super::convert::{chunk_for, file_stats, StatsRead};
use super::run::{summary_line, Said};
use crate::export::report::stats::{FileStats, Stats, StatsOutput};
use crate::model::crs::Crs;
use crate::model::runtime::progress::{Progress, Stage};
use rayon::prelude::*;
use std::path::PathBuf;
use std::time::Instant;

/// How [`stats_files`] reads.
#[derive(Debug, Clone, Copy)]
pub struct StatsFiles<'a> {
    /// The CRS the inputs are in, whatever they name.
    pub source_crs: Option<&'a Crs>,
    /// The chunk large files are streamed by ([`chunk_for`]; 0: every file read whole).
    pub chunk: u64,
    /// Say every warning (`file:line:column: message`), not only their number.
    pub verbose: bool,
}

/// What [`stats_files`] found.
#[derive(Debug)]
#[non_exhaustive]
pub struct StatsRun {
    /// The document: one entry per file read, in input order, and their total.
    pub output: StatsOutput,
    /// The lines to show, in input order (the closing line last, for several inputs).
    pub said: Vec<Said>,
    /// Some input could not be read.
    pub failed: bool,
}

/// The statistics of `inputs` ([`file_stats`] each; [`Stage::Read`] of `progress` counts
/// them and their bytes; `note` hears why a file meant to be streamed was read whole). One
/// input: its model and warnings are left to the end of the process, not handed back to the
/// allocator piece by piece (a large share of a small file's run); a batch frees each model
/// after its counts, so memory stays that of the files being read. `started`: the start of
/// the run, for the closing line.
pub fn stats_files(
    inputs: &[PathBuf],
    o: &StatsFiles<'_>,
    progress: &dyn Progress,
    note: &(dyn Fn(String) + Sync),
    started: Instant,
) -> StatsRun {
    let single = inputs.len() == 1;
    let bytes = inputs
        .iter()
        .filter_map(|p| p.metadata().ok())
        .map(|m| m.len());
    progress.start(Stage::Read, inputs.len() as u64, bytes.sum());
    let results: Vec<_> = (inputs.par_iter())
        .map(|p| {
            let chunk = (chunk_for(p, o.chunk), o.verbose);
            let r = file_stats(p, o.source_crs, chunk, progress, note, single);
            progress.advance(Stage::Read, 1, 0, None);
            r
        })
        .collect();
    progress.finish(Stage::Read);
    let (mut files, mut said, mut failed) = (Vec::new(), Vec::new(), false);
    for (path, r) in inputs.iter().zip(results) {
        match r {
            Ok(StatsRead { stats, warnings }) => {
                if o.verbose {
                    said.extend(
                        warnings
                            .iter()
                            .map(|w| Said::Warning(format!("warning: {w}"))),
                    );
                }
                if single {
                    std::mem::forget(warnings);
                }
                files.push(FileStats::new(path.display().to_string(), stats));
            }
            Err(e) => {
                said.push(Said::Error(e.to_string()));
                failed = true;
            }
        }
    }
    let total = Stats::total(files.iter().map(|f| &f.stats));
    if inputs.len() > 1 {
        let (ok, warnings) = (files.len(), total.warnings);
        let line = summary_line(
            "stats",
            ok,
            inputs.len() - ok,
            warnings,
            None,
            started.elapsed(),
        );
        said.push(Said::Summary(line));
    }
    // One shape whatever the number of inputs: a pipeline never has to test for it.
    let output = StatsOutput::new(files, total);
    StatsRun {
        output,
        said,
        failed,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::runtime::progress::Silent;
    use std::path::Path;

    #[test]
    fn files_in_order_their_total_failures_and_the_closing_line() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
        let (a, b) = (
            dir.join("chimney-citygml2.gml"),
            dir.join("synth-small.gml"),
        );
        let inputs = [a.clone(), dir.join("no-such-file.gml"), b.clone()];
        let o = StatsFiles {
            source_crs: None,
            chunk: 0,
            verbose: false,
        };
        let r = stats_files(&inputs, &o, &Silent, &|_| {}, Instant::now());
        assert!(r.failed);
        let names: Vec<&str> = r.output.files.iter().map(|f| f.path.as_str()).collect();
        assert_eq!(names, [a.display().to_string(), b.display().to_string()]);
        let one = |p: &Path| file_stats(p, None, (None, false), &Silent, &|_| {}, false);
        let (sa, sb) = (one(&a).unwrap().stats, one(&b).unwrap().stats);
        assert_eq!(r.output.total, Stats::total([&sa, &sb]));
        assert_eq!(r.said.len(), 2, "{:?}", r.said);
        assert!(matches!(&r.said[0], Said::Error(e) if e.contains("no-such-file.gml")));
        assert!(matches!(&r.said[1], Said::Summary(l) if l.starts_with("stats: ")));
    }

    #[test]
    fn one_input_has_no_closing_line_and_verbose_says_each_warning() {
        let gml = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/bad");
        let Some(bad) = std::fs::read_dir(&gml)
            .unwrap()
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| {
                file_stats(p, None, (None, true), &Silent, &|_| {}, false)
                    .is_ok_and(|s| !s.warnings.is_empty())
            })
            .min()
        else {
            panic!("fixtures/bad has a file that reads with warnings");
        };
        let o = StatsFiles {
            source_crs: None,
            chunk: 0,
            verbose: true,
        };
        let run = |o: &StatsFiles<'_>| {
            stats_files(
                std::slice::from_ref(&bad),
                o,
                &Silent,
                &|_| {},
                Instant::now(),
            )
        };
        let r = run(&o);
        assert!(!r.failed);
        assert_eq!(r.said.len(), r.output.total.warnings, "{:?}", r.said);
        assert!(r
            .said
            .iter()
            .all(|s| matches!(s, Said::Warning(w) if w.starts_with("warning: "))));
        let o = StatsFiles {
            verbose: false,
            ..o
        };
        assert!(run(&o).said.is_empty());
    }
}
