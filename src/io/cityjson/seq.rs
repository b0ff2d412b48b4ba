//! CityJSONSeq (`.city.jsonl`) read in chunks of whole lines: the same [`Part`]s as
//! [`super::chunks`] gives of a document, from one pass over the file. The first line is the
//! header (`transform`, `metadata`, `geometry-templates`); each feature line is one
//! top-level city object with its children and its own vertices, mapped as the whole read
//! ([`crate::io::cityjson::read_slice`]) maps it (its line number in warnings and assets).
//! A chunk ends after the line that takes it past `chunk_bytes` of the file; memory follows
//! the chunk, and what grows with the file is the ids of the city objects as 8-byte hashes
//! (to find a link between chunks).
//!
//! The stream declines (the file is read whole, as before) where a chunk could differ from
//! the whole read: an object linked (`parents`, `children`) with an object of another chunk,
//! an id given twice, and any line that does not read.

use super::chunks::{part, Copied, Input, Part, Shared, Stop};
use super::doc::{CityObject, Metadata, Templates, Transform};
use super::map::{real_vertices, Mapper, Vertices};
use super::read::{check_version, model_version, source_file, template_vertices};
use super::source::{add_object, FromSource};
use super::stream::{id_hash, Counted};
use super::CityJsonError;
use serde::de::{Deserializer, MapAccess, Visitor};
use serde::Deserialize;
use serde_json::value::RawValue;
use std::cell::Cell;
use std::collections::{HashMap, HashSet};
use std::fmt;
use std::path::Path;
use std::rc::Rc;

/// One line: the header or a `CityJSONFeature`, its city objects as their text.
#[derive(Deserialize)]
struct Line {
    #[serde(rename = "type")]
    ty: String,
    #[serde(default)]
    version: Option<String>,
    #[serde(default)]
    transform: Option<Transform>,
    #[serde(default)]
    metadata: Option<Metadata>,
    #[serde(rename = "CityObjects", default)]
    objects: Texts,
    #[serde(default)]
    vertices: Vec<[f64; 3]>,
    #[serde(rename = "geometry-templates", default)]
    templates: Option<Templates>,
}

/// `CityObjects` in line order, each object as its text.
#[derive(Default)]
struct Texts(Vec<(String, Box<RawValue>)>);

impl<'de> Deserialize<'de> for Texts {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Texts;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("an object of city objects")
            }
            fn visit_map<A: MapAccess<'de>>(self, mut m: A) -> Result<Texts, A::Error> {
                let mut v = Vec::new();
                while let Some(e) = m.next_entry::<String, Box<RawValue>>()? {
                    v.push(e);
                }
                Ok(Texts(v))
            }
        }
        d.deserialize_map(V)
    }
}

/// The ids of the chunks handed over and of the one being read, to find what links chunks.
#[derive(Default)]
struct Links {
    /// Ids of earlier chunks.
    earlier: HashSet<u64>,
    /// Ids linked from earlier chunks and not found there.
    pending: HashSet<u64>,
    /// Ids of this chunk, and the ids its objects link to.
    ids: HashSet<u64>,
    links: Vec<u64>,
}

impl Links {
    /// Object `id` with `o`'s links; why the chunks could differ from the whole read.
    fn add(&mut self, id: &str, o: &CityObject) -> Result<(), String> {
        let h = id_hash(id);
        if self.earlier.contains(&h) || !self.ids.insert(h) {
            return Err(format!("city object id {id:?} given twice"));
        }
        if self.pending.contains(&h) {
            return Err(format!("city object {id:?} is linked from an earlier line"));
        }
        for l in o.parents.iter().chain(&o.children) {
            let lh = id_hash(l);
            if self.earlier.contains(&lh) {
                return Err(format!("{id:?} is linked with {l:?} of an earlier line"));
            }
            self.links.push(lh);
        }
        Ok(())
    }

    /// The chunk ends.
    fn cut(&mut self) {
        for l in self.links.drain(..) {
            if !self.ids.contains(&l) {
                self.pending.insert(l);
            }
        }
        self.earlier.extend(self.ids.drain());
    }
}

