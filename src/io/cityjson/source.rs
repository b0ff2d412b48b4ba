//! What a CityJSON source gives its CityJSON output: the attributes of its city objects and
//! the members of its semantic surface objects (beyond `type`, `parent` and `children`,
//! which the writer makes itself), found again by reading the source in chunks
//! ([`super::chunks::stream`]), each chunk's surface objects by their asset in the model.

use super::chunks::{stream, Input, Part, Stop};
use super::doc::CityObject;
use crate::model::{AssetKind, CityModel, Source};
use serde_json::{Map, Value};
use std::collections::{BTreeMap, HashMap};
use std::io;

/// Attributes copied from a CityJSON source.
#[derive(Debug, Default, Clone)]
pub(crate) struct FromSource {
    /// `attributes` of each city object, by id.
    pub objects: HashMap<String, Map<String, Value>>,
    /// Members of the semantic surface object of each asset (model index).
    pub surfaces: BTreeMap<usize, Map<String, Value>>,
}

/// The attributes of file `file`'s source when it is CityJSON (`None` for CityGML), read
/// in chunks of about `chunk_bytes` (in one where the chunks could differ from the whole
/// read).
///
/// # Errors
/// The source cannot be read again, or is no longer the document the model was read from.
pub(crate) fn from_source(
    model: &CityModel,
    file: usize,
    chunk_bytes: u64,
) -> io::Result<Option<FromSource>> {
    let Some(f) = model.files.get(file).filter(|f| f.cityjson.is_some()) else {
        return Ok(None);
    };
    let assets: Vec<usize> = (0..model.assets.len())
        .filter(|&i| model.assets[i].file == file)
        .collect();
    let changed = |now: usize| {
        io::Error::other(format!(
            "{}: the CityJSON source changed since it was read ({} assets, now {now})",
            crate::model::shown(&f.path),
            assets.len(),
        ))
    };
    let input = match &f.source {
        Source::File(p) => Input::File(p),
        Source::Memory(b) if crate::io::files::is_gzip(b) => Input::Gzip(b),
        Source::Memory(b) => Input::Bytes(b),
    };
    let mut chunk = chunk_bytes;
    loop {
        let mut found = FromSource::default();
        // non-body assets of earlier chunks come first in the model
        let (mut before, mut total) = (0, 0);
        let r = stream(input, &f.path, chunk, None, &|_| {}, |c: Part| {
            found.objects.extend(c.source.objects);
            for (j, m) in c.source.surfaces {
                let i = assets.get(before + j).ok_or_else(|| changed(before + j))?;
                found.surfaces.insert(*i, m);
            }
            before += c
                .model
                .assets
                .iter()
                .filter(|a| a.kind != AssetKind::Body)
                .count();
            total += c.model.assets.len();
            Ok(())
        });
        match r {
            Ok(_) if total == assets.len() => return Ok(Some(found)),
            Ok(_) => return Err(changed(total)),
            Err(Stop::Each(e)) => return Err(e),
            Err(Stop::Declined(_)) if chunk < u64::MAX => chunk = u64::MAX,
            Err(Stop::Declined(why)) => return Err(io::Error::other(why)),
            Err(Stop::Read(e)) => return Err(io::Error::other(e)),
        }
    }
}

/// What city object `id` (`o`) of the source gives: its attributes, and the members of the
/// semantic surface objects `wanted` (asset, geometry, surface) but for `type`, `parent`
/// and `children`.
pub(crate) fn add_object(
    out: &mut FromSource,
    id: String,
    o: &mut CityObject,
    wanted: &[(usize, usize, usize)],
) {
    for &(i, g, k) in wanted {
        let s = o
            .geometry
            .get(g)
            .and_then(|g| g.semantics.as_ref()?.surfaces.get(k));
        if let Some(m) = s.map(|s| s.copied()).filter(|m| !m.is_empty()) {
            out.surfaces.insert(i, m);
        }
    }
    if let Some(a) = o.attributes.take().filter(|a| !a.is_empty()) {
        out.objects.insert(id, a);
    }
}
