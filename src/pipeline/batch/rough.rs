//! One input of `rough`: read, generalised in a local metric frame (thickness and angles in
//! metres), written back in its CRS with every asset at level 1 — CityGML through the
//! mixed-LoD writer (a CityJSON source: its CityJSON output converted), OBJ or CityJSON
//! through [`crate::export`]. What [`Batch::run_each`](super::run::Batch::run_each)'s callers
//! run on each input of a rough batch.

use super::run::Done;
use crate::export::citygml_via_cityjson::{is_cityjson_source, write_citygml_levels};
use crate::export::{Content, Format};
use crate::io::citygml::write::WriteOptions;
use crate::io::citygml::{read_file, WriteError};
use crate::lod::mixed::write_mixed;
use crate::lod::rough::{rough_model, rough_to_source, RoughOptions};
use crate::model::crs::{model_crs, Crs, FrameWarning, LocalFrame};
use std::path::Path;

/// How [`rough_file`] generalises and writes.
#[derive(Debug, Clone, Copy)]
pub struct RoughFile<'a> {
    /// The format written.
    pub format: Format,
    /// The rough model's options.
    pub rough: &'a RoughOptions,
    /// The writer's options.
    pub write: &'a WriteOptions,
    /// The CRS the input is in, whatever it names (`None`: its `srsName`).
    pub source_crs: Option<&'a Crs>,
}

/// The rough model of `input` written to `out`: its [`Done`] (its line, warnings, polygons in
/// and out; polygons not counted for OBJ and CityJSON). `warned` hears the frame's warning
/// (no CRS, an unknown one: coordinates taken as metres) as soon as the frame is chosen.
///
/// # Errors
/// The input cannot be read, the output cannot be written.
pub fn rough_file(
    input: &Path,
    out: &Path,
    o: &RoughFile<'_>,
    warned: &dyn Fn(&FrameWarning),
) -> Result<Done, WriteError> {
    let mut model = read_file(input)?;
    if let Some(c) = o.source_crs {
        for f in &mut model.files {
            f.srs_name = Some(c.name.clone());
        }
    }
    let (frame, warning) = LocalFrame::new(&model_crs(&model, o.source_crs), &model.bbox());
    if let Some(w) = warning {
        warned(&w);
    }
    let local = frame.model_to_local(&model);
    let rough_local = rough_model(&local, o.rough);
    let rough = rough_to_source(&frame, &local, &model, &rough_local, None);
    let levels = vec![1u8; model.assets.len()];
    let content = Content::Levels {
        rough: &rough,
        levels: &levels,
    };
    let warnings = model.warnings.len();
    if o.format != Format::CityGml {
        let chunks = crate::export::Chunks::model(&model, 0, content);
        let (s, _) = crate::export::write(o.format, &chunks, out, o.write)?;
        let input = model.files.first().map_or(Path::new(""), |f| &f.path);
        let line = Some(s.describe(o.format, input, out));
        let polygons = (0, 0);
        return Ok(Done {
            line,
            warnings,
            polygons,
        });
    }
    if is_cityjson_source(&model, 0) {
        // A CityJSON source has no XML to copy: its CityJSON output converted to CityGML 2.0.
        let s = write_citygml_levels(&model, 0, content, out, o.write)?;
        let read = model.assets.iter().map(|a| a.detail_polygons().len()).sum();
        let line = Some(s.describe(input, out));
        let polygons = (read, s.polygons);
        return Ok(Done {
            line,
            warnings,
            polygons,
        });
    }
    let s = write_mixed((&model, 0), &rough, &levels, out, o.write)?;
    let line = Some(s.rough_line(input, out));
    let polygons = (s.polygons_in, s.polygons_out);
    Ok(Done {
        line,
        warnings,
        polygons,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Mutex;

    fn run(input: &Path, name: &str, format: Format, crs: Option<&Crs>) -> (Done, Vec<u8>, usize) {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join(name);
        let (rough, write) = (RoughOptions::default(), WriteOptions::default());
        let o = RoughFile {
            format,
            rough: &rough,
            write: &write,
            source_crs: crs,
        };
        let heard = Mutex::new(0);
        let d = rough_file(input, &out, &o, &|_| *heard.lock().unwrap() += 1).unwrap();
        (d, std::fs::read(&out).unwrap(), heard.into_inner().unwrap())
    }

    #[test]
    fn a_rough_model_has_fewer_polygons_in_every_format() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
        let gml = dir.join("synth-small.gml");
        let (d, bytes, _) = run(&gml, "r.gml", Format::CityGml, None);
        assert!(d.polygons.1 < d.polygons.0, "{:?}", d.polygons);
        assert!(d.line.unwrap().contains("r.gml"));
        assert!(bytes.len() < std::fs::metadata(&gml).unwrap().len() as usize);
        let (d, bytes, _) = run(&gml, "r.obj", Format::Obj, None);
        assert_eq!(d.polygons, (0, 0));
        assert!(d.line.unwrap().contains("(obj)"));
        assert!(String::from_utf8_lossy(&bytes).contains("\nf "));
        let json = dir.join("cityjson/cjio-dummy.city.json");
        let (d, bytes, _) = run(&json, "r.gml", Format::CityGml, None);
        assert!(String::from_utf8_lossy(&bytes).contains("CityModel"));
        assert!(d.polygons.1 <= d.polygons.0, "{:?}", d.polygons);
    }

    #[test]
    fn the_source_crs_replaces_an_unknown_one_and_its_frame_warning() {
        let fixture = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/synth-small.gml");
        let text = std::fs::read_to_string(fixture).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let gml = dir.path().join("unknown-crs.gml");
        std::fs::write(&gml, text.replace("EPSG:25831", "local-grid")).unwrap();
        let (_, plain, heard) = run(&gml, "r.gml", Format::CityGml, None);
        assert_eq!(heard, 1, "an unknown CRS: coordinates taken as metres");
        let crs = Crs::parse_named("EPSG:25831").unwrap();
        let (_, given, heard) = run(&gml, "r.gml", Format::CityGml, Some(&crs));
        assert_eq!(heard, 0);
        assert!(!plain.is_empty() && !given.is_empty());
    }
}