/// [`super::chunks::stream_chunks`] of CityJSONSeq (module docs).
///
/// # Errors
/// `each`'s; a line that does not read, or chunks that could differ from the whole read,
/// decline.
pub(super) fn stream_seq<E>(
    input: Input<'_>,
    path: &Path,
    chunk_bytes: u64,
    passed: &dyn Fn(u64),
    mut each: impl FnMut(Part) -> Result<(), E>,
) -> Result<Shared, Stop<E>> {
    let read = |e: &serde_json::Error| Stop::Read(CityJsonError::json(path, e));
    let r = input.open(path).map_err(|e| Stop::Declined(e.to_string()))?;
    let gzip = input.gzip();
    // the file's size (a chunk's model is of the whole file)
    let len = match input {
        _ if gzip => 0,
        Input::File(p) => std::fs::metadata(p).map_or(0, |m| m.len()),
        Input::Bytes(b) => b.len() as u64,
        Input::Gzip(_) => 0,
    };
    let n = Rc::new(Cell::new(0u64));
    let counted = Counted {
        inner: r,
        n: n.clone(),
    };
    let mut values = serde_json::Deserializer::from_reader(counted).into_iter::<Line>();
    let mut head = match values.next() {
        Some(Ok(h)) if h.ty == "CityJSON" => h,
        Some(Err(e)) => return Err(read(&e)),
        _ => return Err(Stop::Declined("not CityJSON".into())),
    };
    let version = head.version.clone().unwrap_or_default();
    let srs_name = head.metadata.as_ref().and_then(Metadata::srs_name);
    let transform = head.transform;
    let kept = head.templates.take();
    let templates = kept.as_ref();
    let template_list = template_vertices(templates, path).map_err(Stop::Read)?;
    let shared = Shared {
        version: Some(model_version(&version)),
        srs_name: srs_name.clone(),
    };
    let mut mapper = Mapper::new(path);
    check_version(&mut mapper, &version);
    let mut source = FromSource::default();
    let mut links = Links::default();
    let mut reported = 0u64;
    let mut hand_over = |mapper: Mapper, source| {
        let (buildings, assets, _, warnings, counts) = mapper.finish();
        let mut file = source_file(path, &version, srs_name.clone(), gzip, len, counts);
        if let Some(c) = &mut file.cityjson {
            c.seq = true;
        }
        let at = n.get();
        let parts = (buildings, assets, warnings);
        let chunk = part(file, parts, (reported, at), source);
        if at > reported {
            passed(at - reported);
            reported = at;
        }
        each(chunk).map_err(Stop::Each)
    };
    let mut line = 0u64;
    let mut next = Some(head);
    let mut from = 0u64;
    while let Some(l) = next.take() {
        let list =
            real_vertices(&l.vertices, transform.as_ref(), path, line).map_err(Stop::Read)?;
        let verts = Vertices {
            list: &list,
            templates,
            template_list: &template_list,
        };
        let mut typed = Vec::with_capacity(l.objects.0.len());
        let mut copied = Vec::with_capacity(l.objects.0.len());
        for (id, o) in l.objects.0 {
            let at = |m: String| Stop::Read(CityJsonError::at(path, line.max(1), Some(&id), m));
            let t = serde_json::from_str::<CityObject>(o.get()).map_err(|e| at(e.to_string()))?;
            let c = serde_json::from_str::<Copied>(o.get()).map_err(|e| at(e.to_string()))?;
            links.add(&id, &t).map_err(Stop::Declined)?;
            typed.push((id, t));
            copied.push(c);
        }
        let before = mapper.origins.len();
        mapper.add(&typed, &verts, line).map_err(Stop::Read)?;
        let mut wanted: HashMap<&str, Vec<(usize, usize, usize)>> = HashMap::new();
        for (i, o) in mapper.origins[before..].iter().enumerate() {
            if let Some((g, s)) = o.surface {
                let w = wanted.entry(o.object.as_str()).or_default();
                w.push((before + i, g, s));
            }
        }
        for ((id, _), c) in typed.iter().zip(copied) {
            let w = wanted.get(id.as_str()).map_or(&[][..], Vec::as_slice);
            add_object(&mut source, id.clone(), &mut c.into_object(), w);
        }
        drop(wanted);
        line += if line == 0 { 2 } else { 1 };
        next = match values.next() {
            None => None,
            Some(Err(e)) => return Err(read(&e)),
            Some(Ok(f)) if f.ty != "CityJSONFeature" => {
                return Err(Stop::Declined(format!(
                    "line {line}: a value of type {:?} after the CityJSON header",
                    f.ty
                )))
            }
            Some(Ok(f)) => Some(f),
        };
        // the header goes with the first feature
        if next.is_none() || (line > 2 && n.get() - from >= chunk_bytes) {
            from = n.get();
            let m = std::mem::replace(&mut mapper, Mapper::new(path));
            hand_over(m, std::mem::take(&mut source))?;
            links.cut();
        }
    }
    Ok(shared)
}

#[cfg(test)]
mod tests {
    use super::*;

