//! Several CityJSON / CityJSONSeq documents merged into one CityJSON document or one
//! CityJSONSeq stream: what `subset`, `filter-lods`, `upgrade` and `reproject` write for
//! several CityJSON inputs and one output file.
//!
//! The merged output has
//!
//! * **one `transform`**: per axis the finest `scale` of the inputs and the smallest
//!   `translate` (an input without a `transform` gives the lower corner of its vertices and no
//!   scale; none at all: 0.001). Each vertex is stored again as
//!   `round((v·scale + translate − translate') / scale')`: exact where the scales agree and the
//!   translates differ by whole steps (every skylod output), else within half a step;
//! * **one CRS**: the first `metadata.referenceSystem` given; inputs naming CRSs that differ
//!   ([`crate::model::crs::same_crs`]; an input naming none agrees with any) are refused,
//!   naming each CRS once, as the CityGML merge refuses them ([`MergeError::Crs`]); inputs of
//!   different CityJSON versions are refused too ([`MergeError::CityJsonVersion`]);
//! * **the city objects of every input**, in input order, their ids renamed by the CityGML
//!   merge's rule ([`rename_ids`]: the first input keeps its ids, an id of input `k`
//!   (1-based) that an earlier input used becomes `<id>__<k>`), their `parents` / `children`
//!   (and a CityJSONSeq feature's `id`) following;
//! * **geometry templates** and **appearances** (`materials`, `textures`,
//!   `vertices-texture`) concatenated, the indices of each input offset past those of the
//!   inputs before it; the other members of the first input's header (`metadata`,
//!   `extensions` of every input joined) kept, `metadata.geographicalExtent` recomputed.
//!
//! A `.city.json` target is one document (held whole, as any document is). A CityJSONSeq
//! target (`seq`) is one header line, then one feature per line: a CityJSONSeq input's
//! features are streamed through one at a time (memory: one feature, the ids of every input,
//! the templates); a document input's top-level objects become features (with their
//! descendants; a document's appearance goes whole into each of its features, its indices
//! unchanged). Every input is read twice: first for its header, ids and box, then to write.

use super::{cj, srs_of, transform_of, trees, write_line, Transform, Values};
use crate::io::citygml::error::WriteError;
use crate::io::citygml::merge::{check_same_crs, rename_ids, MergeError, MergeSummary};
use crate::io::citygml::write::{atomic_write, check_target, WriteOptions};
use crate::model::Bbox;
use glam::DVec3;
use serde_json::{Map, Value};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// What the first pass learns of one input.
struct Head {
    transform: Option<Transform>,
    srs: Option<String>,
    version: String,
    /// Every city object id, in document order.
    ids: Vec<String>,
    /// The box of its vertices, real coordinates.
    bbox: Bbox,
    templates: Vec<Value>,
    template_vertices: Vec<Value>,
}

