//! `subset`, `filter-lods` and `upgrade` of CityJSON 1.x / 2.0 documents and CityJSONSeq, into
//! CityJSON (CityJSONSeq for a CityJSONSeq source): the rules of the CityGML edits
//! ([`crate::export::transform::citygml::edit`]) applied to CityJSON's city objects, as `cjio` users know them.
//!
//! # How
//! The unit of an edit is a **tree**: a top-level city object (one without `parents`) and its
//! descendants (`children`, followed recursively: parts, installations, group members), as a
//! CityGML `cityObjectMember` holds its nested features. A rule keeps or drops a tree whole
//! ([`subset`]: children follow their parent, as `cjio subset` does) or removes geometries
//! and nested objects from it ([`filter_lods`]). Then, in what stays:
//!
//! * `children` / `parents` entries naming removed objects are pruned (an emptied list goes);
//! * vertices are renumbered in order of first use and the unused ones dropped; `transform`,
//!   `geometry-templates` (their own vertices), `appearance`, `extensions` and every
//!   attribute are kept as they are;
//! * `metadata.geographicalExtent` is recomputed from the vertices that stay (real
//!   coordinates: `transform` applied), removed when none stay; city objects' own
//!   `geographicalExtent`s are kept as they are.
//!
//! A `.city.json` document is streamed in three passes, one city object and one vertex at a
//! time, its top-level members in any order (`stream.rs`, `document.rs`): memory follows the
//! trees being decided, plus about 20 bytes per vertex (the stored vertices and their new
//! numbers) and 50 per city object (the tree structure as id hashes), not the file.
//! **CityJSONSeq** is streamed in two passes, one feature line at a time (memory follows the
//! largest feature): the first decides and records the box of what stays and the ids that go
//! (8 bytes each), the second writes the header with the recomputed extent, then each kept
//! feature.
//!
//! The box of a tree (for `--bbox`) is that of its vertices, `transform` applied; a
//! `GeometryInstance` counts by its reference point (as the CityGML edit counts an implicit
//! geometry's reference point), not its template.
//!
//! # Example
//! ```
//! use skylod::export::transform::subset_cityjson;
//! use skylod::export::transform::Subset;
//! let dir = tempfile::tempdir().unwrap();
//! let src = dir.path().join("in.city.json");
//! std::fs::write(&src, br#"{"type":"CityJSON","version":"2.0",
//!   "transform":{"scale":[1,1,1],"translate":[0,0,0]},
//!   "CityObjects":{"a":{"type":"Building","children":["a1"]},
//!     "a1":{"type":"BuildingPart","parents":["a"],
//!       "geometry":[{"type":"MultiSurface","lod":"1","boundaries":[[[2,3,4]]]}]},
//!     "b":{"type":"Building","geometry":[{"type":"MultiSurface","lod":"1","boundaries":[[[0,1,2]]]}]}},
//!   "vertices":[[90,0,0],[99,9,9],[0,0,0],[2,0,0],[2,1,3]]}"#).unwrap();
//! let out = dir.path().join("out.city.json");
//! let rule = Subset { ids: vec!["a".into()], ..Subset::default() };
//! let s = subset_cityjson(&src, &out, &rule, &Default::default()).unwrap();
//! assert_eq!((s.members, s.members_kept), (2, 1));
//! let doc: serde_json::Value = serde_json::from_slice(&std::fs::read(&out).unwrap()).unwrap();
//! assert!(doc["CityObjects"]["a1"].is_object() && doc["CityObjects"]["b"].is_null());
//! assert_eq!(doc["vertices"], serde_json::json!([[0,0,0],[2,0,0],[2,1,3]]));
//! assert_eq!(doc["metadata"]["geographicalExtent"], serde_json::json!([0.0,0.0,0.0,2.0,1.0,3.0]));
//! ```

mod document;
mod reproject;
mod rules;
pub(crate) mod stream;
use stream::{cj, cj_error, forest, id_hash};
mod upgrade;

pub use reproject::reproject_cityjson;
pub use rules::{filter_lods, subset};
pub use upgrade::upgrade_cityjson;

