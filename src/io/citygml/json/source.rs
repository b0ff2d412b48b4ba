//! What a CityJSON source gives its CityJSON output: the attributes of its city objects and
//! the members of its semantic surface objects (beyond `type`, `parent` and `children`,
//! which the writer makes itself), found again from the source document
//! ([`crate::io::cityjson::read_slice_with_origins`]: where each asset came from).

use crate::io::citygml::read::Chunk;
use crate::io::cityjson::Origin;
use crate::model::CityModel;
use serde_json::{Map, Value};
use std::collections::{BTreeMap, HashMap};
use std::io::{self, Read};

/// Attributes copied from a CityJSON source.
#[derive(Debug, Default, Clone)]
pub(crate) struct FromSource {
    /// `attributes` of each city object, by id.
    pub objects: HashMap<String, Map<String, Value>>,
    /// Members of the semantic surface object of each asset (model index).
    pub surfaces: BTreeMap<usize, Map<String, Value>>,
}

/// The attributes of file `file`'s source when it is CityJSON (`None` for CityGML).
///
/// # Errors
/// The source cannot be read again, or is no longer the document the model was read from.
pub(crate) fn from_source(model: &CityModel, file: usize) -> io::Result<Option<FromSource>> {
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
    // a file in chunks (the chunked read: one chunk's model at a time, besides the model
    // given), each chunk's surface objects by their asset in the whole file's model
    if let crate::model::Source::File(p) = &f.source {
        let mut found = FromSource::default();
        let chunk = crate::io::citygml::read::CHUNK_BYTES;
        let r = super::chunks::stream_chunks(p, chunk, &|_| {}, |c: Chunk| {
            let Some(s) = c.source else {
                return Ok(());
            };
            found.objects.extend(s.objects);
            for (j, m) in s.surfaces {
                // non-body assets: those of earlier chunks come first
                let i = assets
                    .get(c.assets_before + j)
                    .ok_or_else(|| changed(c.assets_before + j))?;
                found.surfaces.insert(*i, m);
            }
            Ok(())
        });
        match r {
            Ok(sum) if sum.assets + sum.bodies == assets.len() => return Ok(Some(found)),
            Ok(sum) => return Err(changed(sum.assets + sum.bodies)),
            Err(super::chunks::Stop::Each(e)) => return Err(e),
            // read whole below
            Err(_) => {}
        }
    }
    let mut bytes = Vec::new();
    match crate::io::citygml::source::load_source(&f.source, &f.path).map_err(io::Error::other)? {
        crate::io::citygml::source::Loaded::Plain(b) => bytes.extend_from_slice(&b),
        crate::io::citygml::source::Loaded::Gzip(mut r, _) => {
            r.read_to_end(&mut bytes)?;
        }
    }
    let (_, origins) =
        crate::io::cityjson::read_slice_with_origins(&bytes, &f.path).map_err(io::Error::other)?;
    if assets.len() != origins.len() {
        return Err(changed(origins.len()));
    }
    // (object, geometry, surface) wanted, then one pass over the document's values
    let mut wanted: HashMap<&str, Vec<(usize, usize, usize)>> = HashMap::new();
    for (&i, o) in assets.iter().zip(&origins) {
        if let Origin {
            object,
            surface: Some((g, k)),
        } = o
        {
            wanted.entry(object.as_str()).or_default().push((i, *g, *k));
        }
    }
    let mut out = FromSource::default();
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(&bytes);
    for v in serde_json::Deserializer::from_slice(bytes).into_iter::<Value>() {
        let Value::Object(mut doc) = v.map_err(io::Error::other)? else {
            continue;
        };
        let Some(Value::Object(objects)) = doc.remove("CityObjects") else {
            continue;
        };
        for (id, o) in objects {
            let Value::Object(mut o) = o else {
                continue;
            };
            let w = wanted.get(id.as_str()).map_or(&[][..], Vec::as_slice);
            add_object(&mut out, id, &mut o, w);
        }
    }
    Ok(Some(out))
}

/// What city object `id` (`o`) of the source gives: its attributes, and the members of the
/// semantic surface objects `wanted` (asset, geometry, surface).
pub(crate) fn add_object(
    out: &mut FromSource,
    id: String,
    o: &mut Map<String, Value>,
    wanted: &[(usize, usize, usize)],
) {
    let geoms = o.get("geometry").and_then(Value::as_array);
    for &(i, g, k) in wanted {
        let s = geoms
            .and_then(|gs| gs.get(g))
            .and_then(|g| g.pointer(&format!("/semantics/surfaces/{k}")))
            .and_then(Value::as_object);
        if let Some(s) = s {
            let mut m = s.clone();
            for key in ["type", "parent", "children"] {
                m.remove(key);
            }
            if !m.is_empty() {
                out.surfaces.insert(i, m);
            }
        }
    }
    if let Some(Value::Object(a)) = o.remove("attributes") {
        if !a.is_empty() {
            out.objects.insert(id, a);
        }
    }
}