/// Merge the CityJSON / CityJSONSeq documents `inputs` (plain or gzip; named `names`, the
/// same length, in errors) into `out` (atomically, `-`: standard output): one document, or
/// CityJSONSeq when `seq`. See the module docs for the rules.
///
/// # Errors
/// A refused target, an input that is not CityJSON, inputs in different CRSs or of
/// different versions ([`MergeError`]), I/O errors. Nothing is written then.
pub fn merge_cityjson(
    inputs: &[PathBuf],
    names: &[PathBuf],
    out: &Path,
    seq: bool,
    opts: &WriteOptions,
) -> Result<MergeSummary, MergeError> {
    if inputs.is_empty() {
        return Err(MergeError::NoInput);
    }
    let name = |k: usize| names.get(k).unwrap_or(&inputs[k]).clone();
    check_target(out, opts, inputs.iter().chain(names).map(PathBuf::as_path))?;
    let mut heads = Vec::with_capacity(inputs.len());
    for (k, p) in inputs.iter().enumerate() {
        heads.push(first_pass(p, &name(k))?);
    }
    check_heads(&heads, &name)?;
    let lists: Vec<&[String]> = heads.iter().map(|h| h.ids.as_slice()).collect();
    let renames = rename_ids(&lists);
    let to = common_transform(&heads);
    // The merged header: the first input's, its objects and vertices taken out.
    let mut values = Values::open(&inputs[0])?;
    let mut head = values.header()?;
    drop(values);
    if let Some(h) = head.as_object_mut() {
        for k in [
            "CityObjects",
            "vertices",
            "appearance",
            "geometry-templates",
        ] {
            h.shift_remove(k);
        }
        h.insert(
            "transform".into(),
            serde_json::json!({"scale": to.0, "translate": to.1}),
        );
    }
    join_extensions(&mut head, inputs)?;
    set_srs(&mut head, heads.iter().find_map(|h| h.srs.as_deref()));
    let mut ext = Bbox::EMPTY;
    for h in &heads {
        if !h.bbox.is_empty() {
            ext.add(quantised(h.bbox.min, to));
            ext.add(quantised(h.bbox.max, to));
        }
    }
    super::set_extent(&mut head, &ext);
    // Templates: concatenated, each input's template vertices offset.
    let mut tpl_off = Vec::with_capacity(heads.len());
    let (mut templates, mut tverts) = (Vec::new(), Vec::new());
    for h in &mut heads {
        tpl_off.push(templates.len() as u64);
        let off = tverts.len() as u64;
        for mut t in std::mem::take(&mut h.templates) {
            if let Some(b) = t.get_mut("boundaries") {
                shift_numbers(b, off);
            }
            templates.push(t);
        }
        tverts.append(&mut h.template_vertices);
    }
    if !templates.is_empty() {
        if let Some(h) = head.as_object_mut() {
            h.insert(
                "geometry-templates".into(),
                serde_json::json!({"templates": templates, "vertices-templates": tverts}),
            );
        }
    }
    let mut summary = MergeSummary {
        files: inputs.len(),
        members: 0,
        ids_renamed: renames.iter().map(HashMap::len).sum(),
        refs_rewritten: 0,
        bytes: 0,
    };
    let io = |e| WriteError::Io {
        file: out.to_path_buf(),
        source: e,
    };
    let bytes = atomic_write(out, |w| {
        let mut sink = if seq {
            let n = write_line(w, &head).map_err(io)?;
            Sink::Seq(w, n)
        } else {
            Sink::Doc(Box::default())
        };
        for (k, p) in inputs.iter().enumerate() {
            let mut values = Values::open(p)?;
            values.input = name(k);
            let mut part = Part {
                from: heads[k].transform,
                to,
                renames: &renames[k],
                tpl: tpl_off[k],
                summary: &mut summary,
            };
            let mut h = values.header()?;
            let app = h.get_mut("appearance").map(Value::take);
            if let Some(Value::Object(objects)) = h.get_mut("CityObjects").map(Value::take) {
                let vertices = take_vertices(&mut h);
                part.absorb(&mut sink, objects, vertices, app.as_ref(), io)
                    .map_err(|m| cj(&values.input, 1, None, m))?;
            }
            let mut line = 1;
            while let Some(mut f) = values.next()? {
                line += 1;
                let app = f.get_mut("appearance").map(Value::take);
                let Some(Value::Object(objects)) = f.get_mut("CityObjects").map(Value::take) else {
                    return Err(cj(&values.input, line, None, "no \"CityObjects\"".into()));
                };
                let vertices = take_vertices(&mut f);
                part.absorb(&mut sink, objects, vertices, app.as_ref(), io)
                    .map_err(|m| cj(&values.input, line, None, m))?;
            }
        }
        match sink {
            Sink::Seq(_, n) => Ok(n),
            Sink::Doc(d) => {
                if let (Some(h), Some(a)) = (head.as_object_mut(), d.appearance.into_value()) {
                    h.insert("appearance".into(), a);
                }
                // the header's members, then the objects and vertices gathered as text
                let mut text = serde_json::to_vec(&head).map_err(|e| io(e.into()))?;
                text.pop();
                if text.len() > 1 {
                    text.push(b',');
                }
                let parts: [&[u8]; 6] = [
                    &text,
                    b"\"CityObjects\":{",
                    &d.objects,
                    b"},\"vertices\":[",
                    &d.vertices,
                    b"]}\n",
                ];
                let mut n = 0;
                for b in parts {
                    w.write_all(b).map_err(io)?;
                    n += b.len() as u64;
                }
                Ok(n)
            }
        }
    })?;
    summary.bytes = bytes;
    Ok(summary)
}

