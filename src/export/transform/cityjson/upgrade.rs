//! CityJSON 1.0 / 1.1 → 2.0, as `cjio upgrade` does it (cjio 0.10), CityJSONSeq streamed line
//! by line.
//!
//! * 1.1 → 2.0: `version`; `metadata.pointOfContact.address` as an object; the
//!   `+GenericCityObject` of cjio's `Generic` extension back to `GenericCityObject` (the
//!   extension entry removed).
//! * 1.0 → 1.1 first: `lod` as a string (geometries and templates); a `CityObjectGroup`'s
//!   `members` as `children`, its members given the group in `parents`; empty `geometry`
//!   arrays removed; `BridgeConstructionElement` → `BridgeConstructiveElement`;
//!   `metadata.referenceSystem` `urn:ogc:def:crs:EPSG::N` → `https://www.opengis.net/def/crs/EPSG/0/N`;
//!   a city object's `address` as an array; metadata members renamed
//!   (`datasetTitle` → `title`, ...) and the ones 1.1 has not dropped; a document without
//!   `transform` gets one (millimetres, translated to its lowest corner) and integer vertices.
//!
//! A 2.0 source is written unchanged (its `version` already says so).
//!
//! A `.city.json` document is streamed ([`super::stream`]): a first pass reads its small
//! members, counts its city objects, notes the members of 1.0 groups and the lowest corner of
//! the vertices; then the document is written member by member, the city objects and the
//! vertices read again one at a time.

use super::stream::{self, EachObject, EachVertex, Pass, Vertex};
use super::{check_json_target, check_type, Values};
use crate::io::citygml::error::WriteError;
use crate::io::citygml::write::{check_target, WriteOptions};
use serde_json::{Map, Value};
use std::collections::HashMap;
use std::path::Path;

/// What [`upgrade_cityjson`] did.
#[derive(Debug, Clone, Default, PartialEq, Eq, serde::Serialize)]
#[non_exhaustive]
pub struct CityJsonUpgrade {
    /// The source's `version`.
    pub from: String,
    /// City objects written.
    pub objects: usize,
    /// What changed, with counts (`"lod as a string": 12`).
    pub changes: std::collections::BTreeMap<String, usize>,
    /// Bytes of the (decompressed) source.
    pub bytes_in: u64,
    /// Bytes written (before compression).
    pub bytes_out: u64,
}

impl CityJsonUpgrade {
    /// `a.city.json -> b.city.json: CityJSON 1.1 -> 2.0, 12 city object(s), ...`.
    pub fn describe(&self, input: &Path, out: &Path) -> String {
        let mut s = format!(
            "CityJSON {} -> 2.0, {} city object(s)",
            self.from, self.objects
        );
        for (what, n) in &self.changes {
            s += &format!(", {what} {n}");
        }
        s += &format!(", {} -> {} bytes", self.bytes_in, self.bytes_out);
        crate::model::made_line(input, out, &s)
    }

    fn note(&mut self, what: &str) {
        *self.changes.entry(what.to_string()).or_default() += 1;
    }
}

/// Upgrade the CityJSON / CityJSONSeq document at `input` to CityJSON 2.0 into `out`
/// (atomically; `-` for standard output; gzip for a name ending in `.gz`; see the module docs).
///
/// # Errors
/// A refused target (a CityGML name among them: `convert --citygml-version 3.0` writes
/// CityGML 3.0), a source that cannot be read or is not CityJSON, a version other than 1.0,
/// 1.1 and 2.0, I/O errors.
pub fn upgrade_cityjson(
    input: &Path,
    out: &Path,
    opts: &WriteOptions,
) -> Result<CityJsonUpgrade, WriteError> {
    check_target(out, opts, std::iter::once(input))?;
    check_json_target(out)?;
    let mut scan = Scan::default();
    let seen = stream::read(input, input, &mut scan)?;
    if !seen.more {
        check_type(input, &scan.head)?;
    }
    let mut s = CityJsonUpgrade {
        from: match scan.head.get("version") {
            Some(Value::String(v)) => v.clone(),
            Some(v) => v.to_string(),
            None => String::new(),
        },
        ..CityJsonUpgrade::default()
    };
    if !matches!(s.from.as_str(), "1.0" | "1.1" | "2.0") {
        return Err(super::cj(
            input,
            1,
            None,
            format!(
                "CityJSON version {:?}: upgrade reads 1.0, 1.1 and 2.0",
                s.from
            ),
        ));
    }
    let from = s.from.clone();
    if !seen.more {
        s.bytes_in = seen.bytes;
        s.bytes_out = upgrade_document(input, out, scan, &from, &mut s)?;
        return Ok(s);
    }
    drop(scan);
    let mut values = Values::open(input)?;
    let mut head = values.header()?;
    let generic = upgrade_header(&mut head, &from, &mut s, None);
    s.bytes_out = values.write_seq(out, &head, |_, f| {
        if let Some(objects) = f.get_mut("CityObjects").and_then(Value::as_object_mut) {
            upgrade_objects(objects, &from, generic, &mut s);
        }
        if from == "1.0" && f.get("transform").is_none() {
            compress_feature(f, &head);
        }
        Ok(true)
    })?;
    s.bytes_in = values.bytes();
    Ok(s)
}

