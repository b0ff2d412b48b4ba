//! A CityJSON document (`.city.json`) read in chunks of whole city-object
//! trees ([`stream`]): each chunk a [`Part`], which the chunked CityGML read
//! (`crate::io::citygml::read::stream`) hands over as the same `Chunk`s, in the same order,
//! as it gives of CityGML, so that `stats` and `convert` consume both alike; memory follows
//! the chunk, not the document.
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
//! A document with a city object id given twice is one chunk, its objects mapped at once
//! (the links cannot tell which object of the id another one names). A document that does
//! not read stops the stream ([`Stop::Read`]: the file, and the line:column where the JSON
//! parser was). CityJSONSeq (a second JSON value after the first) is read in chunks of
//! lines (`super::seq`). The whole read ([`whole_model`]) is the chunks collected, as one
//! chunk.
//!
//! Pass 1's results ([`Prepared`]) serve every later pass over the objects: the CityGML
//! writer's (`crate::export::citygml_from_cityjson`), a streamed writer's passes (kept in
//! a [`Kept`]), and the whole model of a CityJSON input ([`whole_model`]: one chunk of
//! everything, no serde value of the document).

use super::doc::{CityObject, Metadata, Templates, Transform};
use super::head::{check_version, model_version, source_file, template_vertices};
use super::map::{real_vertices, Mapper, Vertices};
use super::source::{add_object, FromSource};
use super::stream::{open_json, read_from, read_slice, EachText, Pass, Seen, Structure, Vertex};
use super::CityJsonError as Error;
use crate::model::{Asset, Building, CityGmlVersion, CityModel, SourceFile, Warning};
use glam::DVec3;
use serde::Deserialize;
use serde_json::value::RawValue;
use serde_json::{Map, Value};
use std::collections::HashMap;
use std::path::Path;

/// Why [`stream`] stopped.
#[derive(Debug)]
pub(crate) enum Stop<E> {
    /// The caller's function failed.
    Each(E),
    /// The document could differ from the whole read (see the module docs).
    Declined(String),
    /// The document does not read: the file, line:column and city object where known.
    Read(Error),
}

/// One chunk of a document: a model of one file (the document's path and CRS), its first
/// and last byte (exclusive) in the document (of a `.city.json`: in proportion to its city
/// objects), and what a CityJSON output copies of its city objects (empty unless asked for).
#[derive(Debug)]
pub(crate) struct Part {
    pub model: CityModel,
    pub bytes: (u64, u64),
    pub source: FromSource,
}

/// What the chunks of a document share: the CityGML version its CityJSON version encodes
/// and its `srsName`.
#[derive(Debug, Clone, Default)]
pub(crate) struct Shared {
    pub version: Option<CityGmlVersion>,
    pub srs_name: Option<String>,
}