/// The header, ids, box and templates of the document at `p` (named `name`).
fn first_pass(p: &Path, name: &Path) -> Result<Head, WriteError> {
    let mut values = Values::open(p)?;
    values.input = name.to_path_buf();
    let h = values.header()?;
    let transform = transform_of(&h);
    let gt = h.get("geometry-templates");
    let list = |k: &str| -> Vec<Value> {
        gt.and_then(|g| g.get(k))
            .and_then(Value::as_array)
            .cloned()
            .unwrap_or_default()
    };
    let mut head = Head {
        transform,
        srs: srs_of(&h),
        version: h
            .get("version")
            .and_then(Value::as_str)
            .unwrap_or("")
            .to_string(),
        ids: Vec::new(),
        bbox: Bbox::EMPTY,
        templates: list("templates"),
        template_vertices: list("vertices-templates"),
    };
    let take = |v: &Value, head: &mut Head| {
        if let Some(o) = v.get("CityObjects").and_then(Value::as_object) {
            head.ids.extend(o.keys().cloned());
        }
        for x in v
            .get("vertices")
            .and_then(Value::as_array)
            .into_iter()
            .flatten()
        {
            if let Some(q) = real(x, transform) {
                head.bbox.add(q);
            }
        }
    };
    take(&h, &mut head);
    while let Some(f) = values.next()? {
        take(&f, &mut head);
    }
    Ok(head)
}

/// Refuse inputs of different versions or CRSs.
fn check_heads(heads: &[Head], name: &dyn Fn(usize) -> PathBuf) -> Result<(), MergeError> {
    let first = &heads[0].version;
    if let Some(k) = heads.iter().position(|h| &h.version != first) {
        return Err(MergeError::CityJsonVersion {
            first: name(0),
            first_version: first.clone(),
            other: name(k),
            other_version: heads[k].version.clone(),
        });
    }
    check_same_crs(heads.iter().map(|h| h.srs.as_deref()), name)
}

/// The merged `transform` (module docs).
fn common_transform(heads: &[Head]) -> Transform {
    let mut scale = [f64::INFINITY; 3];
    let mut translate = [f64::INFINITY; 3];
    for h in heads {
        let t = match h.transform {
            Some((s, t)) => {
                for (a, b) in scale.iter_mut().zip(s) {
                    *a = a.min(b);
                }
                t
            }
            None if h.bbox.is_empty() => continue,
            None => h.bbox.min.to_array(),
        };
        for (a, b) in translate.iter_mut().zip(t) {
            *a = a.min(b);
        }
    }
    (
        scale.map(|s| if s.is_finite() && s > 0.0 { s } else { 0.001 }),
        translate.map(|t| if t.is_finite() { t } else { 0.0 }),
    )
}

/// The real coordinates of a stored vertex.
fn real(v: &Value, t: Option<Transform>) -> Option<DVec3> {
    let a = v.as_array()?;
    let c = |k: usize| a.get(k).and_then(Value::as_f64);
    let p = [c(0)?, c(1)?, c(2)?];
    Some(match t {
        Some((s, tr)) => DVec3::new(
            p[0] * s[0] + tr[0],
            p[1] * s[1] + tr[1],
            p[2] * s[2] + tr[2],
        ),
        None => DVec3::from_array(p),
    })
}

/// `p` stored with `t` (integers), as real coordinates again.
fn quantised(p: DVec3, (s, tr): Transform) -> DVec3 {
    let q = |k: usize| ((p[k] - tr[k]) / s[k]).round() * s[k] + tr[k];
    DVec3::new(q(0), q(1), q(2))
}

/// Vertex `v` stored with `from` stored again with `to` (module docs).
fn requantise(v: &Value, from: Option<Transform>, (s2, t2): Transform) -> Option<Value> {
    let a = v.as_array()?;
    let c = |k: usize| a.get(k).and_then(Value::as_f64);
    let p = [c(0)?, c(1)?, c(2)?];
    let q = |k: usize| -> i64 {
        match from {
            Some((s, t)) => (p[k] * (s[k] / s2[k]) + (t[k] - t2[k]) / s2[k]).round() as i64,
            None => ((p[k] - t2[k]) / s2[k]).round() as i64,
        }
    };
    Some(serde_json::json!([q(0), q(1), q(2)]))
}