/// What the first pass over a document learns.
#[derive(Default)]
struct Scan {
    /// The small members, `CityObjects` and `vertices` as `null` in their places.
    head: Map<String, Value>,
    /// Each object a 1.0 group lists as a member, with its groups in document order.
    groups: HashMap<String, Vec<String>>,
    /// The lowest corner of the vertices.
    lo: Option<[f64; 3]>,
}

impl Pass for Scan {
    fn members(&mut self) -> Option<&mut Map<String, Value>> {
        Some(&mut self.head)
    }
    fn place(&mut self, key: &str) {
        self.head.insert(key.to_string(), Value::Null);
    }
    fn wants_objects(&self) -> bool {
        true
    }
    fn object(&mut self, id: String, o: Value) -> Result<(), String> {
        for m in group_members(&o) {
            self.groups
                .entry(m.to_string())
                .or_default()
                .push(id.clone());
        }
        Ok(())
    }
    fn wants_vertices(&self) -> bool {
        true
    }
    fn vertex(&mut self, v: Vertex) -> Result<(), String> {
        let lo = self.lo.get_or_insert([f64::INFINITY; 3]);
        lowest(lo, |k| v.coord(k));
        Ok(())
    }
}

/// The members a 1.0 `CityObjectGroup` lists.
fn group_members(o: &Value) -> impl Iterator<Item = &str> {
    let group = o.get("type").and_then(Value::as_str) == Some("CityObjectGroup");
    o.get("members")
        .and_then(Value::as_array)
        .filter(|_| group)
        .into_iter()
        .flatten()
        .filter_map(Value::as_str)
}

/// The document scanned as `scan` upgraded from `from` into `out`: the bytes written.
fn upgrade_document(
    input: &Path,
    out: &Path,
    scan: Scan,
    from: &str,
    s: &mut CityJsonUpgrade,
) -> Result<u64, WriteError> {
    let Scan { head, groups, lo } = scan;
    let mut head = Value::Object(head);
    let lo = floor_corner(lo.unwrap_or([f64::INFINITY; 3]));
    let compress = (from == "1.0" && head.get("transform").is_none()).then_some(lo);
    let generic = upgrade_header(&mut head, from, s, Some(lo));
    let head = match head {
        Value::Object(m) => m,
        _ => Map::new(),
    };
    stream::write_document(out, &head, &mut |key, entries| {
        if key == "vertices" {
            let mut each = EachVertex(|v: Vertex| match compress {
                Some(lo) => {
                    let mut v = v.into_value();
                    quantize(&mut v, lo);
                    entries.vertex(&Vertex::from_value(v))
                }
                None => entries.vertex(&v),
            });
            return stream::read(input, input, &mut each).map(drop);
        }
        let mut each = EachObject(|id: String, mut o: Value| {
            upgrade_object(&id, &mut o, from, generic, &groups, s);
            entries.object(&id, &o)
        });
        stream::read(input, input, &mut each).map(drop)
    })
}