use crate::export::transform::citygml::edit::EditSummary;
use crate::io::citygml::error::WriteError;
use crate::io::citygml::write::{atomic_write, check_target, WriteOptions};
use crate::model::Bbox;
use glam::DVec3;
use serde_json::{Map, Value};
use std::collections::{HashMap, HashSet};
use std::io::{BufRead, Write};
use std::path::Path;

/// `transform` as `(scale, translate)`.
pub(crate) type Transform = ([f64; 3], [f64; 3]);

/// The vertices a tree's boundaries index: a CityJSONSeq feature's values, or a document's
/// vertices as its first pass stored them.
#[derive(Clone, Copy)]
pub(crate) enum Verts<'a> {
    Values(&'a [Value]),
    Store(&'a [stream::Vertex]),
}

/// What a rule knows of the document besides the tree.
pub(crate) struct Ctx<'a> {
    /// The vertices the tree's boundaries index (the document's, or the feature's).
    pub verts: Verts<'a>,
    /// `transform` as `(scale, translate)`.
    pub transform: Option<Transform>,
    /// `geometry-templates.templates`.
    pub templates: Option<&'a [Value]>,
    /// `metadata.referenceSystem` as text.
    pub srs: Option<&'a str>,
}

impl Ctx<'_> {
    /// The real coordinates of vertex `i`.
    fn point(&self, i: usize) -> Option<DVec3> {
        let p = match self.verts {
            Verts::Values(vs) => {
                let v = vs.get(i)?.as_array()?;
                let c = |k: usize| v.get(k).and_then(Value::as_f64);
                [c(0)?, c(1)?, c(2)?]
            }
            Verts::Store(vs) => vs.get(i)?.coords()?,
        };
        Some(match self.transform {
            Some((s, t)) => DVec3::new(p[0] * s[0] + t[0], p[1] * s[1] + t[1], p[2] * s[2] + t[2]),
            None => DVec3::from_array(p),
        })
    }

    /// The integer LoD of a geometry (`"2.2"` → 2; a `GeometryInstance` has its template's).
    pub fn lod(&self, g: &Value) -> Option<u8> {
        let lod = if g.get("type").and_then(Value::as_str) == Some("GeometryInstance") {
            let t = g.get("template").and_then(Value::as_u64)?;
            self.templates?.get(usize::try_from(t).ok()?)?.get("lod")?
        } else {
            g.get("lod")?
        };
        let text = match lod {
            Value::String(s) => s.clone(),
            Value::Number(n) => n.to_string(),
            _ => return None,
        };
        let d = text.trim().chars().next()?.to_digit(10)?;
        u8::try_from(d).ok()
    }

    /// The sum and count of the vertices geometry `g` uses, each use counted (a
    /// `GeometryInstance`: its reference point), as cjio sums them for a centroid.
    pub fn add_uses(&self, g: &Value, (sum, count): &mut (DVec3, u64)) {
        let mut each = |i: usize| {
            if let Some(p) = self.point(i) {
                *sum += p;
                *count += 1;
            }
        };
        if let Some(bd) = g.get("boundaries") {
            for_each_index(bd, &mut each);
        }
    }

    /// The box of the vertices geometry `g` uses (a `GeometryInstance`: its reference point).
    pub fn add_box(&self, g: &Value, b: &mut Bbox) {
        let mut each = |i: usize| {
            if let Some(p) = self.point(i) {
                b.add(p);
            }
        };
        if let Some(bd) = g.get("boundaries") {
            for_each_index(bd, &mut each);
        }
    }
}

/// Every vertex index in nested boundary arrays.
fn for_each_index(v: &Value, f: &mut dyn FnMut(usize)) {
    match v {
        Value::Array(a) => a.iter().for_each(|x| for_each_index(x, f)),
        Value::Number(n) => {
            if let Some(i) = n.as_u64().and_then(|i| usize::try_from(i).ok()) {
                f(i);
            }
        }
        _ => {}
    }
}

/// A decision on one tree: drop it, or keep it without the listed nested objects (the rule
/// may also have removed geometries from the objects).
pub(crate) enum Decision {
    Drop,
    Keep(Vec<String>),
}

