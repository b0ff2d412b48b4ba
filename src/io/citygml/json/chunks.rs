//! A CityJSON document (`.city.json`, not CityJSONSeq) read in chunks of whole city-object
//! trees ([`stream`]): the same [`Chunk`]s, in the same order, as the chunked CityGML read
//! gives, so that `stats` and `convert` consume both alike; memory follows the chunk, not
//! the document.
//!
//! Two passes over the document, through the streaming reader of the CityJSON edits
//! (`super::stream`, shared with the CityJSON edits: its members in any order, `CityObjects` one
//! object at a time, `vertices` one vertex at a time):
//!
//! 1. the small members (`type`, `version`, `transform`, `metadata`, `geometry-templates`),
//!    the vertices, and the ids of the city objects with their `parents` and `children` as
//!    hashes (about 50 bytes an object, dropped after the pass; only the links are parsed of
//!    each object's text, the rest skipped). The links tell where the object list can be
//!    cut: after an object when every object before it is linked only with objects before
//!    it. The cuts kept are about one per `chunk_bytes` of document.
//! 2. the city objects, each parsed from its text and mapped as it is read ([`super::map`],
//!    as the whole read maps them, in document order) into the chunk's model, its
//!    attributes and semantic surface objects kept for a CityJSON output; at a cut the
//!    chunk's parents are resolved, its bodies made, and it is handed over and dropped.
//!
//! What grows with the document: the vertices in real coordinates, 24 bytes a vertex (the
//! whole document's list, since any object may use any vertex), and the list of cuts.
//!
//! The stream declines ([`Streamed::Declined`]: the caller reads the document whole, as
//! before) where a chunk could differ from the whole read: CityJSONSeq, a first value that
//! is no `CityJSON` object, a city object id given twice, and any document that does not
//! read (the reason names the file and the line:column where the JSON parser was).

use super::source::{add_object, FromSource};
use super::stream::{read, EachText, Pass, Structure, Vertex};
use crate::io::citygml::read::{Chunk, StreamSummary, Streamed};
use crate::io::citygml::{ReadError, WriteError};
use crate::io::cityjson::doc::{CityObject, Metadata, Templates, Transform};
use crate::io::cityjson::map::{real_vertices, Mapper, Vertices};
use crate::io::cityjson::seq::{
    check_version, reference_system_text, source_file, template_vertices,
};
use crate::io::cityjson::Error;
use crate::model::{AssetKind, CityModel};
use serde::Deserialize;
use serde_json::value::RawValue;
use serde_json::{Map, Value};
use std::path::Path;

/// Why [`stream_chunks`] stopped.
#[derive(Debug)]
pub(crate) enum Stop<E> {
    /// The caller's function failed.
    Each(E),
    /// The document could differ from the whole read (see the module docs).
    Declined(String),
    /// The document does not read: the file, line:column and city object where known.
    Read(Error),
}

/// [`crate::io::citygml::read::stream`] of a CityJSON document (see the module docs): each
/// chunk handed to `each` in document order; `passed(n)`: `n` more bytes of the document
/// read (they add up to its size when it is done).
///
/// # Errors
/// Errors of `each`; a document that cannot be read, or could differ from the whole read, is
/// [`Streamed::Declined`] with the reason.
pub(crate) fn stream<E>(
    path: &Path,
    chunk_bytes: u64,
    passed: &dyn Fn(u64),
    each: impl FnMut(Chunk) -> Result<(), E>,
) -> Result<Streamed, E> {
    match stream_chunks(path, chunk_bytes, passed, each) {
        Ok(sum) => Ok(Streamed::Done(sum)),
        Err(Stop::Each(e)) => Err(e),
        Err(Stop::Declined(why)) => Ok(Streamed::Declined(why)),
        Err(Stop::Read(e)) => Ok(Streamed::Declined(e.to_string())),
    }
}

/// Pass 1: the head, the vertices as stored, the links of the city objects.
#[derive(Default)]
struct Head {
    /// The small top-level members the chunks need (`type`, `version`, `transform`,
    /// `metadata`, `geometry-templates`: [`Pass::keeps`]).
    members: Map<String, Value>,
    vertices: Vec<[f64; 3]>,
    structure: Structure,
    /// An id given twice.
    repeated: Option<String>,
}