/// The header (the whole document for a CityJSONSeq header) to 2.0; whether cjio's `Generic`
/// extension was removed (its `+GenericCityObject`s to rename in the features too). `lo`: the
/// lowest corner of a streamed document's vertices (else taken from the header's).
fn upgrade_header(
    head: &mut Value,
    from: &str,
    s: &mut CityJsonUpgrade,
    lo: Option<[f64; 3]>,
) -> bool {
    let Some(h) = head.as_object_mut() else {
        return false;
    };
    if from == "2.0" {
        if let Some(o) = h.get("CityObjects").and_then(Value::as_object) {
            s.objects += o.len();
        }
        return false;
    }
    h.insert("version".into(), Value::String("2.0".into()));
    if from == "1.0" {
        if !h.contains_key("transform") {
            compress(h, s, lo);
        }
        if let Some(ts) = h
            .get_mut("geometry-templates")
            .and_then(|t| t.get_mut("templates"))
            .and_then(Value::as_array_mut)
        {
            for t in ts {
                lod_as_string(t, s);
            }
        }
        if let Some(m) = h.get_mut("metadata").and_then(Value::as_object_mut) {
            metadata_1_1(m, s);
        }
    }
    // 1.1 → 2.0
    if let Some(a) = h
        .get_mut("metadata")
        .and_then(|m| m.get_mut("pointOfContact"))
        .and_then(|p| p.get_mut("address"))
    {
        if !a.is_object() {
            *a = serde_json::json!({ "address": a.take() });
            s.note("metadata address as an object");
        }
    }
    let mut generic = false;
    if let Some(ext) = h.get_mut("extensions").and_then(Value::as_object_mut) {
        let cjio_generic = ext
            .get("Generic")
            .and_then(|g| g.get("url"))
            .and_then(Value::as_str)
            .is_some_and(|u| u.contains("cityjson.org/extensions/download/generic.ext.json"));
        if cjio_generic {
            ext.shift_remove("Generic");
            generic = true;
        }
        if ext.is_empty() {
            h.shift_remove("extensions");
        }
    }
    if let Some(objects) = h.get_mut("CityObjects").and_then(Value::as_object_mut) {
        upgrade_objects(objects, from, generic, s);
    }
    generic
}

/// The city objects of a document or feature to 2.0.
fn upgrade_objects(
    objects: &mut Map<String, Value>,
    from: &str,
    generic: bool,
    s: &mut CityJsonUpgrade,
) {
    let mut groups: HashMap<String, Vec<String>> = HashMap::new();
    for (id, o) in objects.iter() {
        for m in group_members(o) {
            groups.entry(m.to_string()).or_default().push(id.clone());
        }
    }
    for (id, o) in objects.iter_mut() {
        upgrade_object(id, o, from, generic, &groups, s);
    }
}

/// City object `id` to 2.0; `groups`: the 1.0 groups that list each object as a member.
fn upgrade_object(
    id: &str,
    o: &mut Value,
    from: &str,
    generic: bool,
    groups: &HashMap<String, Vec<String>>,
    s: &mut CityJsonUpgrade,
) {
    s.objects += 1;
    if from == "2.0" {
        return;
    }
    let Some(o) = o.as_object_mut() else { return };
    if from == "1.0" {
        if let Some(Value::Array(gs)) = o.get_mut("geometry") {
            for g in gs.iter_mut() {
                if g.get("type").and_then(Value::as_str) != Some("GeometryInstance") {
                    lod_as_string(g, s);
                }
            }
            if gs.is_empty() {
                o.shift_remove("geometry");
                s.note("empty geometry removed");
            }
        }
        let ty = o
            .get("type")
            .and_then(Value::as_str)
            .unwrap_or("")
            .to_string();
        if ty == "BridgeConstructionElement" {
            o.insert("type".into(), "BridgeConstructiveElement".into());
            s.note("BridgeConstructionElement renamed");
        }
        if ty == "CityObjectGroup" {
            if let Some(m) = o.shift_remove("members") {
                o.insert("children".into(), m);
                s.note("group members as children");
            }
        }
        if let Some(a) = o.get_mut("address") {
            if !a.is_array() {
                *a = Value::Array(vec![a.take()]);
                s.note("address as an array");
            }
        }
        for group in groups.get(id).into_iter().flatten() {
            let p = o
                .entry("parents")
                .or_insert_with(|| Value::Array(Vec::new()));
            if let Some(p) = p.as_array_mut() {
                if !p.iter().any(|x| x.as_str() == Some(group.as_str())) {
                    p.push(Value::String(group.clone()));
                }
            }
        }
    }
    if generic && o.get("type").and_then(Value::as_str) == Some("+GenericCityObject") {
        o.insert("type".into(), Value::String("GenericCityObject".into()));
        s.note("+GenericCityObject as GenericCityObject");
    }
}