/// An edit of CityJSON trees. A rule is made afresh for each pass (CityJSONSeq) and must
/// decide the same way both times.
pub(crate) trait TreeRule {
    /// Decide on the tree `ids` (the top-level object first, then its descendants) of
    /// `objects`.
    fn tree(
        &mut self,
        ids: &[String],
        objects: &mut Map<String, Value>,
        ctx: &Ctx<'_>,
        counts: &mut EditSummary,
    ) -> Result<Decision, String>;
}

/// The trees of `objects`: each top-level object (no `parents` naming an object present)
/// followed by its descendants, in document order; objects reached by no top (a cycle) are
/// trees of their own.
pub(crate) fn trees(objects: &Map<String, Value>) -> Vec<Vec<String>> {
    let keys: Vec<&str> = objects.keys().map(String::as_str).collect();
    let index: HashMap<&str, u32> = keys
        .iter()
        .enumerate()
        .map(|(i, k)| (*k, i as u32))
        .collect();
    let refs = |key: &str| -> Vec<Vec<&str>> {
        objects
            .values()
            .map(|o| {
                o.get(key)
                    .and_then(Value::as_array)
                    .map(|a| a.iter().filter_map(Value::as_str).collect())
                    .unwrap_or_default()
            })
            .collect()
    };
    forest(&index, &keys, &refs("parents"), &refs("children"))
        .into_iter()
        .map(|t| {
            t.into_iter()
                .map(|i| keys[i as usize].to_string())
                .collect()
        })
        .collect()
}

/// What an edit did to one group of objects (a document, a feature).
struct Applied {
    /// The box of the vertices that stay.
    kept: Bbox,
}

/// Apply `rule` to every tree of `objects` (decisions only: the ids that go into `removed`).
fn decide(
    objects: &mut Map<String, Value>,
    ctx: &Ctx<'_>,
    rule: &mut dyn TreeRule,
    counts: &mut EditSummary,
    removed: &mut HashSet<u64>,
) -> Result<(), String> {
    for ids in trees(objects) {
        counts.members += 1;
        match rule.tree(&ids, objects, ctx, counts)? {
            Decision::Drop => {
                for id in &ids {
                    objects.shift_remove(id.as_str());
                    removed.insert(id_hash(id));
                }
            }
            Decision::Keep(gone) => {
                counts.members_kept += 1;
                for id in &gone {
                    objects.shift_remove(id.as_str());
                    removed.insert(id_hash(id));
                }
            }
        }
    }
    Ok(())
}

/// Prune the `children` / `parents` entries of `objects` that name removed objects.
fn prune(objects: &mut Map<String, Value>, removed: &HashSet<u64>, counts: &mut EditSummary) {
    if removed.is_empty() {
        return;
    }
    for o in objects.values_mut() {
        prune_object(o, removed, &mut counts.references_pruned);
    }
}

/// Prune the `children` / `parents` entries of `o` that name removed objects, counted in
/// `pruned`.
fn prune_object(o: &mut Value, removed: &HashSet<u64>, pruned: &mut usize) {
    if removed.is_empty() {
        return;
    }
    let Some(o) = o.as_object_mut() else { return };
    for key in ["children", "parents"] {
        let Some(Value::Array(a)) = o.get_mut(key) else {
            continue;
        };
        let before = a.len();
        a.retain(|v| v.as_str().is_none_or(|s| !removed.contains(&id_hash(s))));
        *pruned += before - a.len();
        if a.is_empty() {
            o.shift_remove(key);
        }
    }
}

/// Renumber the vertices `objects` use (order of first use), dropping the others; the box of
/// those that stay.
fn renumber(
    objects: &mut Map<String, Value>,
    vertices: &mut Vec<Value>,
    ctx_transform: Option<Transform>,
) -> Result<Applied, String> {
    let mut map = vec![u32::MAX; vertices.len()];
    let mut order: Vec<u32> = Vec::new();
    for (id, o) in objects.iter_mut() {
        renumber_object(id, o, &mut map, &mut order)?;
    }
    let mut old = std::mem::take(vertices);
    let mut kept = Bbox::EMPTY;
    vertices.reserve(order.len());
    for &i in &order {
        let v = std::mem::take(&mut old[i as usize]);
        vertices.push(v);
    }
    let ctx = Ctx {
        verts: Verts::Values(vertices),
        transform: ctx_transform,
        templates: None,
        srs: None,
    };
    for i in 0..vertices.len() {
        if let Some(p) = ctx.point(i) {
            kept.add(p);
        }
    }
    Ok(Applied { kept })
}

