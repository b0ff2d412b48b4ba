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
//! * what the plan decides ([`crate::export::merge`]): inputs of different CityJSON versions
//!   or CRSs (`metadata.referenceSystem`) refused, the first CRS given written, ids renamed;
//! * **the city objects of every input**, in input order, their `parents` / `children` (and
//!   a CityJSONSeq feature's `id`) following the renamed ids;
//! * **geometry templates** and **appearances** (`materials`, `textures`,
//!   `vertices-texture`) concatenated, the indices of each input offset past those of the
//!   inputs before it; the other members of the first input's header (`metadata`,
//!   `extensions` of every input joined) kept, `metadata.geographicalExtent` recomputed.
//!
//! A `.city.json` target is one document, written as it is read: the first pass over each
//! input keeps its small members, ids, box and vertex count (a document input streamed
//! member by member, [`stream`]), then the merged header (appearances gathered), the city
//! objects of every input one at a time, and their vertices one at a time (each input read
//! again for each). Memory: the ids of every input and the appearances, not the documents.
//! A CityJSONSeq target (`seq`) is one header line, then one feature per line: a
//! CityJSONSeq input's features are streamed through one at a time (memory: one feature, the
//! ids of every input, the templates); a document input's top-level objects become features
//! (with their descendants; a document's appearance goes whole into each of its features, its
//! indices unchanged). A document input is read in passes too: the links of its city objects (as
//! hashes) and its vertices (as [`Vertex`]es: 16 bytes each for integer triples, the part
//! that grows with it), then its objects one at a time, each tree written once all its
//! objects are read (a document with at most one top-level object is one feature: held
//! whole; one with an id given twice is parsed whole). Every input is read at least twice:
//! first for its header, ids and box, then to write.

use super::{Head as Common, MergeError, MergeSummary, Plan};
use crate::export::transform::cityjson::stream::{self, cj, EachObject, EachVertex, Pass, Vertex};
use crate::export::transform::cityjson::{
    check_type, set_extent, srs_of, transform_of, trees, write_line, Transform, Values,
};
use crate::io::citygml::error::WriteError;
use crate::io::citygml::write::{atomic_write, check_target, WriteOptions};
use crate::model::Bbox;
use glam::DVec3;
use serde_json::{Map, Value};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// What the first pass learns of one input.
struct Head {
    /// What the plan needs: `version`, `metadata.referenceSystem`, every city object id in
    /// document order, the box of its vertices (real coordinates).
    common: Common,
    transform: Option<Transform>,
    templates: Vec<Value>,
    template_vertices: Vec<Value>,
    /// The small top-level members (of a CityJSONSeq input: its header's).
    members: Map<String, Value>,
    /// A document input: how many vertices its objects index (none without `CityObjects`);
    /// `None` for CityJSONSeq.
    doc: Option<u64>,
}

/// The first pass over a document (or a CityJSONSeq header): its small members, its ids, the
/// box of its stored coordinates and how many vertices.
#[derive(Default)]
struct Scan {
    members: Map<String, Value>,
    ids: Vec<String>,
    raw: Bbox,
    vertices: u64,
}

impl Pass for Scan {
    fn members(&mut self) -> Option<&mut Map<String, Value>> {
        Some(&mut self.members)
    }
    fn wants_objects(&self) -> bool {
        true
    }
    fn object(&mut self, id: String, _o: Value) -> Result<(), String> {
        self.ids.push(id);
        Ok(())
    }
    fn wants_vertices(&self) -> bool {
        true
    }
    fn vertex(&mut self, v: Vertex) -> Result<(), String> {
        self.vertices += 1;
        if let Some(c) = v.coords() {
            self.raw.add(DVec3::from_array(c));
        }
        Ok(())
    }
}