/// Pass 1: the head, the vertices as stored, the links of the city objects.
#[derive(Default)]
struct Head {
    /// The small top-level members the chunks need (`type`, `version`, `transform`,
    /// `metadata`, `geometry-templates`: [`Pass::keeps`]).
    members: Map<String, Value>,
    vertices: Vec<[f64; 3]>,
    structure: Structure,
    /// City objects, ids given twice counted twice.
    count: usize,
    /// Whether an id is given twice.
    repeated: bool,
    /// Whether `appearance` is given (not `null`).
    appearance: bool,
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
    fn skipped(&mut self, key: &str, null: bool) {
        self.appearance |= key == "appearance" && !null;
    }
    fn wants_objects(&self) -> bool {
        true
    }
    fn wants_text(&self) -> bool {
        true
    }
    fn object_text(&mut self, id: String, o: &RawValue) -> Result<(), String> {
        self.count += 1;
        if self.structure.contains(&id) {
            self.repeated = true;
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

/// Where a document is read from: a file (gzip recognised, `-` standard input) or its bytes
/// in memory.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Input<'a> {
    File(&'a Path),
    Bytes(&'a [u8]),
    /// Gzip-compressed bytes in memory.
    Gzip(&'a [u8]),
}

impl<'a> Input<'a> {
    /// The JSON text (decompressed, a byte-order mark skipped).
    pub(super) fn open(self, name: &Path) -> Result<Box<dyn std::io::BufRead + 'a>, Error> {
        Ok(match self {
            Input::File(p) => {
                open_json(p).map_err(|e| Error::at(name, 0, None, format!("cannot read: {e}")))?
            }
            Input::Bytes(b) => Box::new(b.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(b)),
            Input::Gzip(b) => {
                let mut r = std::io::BufReader::new(flate2::bufread::MultiGzDecoder::new(b));
                if std::io::BufRead::fill_buf(&mut r).is_ok_and(|h| h.starts_with(b"\xEF\xBB\xBF"))
                {
                    std::io::BufRead::consume(&mut r, 3);
                }
                Box::new(r)
            }
        })
    }

    /// A pass of `pass` over the document (named `name` in errors).
    fn read(self, name: &Path, pass: &mut dyn Pass) -> Result<Seen, Error> {
        match self {
            Input::File(_) | Input::Gzip(_) => read_from(self.open(name)?, name, pass),
            Input::Bytes(b) => read_slice(b.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(b), name, pass),
        }
    }

    /// Whether the document is gzip-compressed.
    pub(super) fn gzip(self) -> bool {
        match self {
            Input::File(path) => {
                let mut magic = [0u8; 2];
                std::fs::File::open(path)
                    .and_then(|mut f| std::io::Read::read_exact(&mut f, &mut magic))
                    .is_ok()
                    && crate::io::files::is_gzip(&magic)
            }
            Input::Bytes(_) => false,
            Input::Gzip(_) => true,
        }
    }
}

/// What pass 1 found of a document (module docs): what every pass over its objects needs.
/// Kept ([`Kept`]) for the later passes of a writer over the same document; its size grows with the document's vertices (24 bytes each) and chunks.
#[derive(Debug)]
pub(crate) struct Prepared {
    /// `version` (empty when absent).
    pub version: String,
    pub transform: Option<Transform>,
    pub metadata: Option<Metadata>,
    pub templates: Option<Templates>,
    /// The vertices in real coordinates.
    pub list: Vec<DVec3>,
    /// The template vertices (never transformed).
    pub template_list: Vec<DVec3>,
    /// Whether the document has an `appearance` (not `null`).
    pub appearance: bool,
    /// The last object of each chunk, in document order.
    ends: Vec<u32>,
    /// Whether a chunk's objects are mapped at once (an id given twice) rather than one by
    /// one.
    batch: bool,
    /// How many city objects.
    pub objects: usize,
    /// The document's bytes (decompressed, a byte-order mark left out).
    pub bytes: u64,
    gzip: bool,
    /// The chunk size the cuts were made for.
    pub chunk_bytes: u64,
}

/// Pass 1 over the document at `input` (named `name`), cut into chunks of about
/// `chunk_bytes`: `None` for CityJSONSeq (more than one JSON value).
///
/// # Errors
/// The document does not read, or could differ from the whole read.
pub(crate) fn prepare<E>(
    input: Input<'_>,
    name: &Path,
    chunk_bytes: u64,
) -> Result<Option<Prepared>, Stop<E>> {
    let path = name;
    let mut head = Head::default();
    let seen = input.read(path, &mut head).map_err(Stop::Read)?;
    if seen.more {
        return Ok(None);
    }
    let stop = Stop::Read;
    match head.members.get("type") {
        Some(Value::String(t)) if t == "CityJSON" => {}
        Some(Value::String(t)) => return Err(stop(not_cityjson(path, t))),
        _ => return Err(stop(Error::at(path, 1, None, "no \"type\" string".into()))),
    }
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
    let template_list = template_vertices(templates.as_ref(), path).map_err(stop)?;
    let list = real_vertices(&head.vertices, transform.as_ref(), path, 0).map_err(stop)?;
    drop(std::mem::take(&mut head.vertices));
    let n = head.count;
    let per = match seen.bytes {
        0 => n.max(1),
        b => usize::try_from(u128::from(chunk_bytes) * n as u128 / u128::from(b))
            .unwrap_or(usize::MAX)
            .max(1),
    };
    // an id given twice: one chunk, its objects mapped at once, as the links cannot tell
    // which object of an id another one names
    let ends = match head.repeated {
        true => n.checked_sub(1).map(|l| l as u32).into_iter().collect(),
        false => chunk_ends(&head.structure.reach(), per),
    };
    Ok(Some(Prepared {
        version,
        transform,
        metadata,
        templates,
        list,
        template_list,
        appearance: head.appearance,
        ends,
        batch: head.repeated,
        objects: n,
        bytes: seen.bytes,
        gzip: input.gzip(),
        chunk_bytes,
    }))
}

/// The error of a first value of type `ty`, not `CityJSON`.
pub(super) fn not_cityjson(name: &Path, ty: &str) -> Error {
    let m = format!("the first object is of type {ty:?}, not \"CityJSON\"");
    Error::at(name, 1, None, m)
}

/// Why the function of [`each_object`] stopped.
pub(crate) enum Fail<E> {
    /// The caller's error.
    Each(E),
    /// The object is refused: the object's id where known, what is wrong (the reader adds
    /// where it is).
    Object(Option<String>, String),
    /// The objects are refused: the error as it is.
    Read(Error),
}

/// Pass 2 over the document `p` was prepared from: each city object's id and text handed to
/// `each` in document order, with `Some(done)` (the objects so far, this one too) when it
/// is the last of a chunk.
///
/// # Errors
/// `each`'s ([`Stop::Each`]); an object refused is [`Stop::Read`] with the file, line:column
/// of the parser and the object; a document that changed since pass 1 is declined.
pub(crate) fn each_object<E>(
    input: Input<'_>,
    name: &Path,
    p: &Prepared,
    mut each: impl FnMut(String, &RawValue, Option<usize>) -> Result<(), Fail<E>>,
) -> Result<(), Stop<E>> {
    let mut k = 0usize;
    let mut failed: Option<E> = None;
    let mut failed_id: Option<String> = None;
    let mut refused: Option<Error> = None;
    let mut end = p.ends.iter().copied();
    let mut next_end = end.next();
    let r = input.read(
        name,
        &mut EachText(|id: String, o: &RawValue| {
            let last = next_end == Some(k as u32);
            if last {
                next_end = end.next();
            }
            k += 1;
            match each(id, o, last.then_some(k)) {
                Ok(()) => Ok(()),
                Err(Fail::Each(e)) => {
                    failed = Some(e);
                    Err("stopped".into())
                }
                Err(Fail::Object(id, m)) => {
                    failed_id = id;
                    Err(m)
                }
                Err(Fail::Read(e)) => {
                    refused = Some(e);
                    Err("stopped".into())
                }
            }
        }),
    );
    if let Some(f) = failed {
        return Err(Stop::Each(f));
    }
    if let Some(e) = refused {
        return Err(Stop::Read(e));
    }
    if let Err(mut e) = r {
        e.id = failed_id.or(e.id);
        return Err(Stop::Read(e));
    }
    if k != p.objects {
        return Err(Stop::Declined("the document changed while read".into()));
    }
    Ok(())
}

/// City object `id` (its text `o`) parsed into `objects`. Errors: the object's id, what is
/// wrong.
fn parse_object<E>(
    objects: &mut Vec<(String, CityObject)>,
    id: String,
    o: &RawValue,
) -> Result<(), Fail<E>> {
    match serde_json::from_str::<CityObject>(o.get()) {
        Ok(t) => {
            objects.push((id, t));
            Ok(())
        }
        Err(e) => {
            let e = e.to_string();
            let m = e.rsplit_once(" at line ").map_or(e.as_str(), |(m, _)| m);
            Err(Fail::Object(Some(id), m.to_string()))
        }
    }
}

/// The city objects `objects` mapped into `mapper` at once (of CityJSONSeq line `line`; a
/// document's: 0), what a CityJSON output copies of them kept in `source` where given (of an
/// id given twice, the last object's, for all of the id's assets).
///
/// # Errors
/// What [`Mapper::add`] refuses.
pub(super) fn map_objects(
    mapper: &mut Mapper,
    source: Option<&mut FromSource>,
    verts: &Vertices<'_>,
    objects: &mut Vec<(String, CityObject)>,
    line: u64,
) -> Result<(), Error> {
    let before = mapper.origins.len();
    mapper.add(objects, verts, line)?;
    if let Some(source) = source {
        // (asset, geometry, surface) of each object's semantic surface objects
        let mut wanted: HashMap<&str, Vec<(usize, usize, usize)>> = HashMap::new();
        for (i, o) in mapper.origins[before..].iter().enumerate() {
            if let Some((g, s)) = o.surface {
                let w = wanted.entry(o.object.as_str()).or_default();
                w.push((before + i, g, s));
            }
        }
        // an object whose id comes again later
        let mut later = std::collections::HashSet::new();
        let mut skip = vec![false; objects.len()];
        if objects.len() > 1 {
            for (k, (id, _)) in objects.iter().enumerate().rev() {
                skip[k] = !later.insert(id.as_str());
            }
        }
        drop(later);
        for ((id, o), skip) in objects.iter_mut().zip(skip) {
            if skip {
                continue;
            }
            let w = wanted.get(id.as_str()).map_or(&[][..], Vec::as_slice);
            add_object(source, id.clone(), o, w);
        }
    }
    objects.clear();
    Ok(())
}

/// The document `input` (named `path`) read in chunks of whole city-object trees of about
/// `chunk_bytes` (CityJSONSeq: of whole lines), each handed to `each` in document order;
/// `passed(n)`: `n` more bytes of the document read (they add up to its size when it is
/// done). With `kept`, pass 1 of a `.city.json` is made once for the file and chunk size
/// and kept there for later streams.
///
/// # Errors
/// [`Stop::Each`]: `each`'s; [`Stop::Read`]: the document does not read;
/// [`Stop::Declined`]: the chunks could differ from the whole read.
pub(crate) fn stream<E>(
    input: Input<'_>,
    path: &Path,
    chunk_bytes: u64,
    kept: Option<&Kept>,
    passed: &dyn Fn(u64),
    each: impl FnMut(Part) -> Result<(), E>,
) -> Result<Shared, Stop<E>> {
    let found = kept.and_then(|k| k.find(path, chunk_bytes));
    let prepared = match found {
        Some(p) => p,
        None => match prepare(input, path, chunk_bytes)? {
            Some(p) => {
                let p = std::sync::Arc::new(p);
                if let Some(k) = kept {
                    k.keep(path, &p);
                }
                p
            }
            None => return super::seq::stream_seq(input, path, chunk_bytes, passed, each),
        },
    };
    stream_prepared(input, path, &prepared, true, passed, each)
}

/// A chunk's model: `file` and the chunk's buildings, assets and warnings.
pub(super) fn part(
    file: SourceFile,
    (buildings, assets, warnings): (Vec<Building>, Vec<Asset>, Vec<Warning>),
    bytes: (u64, u64),
    source: FromSource,
) -> Part {
    Part {
        model: CityModel {
            files: vec![file],
            buildings,
            assets,
            warnings,
        },
        bytes,
        source,
    }
}

/// The chunks of a document (pass 2, after [`prepare`]) handed to `each`. `streamed`: each
/// with what a CityJSON output copies of its objects ([`Part::source`], else empty), and
/// an object the model refuses said where the parser is (else as the whole read says it:
/// the file and the object).
///
/// # Errors
/// As [`each_object`].
pub(crate) fn stream_prepared<E>(
    input: Input<'_>,
    path: &Path,
    p: &Prepared,
    streamed: bool,
    passed: &dyn Fn(u64),
    mut each: impl FnMut(Part) -> Result<(), E>,
) -> Result<Shared, Stop<E>> {
    let srs_name = p.metadata.as_ref().and_then(Metadata::srs_name);
    let verts = Vertices {
        list: &p.list,
        templates: p.templates.as_ref(),
        template_list: &p.template_list,
    };
    let new_mapper = |first: bool| {
        let mut m = Mapper::new(path);
        if first {
            check_version(&mut m, &p.version);
        }
        m
    };
    let shared = Shared {
        version: Some(model_version(&p.version)),
        srs_name: srs_name.clone(),
    };
    let mut reported = 0u64;
    let (n, bytes) = (p.objects, p.bytes);
    let mut hand_over = |mapper: Mapper, source: FromSource, done: usize| -> Result<(), E> {
        let (buildings, assets, _, warnings, counts) = mapper.finish();
        let file = source_file(path, &p.version, srs_name.clone(), p.gzip, bytes, counts);
        let at = match n {
            0 => bytes,
            n => u64::try_from(u128::from(bytes) * done as u128 / n as u128).unwrap_or(bytes),
        };
        let parts = (buildings, assets, warnings);
        let chunk = part(file, parts, (reported, at), source);
        if at > reported {
            passed(at - reported);
            reported = at;
        }
        each(chunk)
    };
    let mut mapper = new_mapper(true);
    let mut source = FromSource::default();
    let mut objects = Vec::new();
    each_object(input, path, p, |id, o, last| {
        parse_object(&mut objects, id, o)?;
        if !p.batch || last.is_some() {
            let copy = streamed.then_some(&mut source);
            map_objects(&mut mapper, copy, &verts, &mut objects, 0).map_err(
                |e| match streamed {
                    true => Fail::Object(e.id, e.message),
                    false => Fail::Read(e),
                },
            )?;
        }
        if let Some(done) = last {
            let m = std::mem::replace(&mut mapper, new_mapper(false));
            let s = std::mem::take(&mut source);
            hand_over(m, s, done).map_err(Fail::Each)?;
        }
        Ok(())
    })?;
    if n == 0 {
        hand_over(mapper, source, 0).map_err(Stop::Each)?;
    }
    Ok(shared)
}

/// A document's first pass kept for the later passes of a writer over it (the chunked
/// read's `Passes`): the file and chunk size it was made for.
#[derive(Debug, Default)]
pub(crate) struct Kept(std::sync::Mutex<Option<(std::path::PathBuf, std::sync::Arc<Prepared>)>>);

impl Kept {
    /// The first pass kept for `path` in chunks of `chunk_bytes`, if any.
    fn find(&self, path: &Path, chunk_bytes: u64) -> Option<std::sync::Arc<Prepared>> {
        let k = self.0.lock().ok()?;
        k.as_ref()
            .filter(|(p, prep)| p == path && prep.chunk_bytes == chunk_bytes)
            .map(|(_, prep)| prep.clone())
    }

    /// Keep `prepared`, the first pass over `path`.
    fn keep(&self, path: &Path, prepared: &std::sync::Arc<Prepared>) {
        if let Ok(mut k) = self.0.lock() {
            *k = Some((path.to_path_buf(), prepared.clone()));
        }
    }
}

/// The whole model of the CityJSON document or CityJSONSeq `input` (named `name`): its
/// chunks collected, as one chunk (no serde value of the document: memory follows the
/// model).
///
/// # Errors
/// The document does not read: the file, line:column and city object where known.
pub(crate) fn whole_model(input: Input<'_>, name: &Path) -> Result<CityModel, Error> {
    let mut out = None;
    let each = |c: Part| {
        let mut model = c.model;
        if let Some(f) = model.files.first_mut() {
            f.len = c.bytes.1;
        }
        out = Some(model);
        Ok::<(), std::convert::Infallible>(())
    };
    let r = match prepare(input, name, u64::MAX) {
        Ok(Some(p)) => stream_prepared(input, name, &p, false, &|_| {}, each),
        Ok(None) => super::seq::stream_seq(input, name, u64::MAX, &|_| {}, each),
        Err(e) => Err(e),
    };
    match r {
        Ok(_) => out.ok_or_else(|| Error::at(name, 0, None, "no chunk".into())),
        Err(Stop::Read(e)) => Err(e),
        Err(Stop::Declined(why)) => Err(Error::at(name, 0, None, why)),
        Err(Stop::Each(never)) => match never {},
    }
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
        let input = Input::File(&path);
        stream(input, &path, chunk, None, &|_| {}, |c: Part| {
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
        let at = format!("{}:4:", e.file.display());
        assert!(e.to_string().starts_with(&at), "{e}");
        // the whole read's names the object (a CityJSONSeq's also the line)
        let e = whole_model(Input::Bytes(bad.as_bytes()), "d".as_ref()).unwrap_err();
        assert_eq!(
            e.to_string(),
            "d [city object c]: invalid CityJSON: vertex index 7 out of range (3 vertices)"
        );
        // a parser's error where the parser was
        let typo = DOC.replace(r#""c":{"type":"Building","#, r#""c":{"type":"Building",,"#);
        let Err(Stop::Read(e)) = chunks_of(&typo, 1) else {
            panic!("a syntax error is an error");
        };
        assert_eq!((e.line, e.column), (4, 32), "{e}");
        let Err(Stop::Read(e)) = chunks_of(&DOC[..DOC.len() - 30], 1) else {
            panic!("a truncated document is an error");
        };
        assert!(
            e.line == 7 && e.column > 0 && e.message.contains("EOF"),
            "{e}"
        );
        // an id given twice: one chunk, whatever the chunk size
        let twice = DOC.replace(r#""d":"#, r#""c":"#);
        assert_eq!(chunks_of(&twice, 1).unwrap_or_default().len(), 1);
        let not = DOC.replace(r#""type":"CityJSON""#, r#""type":"FeatureCollection""#);
        let Err(Stop::Read(e)) = chunks_of(&not, 1) else {
            panic!("not CityJSON is an error");
        };
        assert!(e
            .to_string()
            .ends_with(r#"of type "FeatureCollection", not "CityJSON""#));
        let seq = format!(
            "{}\n{{\"type\":\"CityJSONFeature\"}}",
            DOC.replace('\n', " ")
        );
        // CityJSONSeq is read in chunks of lines (`super::seq`)
        assert_eq!(
            chunks_of(&seq, 1).unwrap_or_default(),
            [vec!["p", "c", "b", "d"]]
        );
    }

    #[test]
    fn the_whole_model_is_the_chunks_collected() {
        let whole = whole_model(Input::Bytes(DOC.as_bytes()), "d".as_ref()).unwrap();
        assert_eq!(whole.files[0].len, DOC.len() as u64);
        let mut parts = Vec::new();
        let input = Input::Bytes(DOC.as_bytes());
        let r = stream(input, "d".as_ref(), 1, None, &|_| {}, |p: Part| {
            parts.push(p.model);
            Ok::<(), ()>(())
        });
        assert!(r.is_ok() && parts.len() == 2);
        let buildings: Vec<_> = parts.iter().flat_map(|m| m.buildings.clone()).collect();
        let ids = |b: &[Building]| b.iter().map(|b| b.id.clone()).collect::<Vec<_>>();
        assert_eq!(ids(&buildings), ids(&whole.buildings));
        let polygons = |m: &CityModel| m.assets.iter().map(|a| a.polygon_count()).sum::<usize>();
        assert_eq!(parts.iter().map(polygons).sum::<usize>(), polygons(&whole));
        // an id given twice: its objects mapped at once, the duplicate said first
        let twice = DOC.replace(r#""d":"#, r#""c":"#);
        let m = whole_model(Input::Bytes(twice.as_bytes()), "d".as_ref()).unwrap();
        assert_eq!(m.buildings.len(), 4);
        assert_eq!(m.warnings[0].message, "duplicate city object id");
    }

    #[test]
    fn passes_keep_the_first_pass() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("d.city.json");
        std::fs::write(&path, DOC).unwrap();
        let kept = Kept::default();
        let mut runs = Vec::new();
        for _ in 0..2 {
            let mut ids = Vec::new();
            let input = Input::File(&path);
            let r = stream(input, &path, 1, Some(&kept), &|_| {}, |c: Part| {
                ids.push(c.model.buildings.len());
                Ok::<(), ()>(())
            });
            assert!(r.is_ok());
            runs.push(ids);
            let k = kept.0.lock().unwrap();
            assert!(k
                .as_ref()
                .is_some_and(|(p, prep)| p == &path && prep.objects == 4));
        }
        assert_eq!(runs[0], [3, 1]);
        assert_eq!(runs[0], runs[1]);
        // a file that changed between the passes (an object fewer) is declined
        let start = DOC.find(",\n        \"d\":").unwrap();
        let end = DOC[start..].find("}]}}").unwrap() + start + 3;
        let fewer = format!("{}{}", &DOC[..start], &DOC[end..]);
        assert!(crate::io::cityjson::read_slice(fewer.as_bytes(), "d".as_ref()).is_ok());
        std::fs::write(&path, fewer).unwrap();
        let input = Input::File(&path);
        let r = stream(input, &path, 1, Some(&kept), &|_| {}, |_| Ok::<(), ()>(()));
        assert!(matches!(r, Err(Stop::Declined(_))));
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