/// Number the vertices object `id` uses through `map` (old index → new, `u32::MAX` for not
/// yet numbered), each new one in order of first use (appended to `order`), and rewrite its
/// boundaries with the new numbers.
fn renumber_object(
    id: &str,
    o: &mut Value,
    map: &mut [u32],
    order: &mut Vec<u32>,
) -> Result<(), String> {
    let n = map.len();
    let mut bad = None;
    fn walk(v: &mut Value, map: &mut [u32], order: &mut Vec<u32>, bad: &mut Option<u64>) {
        match v {
            Value::Array(a) => a.iter_mut().for_each(|x| walk(x, map, order, bad)),
            Value::Number(num) => {
                let Some(i) = num.as_u64() else { return };
                let Some(slot) = usize::try_from(i).ok().and_then(|k| map.get_mut(k)) else {
                    *bad = Some(i);
                    return;
                };
                if *slot == u32::MAX {
                    *slot = order.len() as u32;
                    order.push(i as u32);
                }
                *v = Value::from(*slot);
            }
            _ => {}
        }
    }
    let Some(Value::Array(gs)) = o.get_mut("geometry") else {
        return Ok(());
    };
    for g in gs {
        if let Some(b) = g.get_mut("boundaries") {
            walk(b, map, order, &mut bad);
        }
        if let Some(i) = bad {
            return Err(format!(
                "city object {id}: vertex index {i} out of range ({n} vertices)"
            ));
        }
    }
    Ok(())
}

/// `metadata.referenceSystem` of a header as CRS text.
pub(crate) fn srs_of(head: &Value) -> Option<String> {
    crate::io::cityjson::reference_system_text(head.get("metadata")?.get("referenceSystem")?)
}

/// `transform` of a document as `(scale, translate)`.
pub(crate) fn transform_of(head: &Value) -> Option<Transform> {
    let t = head.get("transform")?;
    let three = |k: &str| -> Option<[f64; 3]> {
        let a = t.get(k)?.as_array()?;
        Some([
            a.first()?.as_f64()?,
            a.get(1)?.as_f64()?,
            a.get(2)?.as_f64()?,
        ])
    };
    Some((three("scale")?, three("translate")?))
}

/// Set (or remove, for an empty box) `metadata.geographicalExtent` of `head`.
pub(crate) fn set_extent(head: &mut Value, b: &Bbox) {
    let Some(h) = head.as_object_mut() else {
        return;
    };
    match b.to_array() {
        Some(e) => {
            let meta = h
                .entry("metadata")
                .or_insert_with(|| Value::Object(Map::new()));
            if let Some(m) = meta.as_object_mut() {
                m.insert("geographicalExtent".into(), serde_json::json!(e));
            }
        }
        None => {
            if let Some(m) = h.get_mut("metadata").and_then(Value::as_object_mut) {
                m.shift_remove("geographicalExtent");
            }
        }
    }
}

/// The JSON values of a (possibly gzip-compressed) CityJSON / CityJSONSeq source, one at a time,
/// and the bytes read so far.
pub(crate) struct Values {
    inner: serde_json::StreamDeserializer<
        'static,
        serde_json::de::IoRead<Box<dyn BufRead + Send>>,
        Value,
    >,
    pub(crate) input: std::path::PathBuf,
    /// Values read so far: the line of the last one (a CityJSONSeq has one a line).
    line: u64,
}

impl Values {
    pub(crate) fn open(input: &Path) -> Result<Values, WriteError> {
        let r = stream::open_json(input)?;
        Ok(Values {
            inner: serde_json::Deserializer::from_reader(r).into_iter::<Value>(),
            input: input.to_path_buf(),
            line: 0,
        })
    }

    pub(crate) fn next(&mut self) -> Result<Option<Value>, WriteError> {
        match self.inner.next() {
            None => Ok(None),
            Some(Ok(v)) => {
                self.line += 1;
                Ok(Some(v))
            }
            Some(Err(e)) => Err(cj_error(crate::io::cityjson::CityJsonError::json(
                &self.input,
                &e,
            ))),
        }
    }