/// Merge the CityJSON / CityJSONSeq documents `inputs` (plain or gzip; named `names`, the
/// same length, in errors) into `out` (atomically, `-`: standard output): one document, or
/// CityJSONSeq when `seq`. See the module docs for the rules.
///
/// # Errors
/// A refused target, an input that is not CityJSON, inputs in different CRSs or of
/// different versions (`MergeError`), I/O errors. Nothing is written then.
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
    let mut app = Appearance::default();
    for (k, p) in inputs.iter().enumerate() {
        heads.push(first_pass(p, &name(k), &mut app)?);
    }
    let common: Vec<&Common> = heads.iter().map(|h| &h.common).collect();
    let plan = Plan::new(&common, "CityJSON", &name)?;
    let renames = &plan.renames;
    let to = common_transform(&heads);
    // The merged header: the first input's, its objects and vertices taken out.
    let mut head = Value::Object(heads[0].members.clone());
    if let Some(h) = head.as_object_mut() {
        for k in ["appearance", "geometry-templates"] {
            h.shift_remove(k);
        }
        h.insert(
            "transform".into(),
            serde_json::json!({"scale": to.0, "translate": to.1}),
        );
    }
    join_extensions(&mut head, &heads);
    set_srs(&mut head, plan.srs.as_deref());
    // (the rounding is monotonic: the box of the inputs' boxes rounded is their union's)
    let mut ext = Bbox::EMPTY;
    if !plan.bbox.is_empty() {
        ext.add(quantised(plan.bbox.min, to));
        ext.add(quantised(plan.bbox.max, to));
    }
    set_extent(&mut head, &ext);
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
        ids_renamed: plan.ids_renamed(),
        refs_rewritten: 0,
        bytes: 0,
    };
    if !seq {
        let merged = Merged {
            inputs,
            names: (0..inputs.len()).map(name).collect(),
            heads: &heads,
            renames,
            tpl_off: &tpl_off,
            to,
        };
        summary.bytes = write_merged_document(&merged, head, app, out, &mut summary)?;
        return Ok(summary);
    }
    let io = |e| WriteError::Io {
        file: out.to_path_buf(),
        source: e,
    };
    let bytes = atomic_write(out, |w| {
        let mut n = write_line(w, &head).map_err(io)?;
        for (k, p) in inputs.iter().enumerate() {
            let mut part = Part {
                from: heads[k].transform,
                to,
                renames: &renames[k],
                tpl: tpl_off[k],
                summary: &mut summary,
            };
            if heads[k].doc.is_some() {
                let app = heads[k].members.get("appearance");
                if part.absorb_document(p, &name(k), (&mut *w, &mut n), app, io)? {
                    continue;
                }
            }
            let mut values = Values::open(p)?;
            values.input = name(k);
            let mut h = values.header()?;
            let app = h.get_mut("appearance").map(Value::take);
            if let Some(Value::Object(objects)) = h.get_mut("CityObjects").map(Value::take) {
                let vertices = take_vertices(&mut h);
                part.absorb((&mut *w, &mut n), objects, vertices, app.as_ref(), io)
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
                part.absorb((&mut *w, &mut n), objects, vertices, app.as_ref(), io)
                    .map_err(|m| cj(&values.input, line, None, m))?;
            }
        }
        Ok(n)
    })?;
    summary.bytes = bytes;
    Ok(summary)
}

