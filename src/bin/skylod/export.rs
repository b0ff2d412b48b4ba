//! Output formats for `convert`, `rough` and `lod`: `--format` and the OBJ / CityJSON / CityJSONSeq writers with their summary line.

use skylod::citygml::write::WriteOptions;
use skylod::export::{Content, Format};
use skylod::model::CityModel;
use std::path::Path;

/// `--format` values.
pub fn parse_format(s: &str) -> Result<Format, String> {
    s.parse()
}

/// Write file `file` of `model` in `format` (not CityGML) and print one summary line.
pub fn write(
    format: Format,
    model: &CityModel,
    file: usize,
    content: Content<'_>,
    out: &Path,
    wopts: &WriteOptions,
) -> anyhow::Result<()> {
    let s = skylod::export::write(format, model, file, content, out, wopts)?;
    crate::log::summary!("{}", describe(format, model, file, &s, out));
    Ok(())
}

/// The summary line of an OBJ / CityJSON / CityJSONSeq output.
pub fn describe(
    format: Format,
    model: &CityModel,
    file: usize,
    s: &skylod::export::ExportSummary,
    out: &Path,
) -> String {
    let input = model
        .files
        .get(file)
        .map(|f| f.path.display().to_string())
        .unwrap_or_default();
    let what = match format {
        Format::Obj => format!(
            "{} objects, {} polygons as {} triangles, {} vertices",
            s.objects, s.polygons, s.triangles, s.vertices
        ),
        Format::CityJsonSeq => format!(
            "{} city objects in {} features, {} surfaces, {} vertices",
            s.objects, s.features, s.polygons, s.vertices
        ),
        _ => format!(
            "{} city objects, {} surfaces, {} vertices",
            s.objects, s.polygons, s.vertices
        ),
    };
    format!(
        "{input} -> {} ({format}): {what}, {} bytes",
        out.display(),
        s.bytes
    )
}