/// `vertices` of a document or feature, taken out of it.
fn take_vertices(v: &mut Value) -> Vec<Value> {
    match v.get_mut("vertices").map(Value::take) {
        Some(Value::Array(a)) => a,
        _ => Vec::new(),
    }
}

/// `extensions` of every input joined into the header's.
fn join_extensions(head: &mut Value, inputs: &[PathBuf]) -> Result<(), WriteError> {
    let mut all = Map::new();
    for p in inputs {
        let mut values = Values::open(p)?;
        let h = values.header()?;
        if let Some(Value::Object(e)) = h.get("extensions") {
            for (k, v) in e {
                all.entry(k.clone()).or_insert_with(|| v.clone());
            }
        }
    }
    if let (false, Some(h)) = (all.is_empty(), head.as_object_mut()) {
        h.insert("extensions".into(), Value::Object(all));
    }
    Ok(())
}

/// `metadata.referenceSystem` of the header (kept as the first input that names one gave it).
fn set_srs(head: &mut Value, srs: Option<&str>) {
    let (Some(srs), Some(h)) = (srs, head.as_object_mut()) else {
        return;
    };
    let meta = h
        .entry("metadata")
        .or_insert_with(|| Value::Object(Map::new()));
    if let Some(m) = meta.as_object_mut() {
        if !m.contains_key("referenceSystem") {
            m.insert("referenceSystem".into(), Value::String(srs.to_string()));
        }
    }
}

/// Add `off` to every number in nested arrays.
fn shift_numbers(v: &mut Value, off: u64) {
    match v {
        Value::Array(a) => a.iter_mut().for_each(|x| shift_numbers(x, off)),
        Value::Number(n) => {
            if let Some(i) = n.as_u64() {
                *v = Value::from(i + off);
            }
        }
        _ => {}
    }
}

/// Texture values: in each innermost array, the texture index (first) and the texture
/// vertices (the rest) offset.
fn shift_texture(v: &mut Value, tex: u64, vt: u64) {
    let Value::Array(a) = v else { return };
    if a.iter().any(Value::is_array) {
        a.iter_mut().for_each(|x| shift_texture(x, tex, vt));
        return;
    }
    for (i, x) in a.iter_mut().enumerate() {
        if let Some(n) = x.as_u64() {
            *x = Value::from(n + if i == 0 { tex } else { vt });
        }
    }
}

/// Appearance indices of one geometry offset: `(materials, textures, texture vertices)`.
fn shift_appearance(g: &mut Value, (mat, tex, vt): (u64, u64, u64)) {
    for (key, is_tex) in [("material", false), ("texture", true)] {
        let Some(Value::Object(themes)) = g.get_mut(key) else {
            continue;
        };
        for theme in themes.values_mut() {
            if let Some(v) = theme.get_mut("values") {
                match is_tex {
                    true => shift_texture(v, tex, vt),
                    false => shift_numbers(v, mat),
                }
            }
            if let Some(v) = theme.get_mut("value") {
                shift_numbers(v, mat);
            }
        }
    }
}

/// The appearance of a merged document, gathered.
#[derive(Default)]
struct Appearance {
    rest: Map<String, Value>,
    materials: Vec<Value>,
    textures: Vec<Value>,
    vertices_texture: Vec<Value>,
}

impl Appearance {
    /// Append `a`: the offsets of its indices.
    fn append(&mut self, a: Option<&Value>) -> (u64, u64, u64) {
        let off = (
            self.materials.len() as u64,
            self.textures.len() as u64,
            self.vertices_texture.len() as u64,
        );
        let Some(Value::Object(a)) = a else {
            return off;
        };
        for (k, v) in a {
            match (k.as_str(), v) {
                ("materials", Value::Array(x)) => self.materials.extend(x.iter().cloned()),
                ("textures", Value::Array(x)) => self.textures.extend(x.iter().cloned()),
                ("vertices-texture", Value::Array(x)) => {
                    self.vertices_texture.extend(x.iter().cloned());
                }
                _ => {
                    self.rest.entry(k.clone()).or_insert_with(|| v.clone());
                }
            }
        }
        off
    }

