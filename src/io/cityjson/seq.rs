//! CityJSONSeq (`.city.jsonl`) read in chunks of whole lines: the same [`Part`]s as
//! [`super::chunks`] gives of a document, from one pass over the file. The first line is the
//! header (`transform`, `metadata`, `geometry-templates`); each feature line is one
//! top-level city object with its children and its own vertices, mapped with its line
//! number in warnings and assets.
//! A chunk ends after the line that takes it past `chunk_bytes` of the file; memory follows
//! the chunk, and what grows with the file is the ids of the city objects as 8-byte hashes
//! (to find a link between chunks).
//!
//! The stream declines (the file is read as one chunk) where chunks could differ from one:
//! an object linked (`parents`, `children`) with an object of another chunk, or with the
//! id of one.

use super::chunks::{map_objects, not_cityjson, part, Input, Part, Shared, Stop};
use super::doc::{CityObject, Doc as Line, Metadata};
use super::head::{check_version, model_version, source_file, template_vertices};
use super::map::{real_vertices, Mapper, Vertices};
use super::source::FromSource;
use super::stream::{id_hash, Counted};
use super::CityJsonError;
use std::cell::Cell;
use std::collections::HashSet;
use std::path::Path;
use std::rc::Rc;

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
        // an id given twice in one chunk is mapped as the whole read maps it
        if self.earlier.contains(&h) {
            return Err(format!("city object id {id:?} given twice"));
        }
        self.ids.insert(h);
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

/// The values of a CityJSONSeq, a line's each, parsed from a slice or a reader.
enum Lines<'a> {
    Slice(serde_json::StreamDeserializer<'a, serde_json::de::SliceRead<'a>, Line>),
    Reader(
        serde_json::StreamDeserializer<
            'a,
            serde_json::de::IoRead<Counted<Box<dyn std::io::BufRead + 'a>>>,
            Line,
        >,
        Rc<Cell<u64>>,
    ),
}

impl Lines<'_> {
    fn next(&mut self) -> Option<Result<Line, serde_json::Error>> {
        match self {
            Lines::Slice(s) => s.next(),
            Lines::Reader(r, _) => r.next(),
        }
    }

    /// Bytes read so far.
    fn read(&self) -> u64 {
        match self {
            Lines::Slice(s) => s.byte_offset() as u64,
            Lines::Reader(_, n) => n.get(),
        }
    }
}

/// [`super::chunks::stream`] of CityJSONSeq (module docs).
///
/// # Errors
/// `each`'s; a line that does not read ([`Stop::Read`]); chunks that could differ from the
/// whole read decline.
pub(super) fn stream_seq<E>(
    input: Input<'_>,
    path: &Path,
    chunk_bytes: u64,
    passed: &dyn Fn(u64),
    mut each: impl FnMut(Part) -> Result<(), E>,
) -> Result<Shared, Stop<E>> {
    let read = |e: &serde_json::Error| Stop::Read(CityJsonError::json(path, e));
    let gzip = input.gzip();
    // the file's size (a chunk's model is of the whole file)
    let len = match input {
        _ if gzip => 0,
        Input::File(p) => std::fs::metadata(p).map_or(0, |m| m.len()),
        Input::Bytes(b) => b.len() as u64,
        Input::Gzip(_) => 0,
    };
    // as a slice where it is one: a parser's error is where the whole read's is
    let mut values = match input {
        Input::Bytes(b) => {
            let b = b.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(b);
            Lines::Slice(serde_json::Deserializer::from_slice(b).into_iter())
        }
        _ => {
            let n = Rc::new(Cell::new(0u64));
            let inner = input.open(path).map_err(Stop::Read)?;
            let counted = Counted {
                inner,
                n: n.clone(),
            };
            let d = serde_json::Deserializer::from_reader(counted);
            Lines::Reader(d.into_iter(), n)
        }
    };
    let mut head = match values.next() {
        Some(Ok(h)) if h.ty == "CityJSON" => h,
        Some(Ok(h)) => return Err(Stop::Read(not_cityjson(path, &h.ty))),
        Some(Err(e)) => return Err(read(&e)),
        None => {
            let m = "empty document".to_string();
            return Err(Stop::Read(CityJsonError::at(path, 0, None, m)));
        }
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
    let mut hand_over = |mapper: Mapper, source, at: u64| {
        let (buildings, assets, _, warnings, counts) = mapper.finish();
        let mut file = source_file(path, &version, srs_name.clone(), gzip, len, counts);
        if let Some(c) = &mut file.cityjson {
            c.seq = true;
        }
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
        let mut objects = l.objects.0;
        for (id, o) in &objects {
            links.add(id, o).map_err(Stop::Declined)?;
        }
        let copy = Some(&mut source);
        map_objects(&mut mapper, copy, &verts, &mut objects, line).map_err(Stop::Read)?;
        line += if line == 0 { 2 } else { 1 };
        next = match values.next() {
            None => None,
            Some(Err(e)) => return Err(read(&e)),
            Some(Ok(f)) if f.ty != "CityJSONFeature" => {
                let m = format!("a value of type {:?} after the CityJSON header (CityJSONSeq holds CityJSONFeature lines)", f.ty);
                return Err(Stop::Read(CityJsonError::at(
                    path,
                    line,
                    f.id.as_deref(),
                    m,
                )));
            }
            Some(Ok(f)) => Some(f),
        };
        // the header goes with the first feature
        if next.is_none() || (line > 2 && values.read() - from >= chunk_bytes) {
            from = values.read();
            let m = std::mem::replace(&mut mapper, Mapper::new(path));
            hand_over(m, std::mem::take(&mut source), from)?;
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
