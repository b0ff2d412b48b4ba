//! A `.city.json` document written as CityGML in chunks of whole city-object trees
//! ([`crate::io::cityjson::chunks`]: pass 1 the small members, the vertices and the
//! links; pass 2 the objects, a chunk's at a time): the bytes [`super::write_citygml`] writes
//! of the whole document, memory that follows the chunk and the vertices (24 bytes each).

use super::{bbox, FromCityJsonError, FromCityJsonSummary, Out};
use crate::io::cityjson::chunks::{each_object, Fail, Input, Prepared, Stop};
use crate::io::cityjson::doc::CityObject;
use crate::io::cityjson::CityJsonError as Error;
use std::io::Write;
use std::path::Path;

/// Write the document `input`, prepared ([`crate::io::cityjson::chunks::prepare`]) as
/// `p`, as CityGML 2.0 to `w`.
///
/// # Errors
/// The document is not CityJSON (a city object that does not read, a vertex index out of
/// range: the file, the object, and where the parser was for what does not read), it
/// changed since pass 1, or `w` fails.
pub(super) fn write_chunked(
    input: &Path,
    mut p: Prepared,
    w: &mut dyn Write,
) -> Result<FromCityJsonSummary, FromCityJsonError> {
    let list: Vec<[f64; 3]> = std::mem::take(&mut p.list)
        .into_iter()
        .map(|v| v.to_array())
        .collect();
    let meta = p.metadata.as_ref();
    let mut out = Out::new(w, input, meta, p.transform.as_ref());
    out.root(bbox(&list).or_else(|| meta?.extent()))?;
    if p.appearance {
        out.tally.drop("appearance (materials, textures)".into());
    }
    let templates = p.templates.as_ref();
    let mut objects: Vec<(String, CityObject)> = Vec::new();
    let r = each_object(Input::File(input), input, &p, |id, o, last| {
        match serde_json::from_str::<CityObject>(o.get()) {
            Ok(t) => objects.push((id, t)),
            Err(e) => return Err(Fail::Object(Some(id), e.to_string())),
        }
        if last.is_some() {
            out.unit(&objects, templates, &list, 0)
                .map_err(Fail::Each)?;
            objects.clear();
        }
        Ok(())
    });
    match r {
        Ok(()) => {}
        Err(Stop::Each(e)) => return Err(e),
        Err(Stop::Read(e)) => return Err(e.into()),
        Err(Stop::Declined(why)) => return Err(Error::at(input, 0, None, why).into()),
    }
    out.finish(std::mem::take(&mut p.version), false, 0)
}