    fn into_value(self) -> Option<Value> {
        let mut m = self.rest;
        for (k, v) in [
            ("materials", self.materials),
            ("textures", self.textures),
            ("vertices-texture", self.vertices_texture),
        ] {
            if !v.is_empty() {
                m.insert(k.into(), Value::Array(v));
            }
        }
        (!m.is_empty()).then_some(Value::Object(m))
    }
}

/// A merged document being gathered, as JSON text (a fraction of the memory of values).
#[derive(Default)]
struct Doc {
    /// `"id":{…}` of each city object, separated by commas.
    objects: Vec<u8>,
    /// `[x,y,z]` of each vertex, separated by commas.
    vertices: Vec<u8>,
    /// How many vertices.
    count: u64,
    appearance: Appearance,
}

impl Doc {
    /// Append `v` to `buf` as JSON, after a comma unless `buf` is empty.
    fn push(buf: &mut Vec<u8>, v: &impl serde::Serialize) -> Result<(), String> {
        if !buf.is_empty() {
            buf.push(b',');
        }
        serde_json::to_writer(buf, v).map_err(|e| e.to_string())
    }
}

/// Where merged objects go: a CityJSONSeq stream (and its bytes so far), or a document.
enum Sink<'w> {
    Seq(&'w mut dyn std::io::Write, u64),
    Doc(Box<Doc>),
}

/// One input being merged.
struct Part<'a> {
    from: Option<Transform>,
    to: Transform,
    renames: &'a HashMap<String, String>,
    tpl: u64,
    summary: &'a mut MergeSummary,
}