/// The header, ids, box and templates of the document at `p` (named `name`); the
/// appearance of each of its parts appended to `app` (in the order the merge takes them).
fn first_pass(p: &Path, name: &Path, app: &mut Appearance) -> Result<Head, WriteError> {
    let mut scan = Scan::default();
    let seen = stream::read(p, name, &mut scan)?;
    check_type(name, &scan.members)?;
    let h = Value::Object(std::mem::take(&mut scan.members));
    let transform = transform_of(&h);
    let gt = h.get("geometry-templates");
    let list = |k: &str| -> Vec<Value> {
        gt.and_then(|g| g.get(k))
            .and_then(Value::as_array)
            .cloned()
            .unwrap_or_default()
    };
    let version = h.get("version").and_then(Value::as_str).unwrap_or("");
    let mut head = Head {
        common: Common {
            version: version.to_string(),
            shown: version.to_string(),
            srs: srs_of(&h),
            ids: std::mem::take(&mut scan.ids),
            bbox: Bbox::EMPTY,
        },
        transform,
        templates: list("templates"),
        template_vertices: list("vertices-templates"),
        members: Map::new(),
        doc: None,
    };
    // the box of the stored coordinates, transformed: the box of the transformed ones (a
    // transform is monotonic per axis, and so is its rounding)
    if !scan.raw.is_empty() {
        for c in [scan.raw.min, scan.raw.max] {
            head.common.bbox.add(to_real(c.to_array(), transform));
        }
    }
    if seen.objects {
        app.append(h.get("appearance"));
    }
    if seen.more {
        let mut values = Values::open(p)?;
        values.input = name.to_path_buf();
        values.header()?;
        while let Some(f) = values.next()? {
            if let Some(o) = f.get("CityObjects").and_then(Value::as_object) {
                head.common.ids.extend(o.keys().cloned());
            }
            for x in f
                .get("vertices")
                .and_then(Value::as_array)
                .into_iter()
                .flatten()
            {
                if let Some(q) = real(x, transform) {
                    head.common.bbox.add(q);
                }
            }
            app.append(f.get("appearance"));
        }
    } else {
        head.doc = Some(if seen.objects { scan.vertices } else { 0 });
    }
    if let Value::Object(m) = h {
        head.members = m;
    }
    Ok(head)
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
            None if h.common.bbox.is_empty() => continue,
            None => h.common.bbox.min.to_array(),
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
    Some(to_real([c(0)?, c(1)?, c(2)?], t))
}