/// A geometry's or template's `lod` as a string (1.1).
fn lod_as_string(g: &mut Value, s: &mut CityJsonUpgrade) {
    if let Some(l) = g.get_mut("lod") {
        if let Value::Number(n) = l {
            *l = Value::String(n.to_string());
            s.note("lod as a string");
        }
    }
}

/// 1.0 metadata → 1.1: the members 1.1 kept, renamed.
fn metadata_1_1(m: &mut Map<String, Value>, s: &mut CityJsonUpgrade) {
    const NAMES: [(&str, &str); 6] = [
        ("citymodelIdentifier", "identifier"),
        ("datasetPointOfContact", "pointOfContact"),
        ("datasetTitle", "title"),
        ("datasetReferenceDate", "referenceDate"),
        ("geographicalExtent", "geographicalExtent"),
        ("referenceSystem", "referenceSystem"),
    ];
    let old = std::mem::take(m);
    for (k, v) in old {
        match NAMES.iter().find(|(a, _)| *a == k) {
            Some((_, new)) => {
                m.insert((*new).to_string(), v);
            }
            None => s.note("metadata member dropped"),
        }
    }
    if let Some(Value::String(r)) = m.get_mut("referenceSystem") {
        if let Some(code) = r
            .to_ascii_lowercase()
            .contains("epsg")
            .then(|| {
                r.rsplit(':')
                    .next()
                    .and_then(|c| c.trim().parse::<u32>().ok())
            })
            .flatten()
        {
            *r = format!("https://www.opengis.net/def/crs/EPSG/0/{code}");
            s.note("referenceSystem as an OGC URL");
        }
    }
}

/// A 1.0 document without `transform`: millimetre integers from its lowest corner (`lo`,
/// floored, when the vertices are streamed; else found in and applied to the header's).
fn compress(h: &mut Map<String, Value>, s: &mut CityJsonUpgrade, lo: Option<[f64; 3]>) {
    let lo = match (lo, h.get_mut("vertices")) {
        (_, None) => return,
        (Some(lo), Some(_)) => lo,
        (None, Some(Value::Array(vs))) => {
            let mut lo = [f64::INFINITY; 3];
            for v in vs.iter() {
                lowest(&mut lo, |k| v.get(k).and_then(Value::as_f64));
            }
            let lo = floor_corner(lo);
            for v in vs.iter_mut() {
                quantize(v, lo);
            }
            lo
        }
        (None, Some(_)) => return,
    };
    h.insert(
        "transform".into(),
        serde_json::json!({"scale": [0.001, 0.001, 0.001], "translate": lo}),
    );
    s.note("transform added");
}

/// `lo` lowered to the coordinates `c` gives.
fn lowest(lo: &mut [f64; 3], c: impl Fn(usize) -> Option<f64>) {
    for (k, l) in lo.iter_mut().enumerate() {
        if let Some(c) = c(k) {
            *l = l.min(c);
        }
    }
}

/// A lowest corner floored to whole units (0 where there was none).
fn floor_corner(lo: [f64; 3]) -> [f64; 3] {
    lo.map(|c| if c.is_finite() { c.floor() } else { 0.0 })
}

fn quantize(v: &mut Value, lo: [f64; 3]) {
    if let Value::Array(a) = v {
        for (k, c) in a.iter_mut().enumerate().take(3) {
            if let Some(x) = c.as_f64() {
                *c = Value::from(((x - lo[k]) / 0.001).round() as i64);
            }
        }
    }
}

/// A 1.0 CityJSONSeq feature's vertices with the header's new `transform`.
fn compress_feature(f: &mut Value, head: &Value) {
    let Some(t) = head.get("transform").and_then(|t| t.get("translate")) else {
        return;
    };
    let c = |k: usize| t.get(k).and_then(Value::as_f64).unwrap_or(0.0);
    let lo = [c(0), c(1), c(2)];
    if let Some(Value::Array(vs)) = f.get_mut("vertices") {
        for v in vs {
            quantize(v, lo);
        }
    }
}