impl Part<'_> {
    /// `objects` (indexing `vertices`, with the appearance `app`) of this input into `sink`.
    fn absorb(
        &mut self,
        sink: &mut Sink<'_>,
        objects: Map<String, Value>,
        vertices: Vec<Value>,
        app: Option<&Value>,
        io: impl Fn(std::io::Error) -> WriteError,
    ) -> Result<(), String> {
        let objects = self.rename(objects);
        match sink {
            Sink::Doc(d) => {
                let offsets = d.appearance.append(app);
                let (base, n) = (d.count, vertices.len() as u64);
                for v in &vertices {
                    Doc::push(&mut d.vertices, &self.vertex(v)?)?;
                    d.count += 1;
                }
                for (id, mut o) in objects {
                    self.geometry(&id, &mut o, offsets, &mut |i| (i < n).then_some(base + i))?;
                    Doc::push(&mut d.objects, &id)?;
                    d.objects.push(b':');
                    serde_json::to_writer(&mut d.objects, &o).map_err(|e| e.to_string())?;
                }
                Ok(())
            }
            Sink::Seq(w, bytes) => {
                let app = app.filter(|a| a.as_object().is_some_and(|m| !m.is_empty()));
                let single = objects.values().filter(|o| is_top(o)).count() <= 1;
                let groups = if single {
                    vec![objects]
                } else {
                    split(objects)
                };
                for group in groups.into_iter().filter(|g| !g.is_empty()) {
                    let f = self.feature(group, &vertices, app)?;
                    *bytes += write_line(&mut **w, &f).map_err(|e| io(e).to_string())?;
                }
                Ok(())
            }
        }
    }

    /// One feature line of `objects` (the first the top-level one) with their own vertices.
    fn feature(
        &mut self,
        objects: Map<String, Value>,
        vertices: &[Value],
        app: Option<&Value>,
    ) -> Result<Value, String> {
        let mut map: HashMap<u64, u64> = HashMap::new();
        let mut local = Vec::new();
        let mut out = Map::new();
        let id = objects
            .iter()
            .find(|(_, o)| is_top(o))
            .or_else(|| objects.iter().next())
            .map(|(k, _)| k.clone())
            .unwrap_or_default();
        for (oid, mut o) in objects {
            let mut bad = None;
            let r = self.geometry(&oid, &mut o, (0, 0, 0), &mut |i| {
                if let Some(&j) = map.get(&i) {
                    return Some(j);
                }
                let v = usize::try_from(i).ok().and_then(|i| vertices.get(i))?;
                match self_vertex(v, self.from, self.to) {
                    Ok(q) => local.push(q),
                    Err(e) => {
                        bad = Some(e);
                        return None;
                    }
                }
                let j = map.len() as u64;
                map.insert(i, j);
                Some(j)
            });
            if let Some(e) = bad {
                return Err(e);
            }
            r?;
            out.insert(oid, o);
        }
        let mut f = serde_json::json!({"type": "CityJSONFeature", "id": id});
        if let Some(m) = f.as_object_mut() {
            m.insert("CityObjects".into(), Value::Object(out));
            m.insert("vertices".into(), Value::Array(local));
            if let Some(a) = app {
                m.insert("appearance".into(), a.clone());
            }
        }
        Ok(f)
    }

    fn vertex(&self, v: &Value) -> Result<Value, String> {
        self_vertex(v, self.from, self.to)
    }

    /// The ids of `objects` renamed, `parents` / `children` following; top-level objects
    /// counted.
    fn rename(&mut self, objects: Map<String, Value>) -> Map<String, Value> {
        let mut out = Map::with_capacity(objects.len());
        for (id, mut o) in objects {
            if is_top(&o) {
                self.summary.members += 1;
            }
            if !self.renames.is_empty() {
                for key in ["parents", "children"] {
                    let Some(Value::Array(a)) = o.get_mut(key) else {
                        continue;
                    };
                    for r in a.iter_mut() {
                        if let Some(new) = r.as_str().and_then(|s| self.renames.get(s)) {
                            *r = Value::String(new.clone());
                            self.summary.refs_rewritten += 1;
                        }
                    }
                }
            }
            let id = self.renames.get(&id).cloned().unwrap_or(id);
            out.insert(id, o);
        }
        out
    }

    /// The geometries of object `id`: vertex indices through `vmap`, template and appearance
    /// indices offset.
    fn geometry(
        &self,
        id: &str,
        o: &mut Value,
        app: (u64, u64, u64),
        vmap: &mut dyn FnMut(u64) -> Option<u64>,
    ) -> Result<(), String> {
        let Some(Value::Array(gs)) = o.get_mut("geometry") else {
            return Ok(());
        };
        for g in gs {
            if g.get("type").and_then(Value::as_str) == Some("GeometryInstance") {
                if let Some(t) = g.get_mut("template") {
                    shift_numbers(t, self.tpl);
                }
            }
            shift_appearance(g, app);
            let Some(b) = g.get_mut("boundaries") else {
                continue;
            };
            let mut bad = None;
            map_indices(b, &mut |i| match vmap(i) {
                Some(j) => j,
                None => {
                    bad = Some(i);
                    i
                }
            });
            if let Some(i) = bad {
                return Err(format!(
                    "city object {id}: vertex index {i} out of range or unreadable"
                ));
            }
        }
        Ok(())
    }
}

fn self_vertex(v: &Value, from: Option<Transform>, to: Transform) -> Result<Value, String> {
    requantise(v, from, to).ok_or_else(|| format!("a vertex that is not three numbers: {v}"))
}

/// Every number of nested arrays through `f`.
fn map_indices(v: &mut Value, f: &mut dyn FnMut(u64) -> u64) {
    match v {
        Value::Array(a) => a.iter_mut().for_each(|x| map_indices(x, f)),
        Value::Number(n) => {
            if let Some(i) = n.as_u64() {
                *v = Value::from(f(i));
            }
        }
        _ => {}
    }
}

/// An object with no `parents`.
fn is_top(o: &Value) -> bool {
    o.get("parents")
        .and_then(Value::as_array)
        .is_none_or(Vec::is_empty)
}

/// `objects` split into trees (a top-level object and its descendants), document order.
fn split(mut objects: Map<String, Value>) -> Vec<Map<String, Value>> {
    trees(&objects)
        .into_iter()
        .map(|ids| {
            ids.into_iter()
                .filter_map(|id| objects.shift_remove(&id).map(|o| (id, o)))
                .collect()
        })
        .collect()
}