    const SEQ: &str = r#"{"type":"CityJSON","version":"2.0","transform":{"scale":[0.01,0.01,0.01],"translate":[100,200,0]},"CityObjects":{},"vertices":[]}
{"type":"CityJSONFeature","id":"b","CityObjects":{"p":{"type":"BuildingPart","parents":["b"],"geometry":[{"type":"MultiSurface","lod":"2","boundaries":[[[0,1,2]]],"semantics":{"surfaces":[{"type":"RoofSurface","slope":9}],"values":[0]}}]},"b":{"type":"Building","children":["p"],"attributes":{"h":1}}},"vertices":[[0,0,0],[100,0,0],[0,100,0]]}
{"type":"CityJSONFeature","id":"c","CityObjects":{"c":{"type":"Building","geometry":[{"type":"MultiSurface","lod":"1","boundaries":[[[0,1,2]]]}]}},"vertices":[[0,0,0],[100,0,0],[0,100,0]]}
{"type":"CityJSONFeature","id":"d","CityObjects":{"d":{"type":"Building","geometry":[{"type":"MultiSurface","lod":"1","boundaries":[[[0,1,2]]]}]}},"vertices":[[5,0,0],[100,0,0],[0,100,0]]}
"#;

    /// Each chunk's model and source, or why the stream stopped.
    fn chunks(doc: &str, chunk: u64) -> Result<Vec<Part>, Stop<()>> {
        let mut out = Vec::new();
        stream_seq(
            Input::Bytes(doc.as_bytes()),
            "s.city.jsonl".as_ref(),
            chunk,
            &|_| {},
            |c| {
                out.push(c);
                Ok(())
            },
        )?;
        Ok(out)
    }

    #[test]
    fn chunks_of_lines_are_the_whole_read_s() {
        let whole = crate::io::cityjson::read_slice(SEQ.as_bytes(), "s.city.jsonl".as_ref());
        let whole = whole.unwrap();
        let Ok(c) = chunks(SEQ, 1) else {
            panic!("stopped")
        };
        // a chunk a line (the header's, without objects, goes with the first feature)
        assert_eq!(c.len(), 3);
        let assets: Vec<_> = c.iter().flat_map(|c| c.model.assets.clone()).collect();
        let ids: Vec<_> = c
            .iter()
            .flat_map(|c| c.model.buildings.iter().map(|b| b.id.clone()))
            .collect();
        let whole_ids: Vec<_> = whole.buildings.iter().map(|b| b.id.clone()).collect();
        assert_eq!(ids, whole_ids);
        let lines: Vec<u64> = assets.iter().map(|a| a.line).collect();
        assert_eq!(
            lines,
            whole.assets.iter().map(|a| a.line).collect::<Vec<_>>()
        );
        assert_eq!(lines, [2, 3, 4]);
        for (a, b) in assets.iter().zip(&whole.assets) {
            assert_eq!(a.detail_polygons(), b.detail_polygons());
        }
        assert_eq!(c[0].model.buildings[0].parent, Some(1));
        assert!(c[0].model.files[0].cityjson.as_ref().is_some_and(|j| j.seq));
        let s = &c[0].source;
        assert_eq!(s.objects.get("b").map(|a| a["h"].clone()), Some(1.into()));
        assert_eq!(
            s.surfaces.get(&0).map(|m| m["slope"].clone()),
            Some(9.into())
        );
        let counts: Vec<_> = c.iter().map(|c| c.model.buildings.len()).collect();
        assert_eq!(counts, [2, 1, 1]);
        let Ok(one) = chunks(SEQ, u64::MAX) else {
            panic!("stopped")
        };
        assert_eq!(one.len(), 1);
        assert_eq!(one[0].model.assets, whole.assets);
        assert_eq!(one[0].model.buildings, whole.buildings);
    }

    #[test]
    fn links_between_lines_and_bad_lines_decline() {
        // `c` names `d`, on the next line, as its child: chunks could differ
        let linked = SEQ.replace(
            r#""c":{"type":"Building","#,
            r#""c":{"type":"Building","children":["d"],"#,
        );
        assert!(matches!(chunks(&linked, 1), Err(Stop::Declined(_))));
        assert!(chunks(&linked, u64::MAX).is_ok(), "one chunk holds both");
        let twice = SEQ.replace(r#"{"d":{"#, r#"{"c":{"#);
        assert!(matches!(chunks(&twice, 1), Err(Stop::Declined(_))));
        // a vertex index out of range: the file, the line, the object
        let bad = SEQ.replace(
            "[[[0,1,2]]]}]}},\"vertices\":[[5",
            "[[[0,1,7]]]}]}},\"vertices\":[[5",
        );
        assert_ne!(bad, SEQ);
        let Err(Stop::Read(e)) = chunks(&bad, 1) else {
            panic!("a bad vertex index is an error")
        };
        assert_eq!((e.line, e.id.as_deref()), (4, Some("d")), "{e}");
        assert!(e.to_string().starts_with("s.city.jsonl:4:"), "{e}");
        let truncated = &SEQ[..SEQ.len() - 20];
        let Err(Stop::Read(e)) = chunks(truncated, 1) else {
            panic!("a truncated line is an error")
        };
        assert_eq!(e.line, 4, "{e}");
    }
}