    /// Write `head`, then each further value that `each` keeps (edited in place; given its
    /// line), to `out` as CityJSONSeq, atomically: the bytes written.
    fn write_seq(
        &mut self,
        out: &Path,
        head: &Value,
        mut each: impl FnMut(u64, &mut Value) -> Result<bool, WriteError>,
    ) -> Result<u64, WriteError> {
        let io = |e| WriteError::Io {
            file: out.to_path_buf(),
            source: e,
        };
        atomic_write(out, |w| {
            let mut n = write_line(w, head).map_err(io)?;
            while let Some(mut f) = self.next()? {
                if each(self.line, &mut f)? {
                    n += write_line(w, &f).map_err(io)?;
                }
            }
            Ok(n)
        })
    }

    /// The header: the first value, of type `CityJSON`.
    pub(crate) fn header(&mut self) -> Result<Value, WriteError> {
        let Some(head) = self.next()? else {
            return Err(cj(&self.input, 0, None, "empty document".into()));
        };
        let ty = head.get("type").and_then(Value::as_str).unwrap_or("");
        if ty != "CityJSON" {
            let m = format!("the first object is of type {ty:?}, not \"CityJSON\"");
            return Err(cj(&self.input, 1, None, m));
        }
        Ok(head)
    }

    fn bytes(&self) -> u64 {
        self.inner.byte_offset() as u64
    }
}

/// Run `make`'s rule over the CityJSON / CityJSONSeq document at `input` into `out` (see the
/// module docs); with no `out`, the decisions only: the rule sees every tree and nothing is
/// written.
pub(crate) fn run<'r>(
    input: &Path,
    out: Option<&Path>,
    opts: &WriteOptions,
    make: &dyn Fn() -> Box<dyn TreeRule + 'r>,
) -> Result<EditSummary, WriteError> {
    if let Some(out) = out {
        check_target(out, opts, std::iter::once(input))?;
        check_json_target(out)?;
    }
    let mut collected = document::Collected::default();
    let seen = stream::read(input, input, &mut collected)?;
    if !seen.more {
        check_document(input, &collected.head, &seen)?;
        return document::run(input, out, collected, seen.bytes, make);
    }
    drop(collected);
    let mut values = Values::open(input)?;
    let mut head = values.header()?;
    let Some(first) = values.next()? else {
        return Err(cj(input, 0, None, changed()));
    };
    // CityJSONSeq, pass 1: decisions, the box of what stays, the ids that go.
    let seq = Seq::new(input, &head);
    let mut removed = HashSet::new();
    let mut kept = Bbox::EMPTY;
    let mut scratch = EditSummary::default();
    let mut rule = make();
    let mut feature = Some(first);
    while let Some(mut f) = feature.take() {
        let (b, _) = edit_feature(
            &seq,
            values.line,
            &mut f,
            &mut *rule,
            &mut scratch,
            &mut removed,
            None,
        )?;
        if let Some(b) = b {
            kept.add(b.min);
            kept.add(b.max);
        }
        feature = values.next()?;
    }
    let Some(out) = out else {
        return Ok(scratch);
    };
    // Pass 2: the same decisions, references pruned, written.
    set_extent(&mut head, &kept);
    let mut counts = EditSummary::default();
    let mut rule = make();
    let mut values = Values::open(input)?;
    values.header()?;
    let mut again = HashSet::new();
    counts.bytes_out = values.write_seq(out, &head, |line, f| {
        let prune = Some(&removed);
        let (_, keep) = edit_feature(&seq, line, f, &mut *rule, &mut counts, &mut again, prune)?;
        Ok(keep)
    })?;
    counts.bytes_in = values.bytes();
    Ok(counts)
}

/// `geometry-templates.templates` of a header.
fn templates_of(head: &Value) -> Option<Vec<Value>> {
    head.get("geometry-templates")?
        .get("templates")?
        .as_array()
        .cloned()
}

/// A CityJSONSeq being edited: what the edit of each feature takes from the header.
struct Seq<'a> {
    input: &'a Path,
    transform: Option<Transform>,
    templates: Option<Vec<Value>>,
    srs: Option<String>,
}

impl<'a> Seq<'a> {
    fn new(input: &'a Path, head: &Value) -> Self {
        Seq {
            input,
            transform: transform_of(head),
            templates: templates_of(head),
            srs: srs_of(head),
        }
    }
}