impl Pass for Head {
    fn members(&mut self) -> Option<&mut Map<String, Value>> {
        Some(&mut self.members)
    }
    fn keeps(&self, key: &str) -> bool {
        // what the chunks need: not `appearance` and the like, which may be large
        matches!(
            key,
            "type" | "version" | "transform" | "metadata" | "geometry-templates"
        )
    }
    fn wants_objects(&self) -> bool {
        true
    }
    fn wants_text(&self) -> bool {
        true
    }
    fn object_text(&mut self, id: String, o: &RawValue) -> Result<(), String> {
        if self.structure.contains(&id) {
            self.repeated.get_or_insert(id);
            return Ok(());
        }
        let l: Links = serde_json::from_str(o.get()).map_err(|e| format!("{id}: {e}"))?;
        self.structure
            .add_links(&id, l.parents.as_ref(), l.children.as_ref())
    }
    fn wants_vertices(&self) -> bool {
        true
    }
    fn vertex(&mut self, v: Vertex) -> Result<(), String> {
        let k = self.vertices.len();
        let c = v
            .coords()
            .ok_or_else(|| format!("vertex {k} is not three numbers"))?;
        self.vertices.push(c);
        Ok(())
    }
}

/// What pass 1 reads of a city object: its links (the rest skipped unparsed).
#[derive(Deserialize)]
struct Links {
    #[serde(default)]
    parents: Option<Value>,
    #[serde(default)]
    children: Option<Value>,
}

/// What a CityJSON output copies of a city object ([`add_object`]): its attributes and its
/// semantic surface objects (the rest skipped unparsed).
#[derive(Deserialize)]
struct Copied {
    #[serde(default)]
    attributes: Option<Value>,
    #[serde(default)]
    geometry: Vec<CopiedGeometry>,
}

#[derive(Deserialize)]
struct CopiedGeometry {
    #[serde(default)]
    semantics: Option<CopiedSemantics>,
}

#[derive(Deserialize)]
struct CopiedSemantics {
    #[serde(default)]
    surfaces: Option<Value>,
}

impl Copied {
    /// The object as [`add_object`] reads it.
    fn into_object(self) -> Map<String, Value> {
        let geometry = self
            .geometry
            .into_iter()
            .map(|g| match g.semantics {
                Some(CopiedSemantics { surfaces: Some(s) }) => {
                    serde_json::json!({"semantics": {"surfaces": s}})
                }
                _ => Value::Object(Map::new()),
            })
            .collect();
        let mut o = Map::new();
        o.insert("geometry".into(), Value::Array(geometry));
        if let Some(a) = self.attributes {
            o.insert("attributes".into(), a);
        }
        o
    }
}

/// A member of the head as `T` (absent: `None`).
fn typed<T: serde::de::DeserializeOwned>(
    v: &Option<Value>,
    key: &str,
    name: &Path,
) -> Result<Option<T>, Error> {
    // from the text: `geometry-templates` keeps boundaries as text (RawValue)
    v.as_ref()
        .map(|v| serde_json::from_str(&v.to_string()))
        .transpose()
        .map_err(|e| Error::at(name, 0, None, format!("{key}: {e}")))
}

/// The last object of each chunk (document order), about `per` objects a chunk, cut only
/// where every object before the cut is linked with objects before it only.
fn chunk_ends(reach: &[u32], per: usize) -> Vec<u32> {
    let mut ends = Vec::new();
    let (mut furthest, mut start) = (0u32, 0usize);
    for (i, &r) in reach.iter().enumerate() {
        furthest = furthest.max(r);
        if furthest as usize == i && i + 1 - start >= per {
            ends.push(i as u32);
            start = i + 1;
        }
    }
    if start < reach.len() {
        ends.push(reach.len() as u32 - 1);
    }
    ends
}

