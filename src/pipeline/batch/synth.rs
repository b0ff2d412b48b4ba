//! The files of `synth`: a procedural district ([`crate::model::synth::generate`]) written
//! to its output and its facade POIs to a CSV beside it, both targets checked before either
//! is written, each written atomically.

use crate::io::citygml::write::{atomic_write, check_target, is_stdout, WriteOptions};
use crate::io::citygml::WriteError;
use crate::model::synth::{generate, pois, pois_path, write_pois_csv, SynthOptions, SynthSummary};
use std::path::{Path, PathBuf};

/// Why [`write_synth`] wrote nothing or not all.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SynthFilesError {
    /// The model and the POI CSV were both asked for on standard output.
    #[error("the model and the POIs cannot both go to standard output")]
    BothStdout,
    /// A target was refused or could not be written (named).
    #[error(transparent)]
    Write(#[from] WriteError),
}

/// What [`write_synth`] wrote.
#[derive(Debug, Clone)]
pub struct SynthFiles {
    /// The counts of the model written.
    pub summary: SynthSummary,
    /// The model's bytes on disk (compressed when it is).
    pub bytes: u64,
    /// The number of POIs.
    pub pois: usize,
    /// Where the POIs were written (`None`: not written).
    pub csv: Option<PathBuf>,
}

impl SynthFiles {
    /// The line that says what was written to `output` in `seconds` (the POIs not said).
    pub fn line(&self, output: &Path, seconds: f64) -> String {
        let s = &self.summary;
        let gz = output.extension().is_some_and(|e| e == "gz");
        format!(
            "{}: {} buildings, {} polygons, {} windows, {} installations, {:.1} MB{} in {seconds:.2} s",
            output.display(),
            s.buildings,
            s.polygons,
            s.windows,
            s.installations_total(),
            self.bytes as f64 / 1e6,
            if gz { " (compressed)" } else { "" },
        )
    }
}

/// Write the district of `opts` to `output` (`-`: standard output) and its POIs to
/// `pois_output`, by default beside the output (`<name>.pois.csv`; none when the output is
/// standard output); without `overwrite`, existing files are refused before anything is
/// written.
///
/// # Errors
/// [`SynthFilesError`].
pub fn write_synth(
    opts: &SynthOptions,
    output: &Path,
    pois_output: Option<&Path>,
    overwrite: bool,
) -> Result<SynthFiles, SynthFilesError> {
    let wopts = WriteOptions {
        overwrite,
        ..Default::default()
    };
    let csv = match pois_output {
        Some(p) => Some(p.to_path_buf()),
        None if is_stdout(output) => None,
        None => Some(pois_path(output)),
    };
    if csv.as_deref().is_some_and(is_stdout) && is_stdout(output) {
        return Err(SynthFilesError::BothStdout);
    }
    check_target(output, &wopts, std::iter::empty())?;
    if let Some(csv) = &csv {
        check_target(csv, &wopts, std::iter::empty())?;
    }
    let io = |file: &Path, e: crate::model::synth::SynthError| WriteError::Io {
        file: file.to_path_buf(),
        source: std::io::Error::other(e.to_string()),
    };
    let mut summary = SynthSummary::default();
    atomic_write(output, |w| {
        summary = generate(opts, w).map_err(|e| io(output, e))?;
        Ok(summary.bytes)
    })?;
    let points = pois(opts);
    if let Some(csv) = &csv {
        atomic_write(csv, |w| {
            write_pois_csv(&points, w).map_err(|e| io(csv, e))?;
            Ok(0)
        })?;
    }
    let bytes = std::fs::metadata(output).map_or(summary.bytes, |m| m.len());
    Ok(SynthFiles {
        summary,
        bytes,
        pois: points.len(),
        csv,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::synth::Preset;

    #[test]
    fn model_and_pois_written_beside_it_targets_checked_first() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("d.gml");
        let opts = Preset::Small.defaults();
        let w = write_synth(&opts, &out, None, false).unwrap();
        let csv = w.csv.clone().unwrap();
        assert_eq!(csv, pois_path(&out));
        assert!(w.summary.buildings > 0 && w.pois > 0);
        let text = std::fs::read_to_string(&csv).unwrap();
        assert_eq!(
            text.lines().count(),
            w.pois + 1,
            "a header and a line per POI"
        );
        assert_eq!(w.bytes, std::fs::metadata(&out).unwrap().len());
        let line = w.line(&out, 0.5);
        assert!(
            line.contains(&format!("{} buildings", w.summary.buildings)),
            "{line}"
        );
        assert!(line.ends_with(" in 0.50 s"), "{line}");
        // Both exist: refused before either is written (the CSV elsewhere is not made).
        let other = dir.path().join("other.csv");
        let e = write_synth(&opts, &out, Some(&other), false).unwrap_err();
        assert!(
            matches!(e, SynthFilesError::Write(WriteError::Exists(_))),
            "{e}"
        );
        assert!(!other.exists());
        let e = write_synth(&opts, &out, Some(&out.with_extension("csv")), true);
        assert!(e.is_ok(), "overwrite");
        let dash = Path::new("-");
        let e = write_synth(&opts, dash, Some(dash), false).unwrap_err();
        assert!(matches!(e, SynthFilesError::BothStdout));
        let gz = w.line(Path::new("d.gml.gz"), 1.0);
        assert!(gz.contains(" MB (compressed) in "), "{gz}");
    }
}