/// Stored coordinates `p` as real ones.
fn to_real(p: [f64; 3], t: Option<Transform>) -> DVec3 {
    match t {
        Some((s, tr)) => DVec3::new(
            p[0] * s[0] + tr[0],
            p[1] * s[1] + tr[1],
            p[2] * s[2] + tr[2],
        ),
        None => DVec3::from_array(p),
    }
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
fn join_extensions(head: &mut Value, heads: &[Head]) {
    let mut all = Map::new();
    for h in heads {
        if let Some(Value::Object(e)) = h.members.get("extensions") {
            for (k, v) in e {
                all.entry(k.clone()).or_insert_with(|| v.clone());
            }
        }
    }
    if let (false, Some(h)) = (all.is_empty(), head.as_object_mut()) {
        h.insert("extensions".into(), Value::Object(all));
    }
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

/// One input being merged.
struct Part<'a> {
    from: Option<Transform>,
    to: Transform,
    renames: &'a HashMap<String, String>,
    tpl: u64,
    summary: &'a mut MergeSummary,
}

impl Part<'_> {
    /// `objects` (indexing `vertices`, with the appearance `app`) of this input as
    /// CityJSONSeq features into `w` (its bytes so far counted).
    fn absorb(
        &mut self,
        (w, bytes): (&mut dyn std::io::Write, &mut u64),
        objects: Map<String, Value>,
        vertices: Vec<Value>,
        app: Option<&Value>,
        io: impl Fn(std::io::Error) -> WriteError,
    ) -> Result<(), String> {
        let vertices: Vec<Vertex> = vertices.into_iter().map(Vertex::from_value).collect();
        let objects = self.rename(objects);
        let app = app.filter(|a| a.as_object().is_some_and(|m| !m.is_empty()));
        let single = objects.values().filter(|o| is_top(o)).count() <= 1;
        let groups = if single {
            vec![objects]
        } else {
            split(objects)
        };
        for group in groups.into_iter().filter(|g| !g.is_empty()) {
            let f = self.feature(group, &vertices, app)?;
            *bytes += write_line(&mut *w, &f).map_err(|e| io(e).to_string())?;
        }
        Ok(())
    }

    /// [`Part::absorb`] of the document at `p` (named `name`) read in passes
    /// ([`super::stream`]): its vertices kept as [`Vertex`]es and its objects' links as
    /// hashes, then its objects one at a time, each tree written as soon as all its objects
    /// are read, in [`trees`]' order (the objects of trees still open are held: one tree for a
    /// document in tree order). `false`, nothing written, for a document with an id given
    /// twice (absorbed whole then).
    fn absorb_document(
        &mut self,
        p: &Path,
        name: &Path,
        (w, bytes): (&mut dyn std::io::Write, &mut u64),
        app: Option<&Value>,
        io: impl Fn(std::io::Error) -> WriteError,
    ) -> Result<bool, WriteError> {
        let mut structure = stream::Structure::default();
        let (mut twice, mut tops) = (false, 0usize);
        stream::read(
            p,
            name,
            &mut EachObject(|id: String, o: Value| {
                if is_top(&o) {
                    tops += 1;
                }
                if structure.contains(&id) {
                    twice = true;
                    return Ok(());
                }
                structure.add(&id, &o)
            }),
        )?;
        if twice {
            return Ok(false);
        }
        let mut vertices = Vec::new();
        stream::read(
            p,
            name,
            &mut EachVertex(|v| {
                vertices.push(v);
                Ok(())
            }),
        )?;
        let app = app.filter(|a| a.as_object().is_some_and(|m| !m.is_empty()));
        let n = structure.len();
        // one feature of every object in document order (at most one top-level object), or
        // one a tree
        let trees: Vec<Vec<u32>> = match tops <= 1 {
            true if n > 0 => vec![(0..n as u32).collect()],
            true => Vec::new(),
            false => structure.trees(),
        };
        drop(structure);
        let mut tree_of = vec![0u32; n];
        let mut left: Vec<usize> = Vec::with_capacity(trees.len());
        for (t, objs) in trees.iter().enumerate() {
            for &i in objs {
                tree_of[i as usize] = t as u32;
            }
            left.push(objs.len());
        }
        let mut held: HashMap<u32, (String, Value)> = HashMap::new();
        let (mut next, mut k) = (0usize, 0u32);
        stream::read(
            p,
            name,
            &mut EachObject(|id: String, o: Value| {
                let t = *tree_of
                    .get(k as usize)
                    .ok_or_else(|| "the document changed while read".to_string())?;
                held.insert(k, (id, o));
                k += 1;
                left[t as usize] -= 1;
                while next < trees.len() && left[next] == 0 {
                    let group: Map<String, Value> = trees[next]
                        .iter()
                        .filter_map(|i| held.remove(i))
                        .map(|(id, o)| self.rename_one(id, o))
                        .collect();
                    next += 1;
                    let f = self.feature(group, &vertices, app)?;
                    *bytes += write_line(&mut *w, &f).map_err(|e| io(e).to_string())?;
                }
                Ok(())
            }),
        )?;
        Ok(true)
    }

    /// One feature line of `objects` (the first the top-level one) with their own vertices.
    fn feature(
        &mut self,
        objects: Map<String, Value>,
        vertices: &[Vertex],
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
                match self_vertex(&v.clone().into_value(), self.from, self.to) {
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
        objects
            .into_iter()
            .map(|(id, o)| self.rename_one(id, o))
            .collect()
    }

    /// [`Part::rename`] of one object.
    fn rename_one(&mut self, id: String, mut o: Value) -> (String, Value) {
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
        (id, o)
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

/// What writing a merged document needs of the first passes.
struct Merged<'a> {
    inputs: &'a [PathBuf],
    names: Vec<PathBuf>,
    heads: &'a [Head],
    renames: &'a [HashMap<String, String>],
    tpl_off: &'a [u64],
    to: Transform,
}

/// The lengths of the appearance arrays of `a` (what [`Appearance::append`] adds) added to
/// `lens`; the lengths before.
fn advance(lens: &mut (u64, u64, u64), a: Option<&Value>) -> (u64, u64, u64) {
    let before = *lens;
    let n = |k: &str| {
        a.and_then(|a| a.get(k))
            .and_then(Value::as_array)
            .map_or(0, |x| x.len() as u64)
    };
    *lens = (
        lens.0 + n("materials"),
        lens.1 + n("textures"),
        lens.2 + n("vertices-texture"),
    );
    before
}

/// The merged document written to `out`, streamed: `head` (the merged header) with the
/// appearance `app` gathered by the first passes, then the city objects of every input, then
/// their vertices, each input read again once for each (module docs). The bytes written.
fn write_merged_document(
    m: &Merged<'_>,
    mut head: Value,
    app: Appearance,
    out: &Path,
    summary: &mut MergeSummary,
) -> Result<u64, WriteError> {
    if let Some(h) = head.as_object_mut() {
        if let Some(a) = app.into_value() {
            h.insert("appearance".into(), a);
        }
        h.insert("CityObjects".into(), Value::Null);
        h.insert("vertices".into(), Value::Null);
    }
    let head = match head {
        Value::Object(h) => h,
        _ => Map::new(),
    };
    stream::write_document(out, &head, &mut |key, entries| {
        let objects = key == "CityObjects";
        let (mut base, mut lens) = (0u64, (0, 0, 0));
        for (k, p) in m.inputs.iter().enumerate() {
            let name = &m.names[k];
            let mut part = Part {
                from: m.heads[k].transform,
                to: m.to,
                renames: &m.renames[k],
                tpl: m.tpl_off[k],
                summary: &mut *summary,
            };
            if let Some(n) = m.heads[k].doc {
                let offsets = advance(&mut lens, m.heads[k].members.get("appearance"));
                if objects {
                    let mut each = EachObject(|id: String, o: Value| {
                        let (id, mut o) = part.rename_one(id, o);
                        part.geometry(&id, &mut o, offsets, &mut |i| (i < n).then_some(base + i))?;
                        entries.object(&id, &o)
                    });
                    stream::read(p, name, &mut each)?;
                } else if n > 0 {
                    let mut each = EachVertex(|v: Vertex| {
                        let q = part.vertex(&v.into_value())?;
                        entries.vertex(&Vertex::from_value(q))
                    });
                    stream::read(p, name, &mut each)?;
                }
                base += n;
                continue;
            }
            // CityJSONSeq: the header, then each feature
            let mut values = Values::open(p)?;
            values.input = name.clone();
            let mut v = Some(values.header()?);
            let mut line = 1;
            while let Some(mut f) = v.take() {
                let Some(Value::Object(objs)) = f.get_mut("CityObjects").map(Value::take) else {
                    if line > 1 {
                        return Err(cj(name, line, None, "no \"CityObjects\"".into()));
                    }
                    line += 1;
                    v = values.next()?;
                    continue;
                };
                let offsets = advance(&mut lens, f.get("appearance"));
                let vertices = take_vertices(&mut f);
                let n = vertices.len() as u64;
                let r = (|| {
                    if !objects {
                        for x in &vertices {
                            entries.vertex(&Vertex::from_value(part.vertex(x)?))?;
                        }
                        return Ok(());
                    }
                    for (id, o) in objs {
                        let (id, mut o) = part.rename_one(id, o);
                        part.geometry(&id, &mut o, offsets, &mut |i| (i < n).then_some(base + i))?;
                        entries.object(&id, &o)?;
                    }
                    Ok::<(), String>(())
                })();
                r.map_err(|e| cj(name, line, None, e))?;
                base += n;
                line += 1;
                v = values.next()?;
            }
        }
        Ok(())
    })
}