/// Edit feature `f` of `seq` (on line `line`) in place: `(box of what stays, whether
/// anything stays)`.
fn edit_feature(
    seq: &Seq<'_>,
    line: u64,
    f: &mut Value,
    rule: &mut dyn TreeRule,
    counts: &mut EditSummary,
    removed: &mut HashSet<u64>,
    prune_with: Option<&HashSet<u64>>,
) -> Result<(Option<Bbox>, bool), WriteError> {
    let (input, transform) = (seq.input, seq.transform);
    let id = f.get("id").and_then(Value::as_str).map(str::to_string);
    let Some(fo) = f.as_object_mut() else {
        return Err(cj(
            input,
            line,
            None,
            "a line that is not a JSON object".into(),
        ));
    };
    let mut objects = match fo.shift_remove("CityObjects") {
        Some(Value::Object(m)) => m,
        _ => return Err(cj(input, line, id.as_deref(), "no \"CityObjects\"".into())),
    };
    let mut vertices = match fo.shift_remove("vertices") {
        Some(Value::Array(v)) => v,
        None => Vec::new(),
        Some(_) => {
            return Err(cj(
                input,
                line,
                id.as_deref(),
                "\"vertices\" is not an array".into(),
            ))
        }
    };
    let ctx = Ctx {
        verts: Verts::Values(&vertices),
        transform,
        templates: seq.templates.as_deref(),
        srs: seq.srs.as_deref(),
    };
    let err = |m: String| cj(input, line, id.as_deref(), m);
    decide(&mut objects, &ctx, rule, counts, removed).map_err(err)?;
    if let Some(r) = prune_with {
        prune(&mut objects, r, counts);
    }
    let applied = renumber(&mut objects, &mut vertices, transform).map_err(err)?;
    let keep = !objects.is_empty();
    if keep {
        if let Some(first) = objects.keys().next() {
            if id.as_deref().is_none_or(|i| !objects.contains_key(i)) {
                fo.insert("id".into(), Value::String(first.clone()));
            }
        }
    }
    fo.insert("CityObjects".into(), Value::Object(objects));
    fo.insert("vertices".into(), Value::Array(vertices));
    Ok(((!applied.kept.is_empty()).then_some(applied.kept), keep))
}

/// A document's first pass, checked: of type `CityJSON`, with `CityObjects`.
fn check_document(
    input: &Path,
    head: &Map<String, Value>,
    seen: &stream::Seen,
) -> Result<(), WriteError> {
    check_type(input, head)?;
    if !seen.objects {
        return Err(cj(input, 1, None, "no \"CityObjects\"".into()));
    }
    Ok(())
}

/// A document's members: of type `CityJSON`.
pub(crate) fn check_type(input: &Path, head: &Map<String, Value>) -> Result<(), WriteError> {
    let ty = head.get("type").and_then(Value::as_str).unwrap_or("");
    if ty != "CityJSON" {
        let m = format!("the first object is of type {ty:?}, not \"CityJSON\"");
        return Err(cj(input, 1, None, m));
    }
    Ok(())
}

/// The error of a source that changed between two passes over it.
fn changed() -> String {
    "the document changed while it was read".into()
}

/// `v` as one line of JSON.
pub(crate) fn write_line(w: &mut dyn Write, v: &Value) -> std::io::Result<u64> {
    let bytes = serde_json::to_vec(v).map_err(std::io::Error::other)?;
    w.write_all(&bytes)?;
    w.write_all(b"\n")?;
    Ok(bytes.len() as u64 + 1)
}

/// A CityJSON source is written as CityJSON: a CityGML name for the output is refused (name
/// it `.city.json` / `.city.jsonl`, or use `convert`).
pub(crate) fn check_json_target(out: &Path) -> Result<(), WriteError> {
    let name = out
        .file_name()
        .map(|n| n.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let name = name.strip_suffix(".gz").unwrap_or(&name);
    if name.ends_with(".gml") || name.ends_with(".xml") {
        return Err(WriteError::Invalid(format!(
            "{}: a CityJSON input is written as CityJSON (name the output .city.json or \
             .city.jsonl; `skylod convert` writes CityGML from it)",
            out.display()
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests;