/// [`stream`], with why it stopped.
pub(crate) fn stream_chunks<E>(
    path: &Path,
    chunk_bytes: u64,
    passed: &dyn Fn(u64),
    mut each: impl FnMut(Chunk) -> Result<(), E>,
) -> Result<StreamSummary, Stop<E>> {
    let read_error = |e: WriteError| match e {
        WriteError::Read(ReadError::CityJson(e)) => Stop::Read(e),
        e => Stop::Declined(e.to_string()),
    };
    // 1. the head, the vertices, the links
    let mut head = Head::default();
    let seen = read(path, path, &mut head).map_err(read_error)?;
    if seen.more {
        return Err(Stop::Declined("CityJSONSeq is read line by line".into()));
    }
    if head.members.get("type").and_then(Value::as_str) != Some("CityJSON") {
        return Err(Stop::Declined("not a CityJSON object".into()));
    }
    if let Some(id) = head.repeated {
        return Err(Stop::Declined(format!("city object id {id:?} given twice")));
    }
    let stop = Stop::Read;
    let version = match head.members.remove("version") {
        Some(Value::String(v)) => v,
        None => String::new(),
        Some(_) => {
            return Err(stop(Error::at(
                path,
                0,
                None,
                "version: not a string".into(),
            )))
        }
    };
    let transform: Option<Transform> =
        typed(&head.members.remove("transform"), "transform", path).map_err(stop)?;
    let metadata: Option<Metadata> =
        typed(&head.members.remove("metadata"), "metadata", path).map_err(stop)?;
    let templates: Option<Templates> = typed(
        &head.members.remove("geometry-templates"),
        "geometry-templates",
        path,
    )
    .map_err(stop)?;
    let srs_name = metadata
        .as_ref()
        .and_then(|m| m.reference_system.as_ref())
        .and_then(reference_system_text);
    let template_list = template_vertices(templates.as_ref(), path).map_err(stop)?;
    let list = real_vertices(&head.vertices, transform.as_ref(), path, 0).map_err(stop)?;
    drop(std::mem::take(&mut head.vertices));
    let n = head.structure.len();
    let per = match seen.bytes {
        0 => n.max(1),
        b => usize::try_from(u128::from(chunk_bytes) * n as u128 / u128::from(b))
            .unwrap_or(usize::MAX)
            .max(1),
    };
    let ends = chunk_ends(&head.structure.reach(), per);
    drop(head.structure);
    let gzip = {
        let mut magic = [0u8; 2];
        std::fs::File::open(path)
            .and_then(|mut f| std::io::Read::read_exact(&mut f, &mut magic))
            .is_ok()
            && crate::io::is_gzip(&magic)
    };
    let verts = Vertices {
        list: &list,
        templates: templates.as_ref(),
        template_list: &template_list,
    };

    // 2. the objects, chunk by chunk
    let new_mapper = |first: bool| {
        let mut m = Mapper::new(path);
        if first {
            check_version(&mut m, &version);
        }
        m
    };
    let mut sum = StreamSummary {
        version: Some(crate::io::cityjson::seq::model_version(&version)),
        srs_name: srs_name.clone(),
        ..StreamSummary::default()
    };
    let mut mapper = new_mapper(true);
    let mut source = FromSource::default();
    let mut k = 0usize;
    let mut failed: Option<Stop<E>> = None;
    let mut failed_id: Option<String> = None;
    let mut reported = 0u64;
    let mut hand_over = |mapper: Mapper,
                         source: FromSource,
                         done: usize,
                         sum: &mut StreamSummary|
     -> Result<(), E> {
        let (buildings, assets, _, warnings, counts) = mapper.finish();
        let file = source_file(path, &version, srs_name.clone(), gzip, seen.bytes, counts);
        let bodies = assets.iter().filter(|a| a.kind == AssetKind::Body).count();
        let at = match n {
            0 => seen.bytes,
            n => u64::try_from(u128::from(seen.bytes) * done as u128 / n as u128)
                .unwrap_or(seen.bytes),
        };
        let chunk = Chunk {
            model: CityModel {
                files: vec![file],
                buildings,
                assets,
                warnings,
            },
            index: sum.chunks,
            buildings_before: sum.buildings,
            assets_before: sum.assets,
            bodies_before: sum.bodies,
            warnings_before: sum.warnings,
            bytes: (reported, at),
            source: Some(source),
        };
        sum.chunks += 1;
        sum.buildings += chunk.model.buildings.len();
        sum.assets += chunk.model.assets.len() - bodies;
        sum.bodies += bodies;
        sum.warnings += chunk.model.warnings.len();
        if at > reported {
            passed(at - reported);
            reported = at;
        }
        each(chunk)
    };
    let mut end = ends.iter().copied();
    let mut next_end = end.next();
    let r = {
        let mut objects = EachText(|id: String, o: &RawValue| {
            let before = mapper.origins.len();
            let parsed = serde_json::from_str::<CityObject>(o.get())
                .and_then(|t| Ok((t, serde_json::from_str::<Copied>(o.get())?)));
            let (typed, copied) = match parsed {
                Ok(t) => t,
                Err(e) => {
                    failed_id = Some(id);
                    return Err(e.to_string());
                }
            };
            let one = [(id, typed)];
            if let Err(e) = mapper.add(&one, &verts, 0) {
                failed_id = e.id.clone();
                return Err(e.message);
            }
            let [(id, _)] = one;
            let wanted: Vec<(usize, usize, usize)> = mapper.origins[before..]
                .iter()
                .enumerate()
                .filter_map(|(i, o)| o.surface.map(|(g, s)| (before + i, g, s)))
                .collect();
            add_object(&mut source, id, &mut copied.into_object(), &wanted);
            if next_end == Some(k as u32) {
                next_end = end.next();
                let m = std::mem::replace(&mut mapper, new_mapper(false));
                let s = std::mem::take(&mut source);
                if let Err(e) = hand_over(m, s, k + 1, &mut sum) {
                    failed = Some(Stop::Each(e));
                    return Err("stopped".into());
                }
            }
            k += 1;
            Ok(())
        });
        read(path, path, &mut objects)
    };
    if let Some(f) = failed {
        return Err(f);
    }
    if let Err(e) = r {
        return Err(match read_error(e) {
            Stop::Read(mut e) => {
                e.id = failed_id.or(e.id);
                Stop::Read(e)
            }
            other => other,
        });
    }
    if k != n {
        return Err(Stop::Declined("the document changed while read".into()));
    }
    if n == 0 {
        hand_over(mapper, source, 0, &mut sum).map_err(Stop::Each)?;
    }
    Ok(sum)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every chunk's buildings, or why the stream stopped.
    fn chunks_of(doc: &str, chunk: u64) -> Result<Vec<Vec<String>>, Stop<()>> {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("d.city.json");
        std::fs::write(&path, doc).unwrap();
        let mut out = Vec::new();
        stream_chunks(&path, chunk, &|_| {}, |c: Chunk| {
            let ids = c
                .model
                .buildings
                .iter()
                .map(|b| b.id.clone().unwrap_or_default());
            out.push(ids.collect());
            Ok::<(), ()>(())
        })?;
        Ok(out)
    }

    const DOC: &str = r#"{"vertices":[[0,0,0],[1000,0,0],[0,1000,0]],"type":"CityJSON","version":"2.0",
      "CityObjects":{
        "p":{"type":"BuildingPart","parents":["b"],"geometry":[{"type":"MultiSurface","lod":"1","boundaries":[[[0,1,2]]]}]},
        "c":{"type":"Building","geometry":[{"type":"MultiSurface","lod":"1","boundaries":[[[0,1,2]]]}]},
        "b":{"type":"Building","children":["p"]},
        "d":{"type":"Building","geometry":[{"type":"MultiSurface","lod":"1","boundaries":[[[0,1,2]]]}]}},
      "transform":{"scale":[0.001,0.001,0.001],"translate":[0,0,0]}}"#;

    #[test]
    fn chunks_hold_whole_trees_in_document_order() {
        // one object a chunk where it can be cut: never between the part and its building
        let c = chunks_of(DOC, 1).unwrap_or_else(|_| panic!("stopped"));
        assert_eq!(c, [vec!["p", "c", "b"], vec!["d"]]);
        let whole = crate::io::cityjson::read_slice(DOC.as_bytes(), "d".as_ref()).unwrap();
        let ids: Vec<_> = whole
            .buildings
            .iter()
            .map(|b| b.id.clone().unwrap())
            .collect();
        assert_eq!(ids, ["p", "c", "b", "d"]);
        assert_eq!(chunks_of(DOC, 1 << 20).unwrap_or_default().len(), 1);
    }

    #[test]
    fn errors_have_the_file_line_column_and_object() {
        let bad = DOC.replace(r#""c":{"type":"Building","geometry":[{"type":"MultiSurface","lod":"1","boundaries":[[[0,1,2]]]}]}"#,
            "\"c\":{\"type\":\"Building\",\"geometry\":[{\"type\":\"MultiSurface\",\"lod\":\"1\",\"boundaries\":[[[0,1,7]]]}]}");
        assert_ne!(bad, DOC);
        let Err(Stop::Read(e)) = chunks_of(&bad, 1) else {
            panic!("a bad vertex index is an error");
        };
        assert_eq!((e.line, e.id.as_deref()), (4, Some("c")), "{e}");
        assert!(e.column > 0 && e.message.contains("vertex index 7"), "{e}");
        assert!(
            e.to_string()
                .starts_with(&format!("{}:4:", e.file.display())),
            "{e}"
        );
        let Err(Stop::Read(e)) = chunks_of(&DOC[..DOC.len() - 30], 1) else {
            panic!("a truncated document is an error");
        };
        assert!(
            e.line == 7 && e.column > 0 && e.message.contains("EOF"),
            "{e}"
        );
        // what could differ from the whole read declines
        let twice = DOC.replace(r#""d":"#, r#""c":"#);
        assert!(matches!(chunks_of(&twice, 1), Err(Stop::Declined(_))));
        let seq = format!(
            "{}\n{{\"type\":\"CityJSONFeature\"}}",
            DOC.replace('\n', " ")
        );
        assert!(matches!(chunks_of(&seq, 1), Err(Stop::Declined(_))));
    }

    #[test]
    fn cuts_only_between_linked_groups() {
        // 0 alone; 1..=3 linked (3 with 1); 4 alone
        let reach = [0, 3, 2, 3, 4];
        assert_eq!(chunk_ends(&reach, 1), [0, 3, 4]);
        assert_eq!(chunk_ends(&reach, 2), [3, 4]);
        assert_eq!(chunk_ends(&reach, 9), [4]);
        assert!(chunk_ends(&[], 1).is_empty());
    }
}
