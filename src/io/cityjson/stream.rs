//! A `.city.json` document read in passes without holding it: serde's streaming
//! deserializer over the top-level object hands each member to a [`Pass`] — the small ones
//! (`metadata`, `transform`, `appearance`, `geometry-templates`, `extensions`, ...) whole, the
//! `CityObjects` one object at a time, the `vertices` one vertex at a time — in whatever order
//! the document has them. A pass says which it wants; the rest is skipped unparsed.
//!
//! What stays between passes is kept small: the vertices as [`Vertex`] (16 bytes each for
//! integer triples), the tree structure of the city objects as id hashes
//! ([`Structure`], about 50 bytes an object).

use super::CityJsonError;
use serde::de::{DeserializeSeed, Error as _, IgnoredAny, MapAccess, SeqAccess, Visitor};
use serde_json::value::RawValue;
use serde_json::{Map, Value};
use std::cell::Cell;
use std::collections::HashMap;
use std::fmt;
use std::hash::{BuildHasher, Hash};
use std::io::{BufRead, Read};
use std::path::Path;
use std::rc::Rc;

/// An 8-byte hash of an id (the ids that go, kept between the passes over CityJSONSeq).
pub(crate) fn id_hash(id: &str) -> u64 {
    foldhash::fast::FixedState::with_seed(0x5b5e_7c17).hash_one(id.as_bytes())
}

/// The trees (each top-level object, then its descendants) over objects `ids` (by index; `index` finds an id's) with their `parents` and
/// `children`.
pub(crate) fn forest<K: Eq + Hash + Copy, L: AsRef<[K]>>(
    index: &HashMap<K, u32>,
    ids: &[K],
    parents: &[L],
    children: &[L],
) -> Vec<Vec<u32>> {
    let is_top = |i: usize| parents[i].as_ref().iter().all(|p| !index.contains_key(p));
    let mut seen = vec![false; ids.len()];
    let mut out = Vec::new();
    let grow = |top: usize, seen: &mut Vec<bool>| {
        // `top` and its descendants not yet seen, depth first in `children` order
        let mut tree = Vec::new();
        let mut stack = vec![top as u32];
        while let Some(i) = stack.pop() {
            if std::mem::replace(&mut seen[i as usize], true) {
                continue;
            }
            let kids = children[i as usize].as_ref();
            stack.extend(kids.iter().rev().filter_map(|k| index.get(k)));
            tree.push(i);
        }
        tree
    };
    for i in 0..ids.len() {
        if is_top(i) && !seen[i] {
            out.push(grow(i, &mut seen));
        }
    }
    for i in 0..ids.len() {
        if !seen[i] {
            out.push(grow(i, &mut seen));
        }
    }
    out
}

/// What one pass over a document wants; every callback's error names what is wrong (the
/// reader adds the file, line and column).
pub(crate) trait Pass {
    /// Where the small top-level members are kept, in document order (`None`: skipped).
    fn members(&mut self) -> Option<&mut Map<String, Value>> {
        None
    }
    /// Whether the small member `key` goes into [`Pass::members`] (else it is skipped unread).
    fn keeps(&self, _key: &str) -> bool {
        true
    }
    /// The small member `key` was skipped unread; `null`: its value was `null`.
    fn skipped(&mut self, _key: &str, _null: bool) {}
    /// `CityObjects` or `vertices` is at this place among the members (read or not).
    fn place(&mut self, _key: &str) {}
    /// Whether `CityObjects` is read.
    fn wants_objects(&self) -> bool {
        false
    }
    /// One city object, in document order.
    fn object(&mut self, _id: String, _o: Value) -> Result<(), String> {
        Ok(())
    }
    /// Whether each city object is handed over as its JSON text ([`Pass::object_text`]) rather
    /// than as a value (for a pass that parses only what it needs of each).
    fn wants_text(&self) -> bool {
        false
    }
    /// One city object as its JSON text, in document order.
    fn object_text(&mut self, _id: String, _o: &RawValue) -> Result<(), String> {
        Ok(())
    }
    /// Whether `vertices` is read.
    fn wants_vertices(&self) -> bool {
        false
    }
    /// One vertex, in document order.
    fn vertex(&mut self, _v: Vertex) -> Result<(), String> {
        Ok(())
    }
}

/// What [`read`] saw besides what it handed the pass.
pub(crate) struct Seen {
    /// Bytes read (decompressed): the document's size when it is one.
    pub bytes: u64,
    /// Another JSON value follows the first: CityJSONSeq, not a document.
    pub more: bool,
    /// Whether the document has `CityObjects` (an object) and `vertices` (an array).
    pub objects: bool,
    pub vertices: bool,
}

/// A vertex as stored: an integer triple (the form `transform` gives), or any other value
/// kept as it was.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Vertex {
    Int([i32; 3]),
    Other(Box<Value>),
}

impl Vertex {
    /// The vertex of a value.
    pub fn from_value(v: Value) -> Vertex {
        let int = |v: &Value| -> Option<[i32; 3]> {
            let a = v.as_array().filter(|a| a.len() == 3)?;
            let c = |k: usize| i32::try_from(a[k].as_i64()?).ok();
            Some([c(0)?, c(1)?, c(2)?])
        };
        match int(&v) {
            Some(i) => Vertex::Int(i),
            None => Vertex::Other(Box::new(v)),
        }
    }

    /// Coordinate `k` as stored, when it is a number.
    pub fn coord(&self, k: usize) -> Option<f64> {
        match self {
            Vertex::Int(i) => i.get(k).map(|&c| f64::from(c)),
            Vertex::Other(v) => v.get(k).and_then(Value::as_f64),
        }
    }

    /// The vertex as a value again.
    pub fn into_value(self) -> Value {
        match self {
            Vertex::Int(i) => serde_json::json!(i),
            Vertex::Other(v) => *v,
        }
    }

    /// The stored coordinates (before `transform`), when they are three numbers.
    pub fn coords(&self) -> Option<[f64; 3]> {
        match self {
            Vertex::Int(i) => Some(i.map(f64::from)),
            Vertex::Other(v) => {
                let c = |k: usize| v.get(k).and_then(Value::as_f64);
                Some([c(0)?, c(1)?, c(2)?])
            }
        }
    }

    /// The vertex as JSON, as serde_json writes its value.
    pub fn write(&self, w: &mut dyn std::io::Write) -> std::io::Result<()> {
        match self {
            Vertex::Int([x, y, z]) => write!(w, "[{x},{y},{z}]"),
            Vertex::Other(v) => serde_json::to_writer(w, v).map_err(std::io::Error::other),
        }
    }
}

/// A reader that counts the bytes it gives (the document's passes here, the lines of a
/// CityJSONSeq in `seq`).
pub(super) struct Counted<R> {
    pub(super) inner: R,
    pub(super) n: Rc<Cell<u64>>,
}

impl<R: Read> Read for Counted<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let k = self.inner.read(buf)?;
        self.n.set(self.n.get() + k as u64);
        Ok(k)
    }
}

/// The (decompressed) JSON text of `input`, a byte-order mark skipped.
pub(crate) fn open_json(input: &Path) -> std::io::Result<Box<dyn BufRead + Send>> {
    let (mut r, _) = crate::io::files::open_decoded(input)?;
    if r.fill_buf().is_ok_and(|h| h.starts_with(b"\xEF\xBB\xBF")) {
        r.consume(3);
    }
    Ok(r)
}

/// Read the first JSON value of the JSON text `b` in memory (a byte-order mark already
/// skipped; named `name` in errors) through `pass`, parsed as a slice (faster than through a
/// reader).
///
/// # Errors
/// The text is empty, is not JSON, is not an object, or the pass refuses something (its
/// message with the file, line and column).
pub(crate) fn read_slice(
    b: &[u8],
    name: &Path,
    pass: &mut dyn Pass,
) -> Result<Seen, CityJsonError> {
    if b.is_empty() {
        return Err(CityJsonError::at(name, 0, None, "empty document".into()));
    }
    let mut de = serde_json::Deserializer::from_slice(b);
    let mut seen = Seen {
        bytes: b.len() as u64,
        more: false,
        objects: false,
        vertices: false,
    };
    let json = |e: serde_json::Error| CityJsonError::json(name, &e);
    Top {
        pass,
        seen: &mut seen,
    }
    .deserialize(&mut de)
    .map_err(json)?;
    seen.more = de.end().is_err();
    Ok(seen)
}

/// [`read_slice`] from the JSON text `r` (a byte-order mark already skipped).
///
/// # Errors
/// As [`read_slice`].
pub(crate) fn read_from(
    mut r: impl BufRead,
    name: &Path,
    pass: &mut dyn Pass,
) -> Result<Seen, CityJsonError> {
    if r.fill_buf().is_ok_and(<[u8]>::is_empty) {
        return Err(CityJsonError::at(name, 0, None, "empty document".into()));
    }
    let n = Rc::new(Cell::new(0));
    let counted = Counted {
        inner: r,
        n: n.clone(),
    };
    let mut de = serde_json::Deserializer::from_reader(counted);
    let mut seen = Seen {
        bytes: 0,
        more: false,
        objects: false,
        vertices: false,
    };
    let json = |e: serde_json::Error| CityJsonError::json(name, &e);
    Top {
        pass,
        seen: &mut seen,
    }
    .deserialize(&mut de)
    .map_err(json)?;
    seen.more = de.end().is_err();
    seen.bytes = n.get();
    Ok(seen)
}

/// The top-level object.
struct Top<'p, 'q> {
    pass: &'p mut dyn Pass,
    seen: &'q mut Seen,
}

impl<'de> DeserializeSeed<'de> for Top<'_, '_> {
    type Value = ();
    fn deserialize<D: serde::Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
        d.deserialize_map(self)
    }
}

impl<'de> Visitor<'de> for Top<'_, '_> {
    type Value = ();
    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a CityJSON object")
    }

    fn visit_map<A: MapAccess<'de>>(self, mut m: A) -> Result<(), A::Error> {
        while let Some(key) = m.next_key::<String>()? {
            match key.as_str() {
                "CityObjects" | "vertices" => {
                    let objects = key == "CityObjects";
                    let twice = match objects {
                        true => std::mem::replace(&mut self.seen.objects, true),
                        false => std::mem::replace(&mut self.seen.vertices, true),
                    };
                    if twice {
                        return Err(A::Error::custom(format!("{key:?} given twice")));
                    }
                    self.pass.place(&key);
                    if objects && self.pass.wants_objects() {
                        m.next_value_seed(Objects(&mut *self.pass))?;
                    } else if !objects && self.pass.wants_vertices() {
                        m.next_value_seed(Vertices(&mut *self.pass))?;
                    } else {
                        // checked for its kind (an object, an array), else skipped
                        m.next_value_seed(Skip(objects))?;
                    }
                }
                _ if !self.pass.keeps(&key) => {
                    let v = m.next_value::<Option<IgnoredAny>>()?;
                    self.pass.skipped(&key, v.is_none());
                }
                _ => match self.pass.members() {
                    Some(members) => {
                        let v: Value = m.next_value()?;
                        members.insert(key, v);
                    }
                    None => {
                        let v = m.next_value::<Option<IgnoredAny>>()?;
                        self.pass.skipped(&key, v.is_none());
                    }
                },
            }
        }
        Ok(())
    }
}

/// `CityObjects` (`true`) or `vertices` skipped, their kind checked.
struct Skip(bool);

impl<'de> DeserializeSeed<'de> for Skip {
    type Value = ();
    fn deserialize<D: serde::Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
        match self.0 {
            true => d.deserialize_map(self),
            false => d.deserialize_seq(self),
        }
    }
}

impl<'de> Visitor<'de> for Skip {
    type Value = ();
    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str(match self.0 {
            true => "\"CityObjects\" as an object",
            false => "\"vertices\" as an array",
        })
    }
    fn visit_map<A: MapAccess<'de>>(self, mut m: A) -> Result<(), A::Error> {
        while m.next_entry::<IgnoredAny, IgnoredAny>()?.is_some() {}
        Ok(())
    }
    fn visit_seq<A: SeqAccess<'de>>(self, mut s: A) -> Result<(), A::Error> {
        while s.next_element::<IgnoredAny>()?.is_some() {}
        Ok(())
    }
}

/// `CityObjects`, one object at a time.
struct Objects<'p>(&'p mut dyn Pass);

impl<'de> DeserializeSeed<'de> for Objects<'_> {
    type Value = ();
    fn deserialize<D: serde::Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
        d.deserialize_map(self)
    }
}

impl<'de> Visitor<'de> for Objects<'_> {
    type Value = ();
    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("\"CityObjects\" as an object")
    }
    fn visit_map<A: MapAccess<'de>>(self, mut m: A) -> Result<(), A::Error> {
        let text = self.0.wants_text();
        while let Some(id) = m.next_key::<String>()? {
            let r = match text {
                true => self.0.object_text(id, &m.next_value::<Box<RawValue>>()?),
                false => self.0.object(id, m.next_value()?),
            };
            r.map_err(A::Error::custom)?;
        }
        Ok(())
    }
}

/// `vertices`, one at a time.
struct Vertices<'p>(&'p mut dyn Pass);

impl<'de> DeserializeSeed<'de> for Vertices<'_> {
    type Value = ();
    fn deserialize<D: serde::Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
        d.deserialize_seq(self)
    }
}

impl<'de> Visitor<'de> for Vertices<'_> {
    type Value = ();
    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("\"vertices\" as an array")
    }
    fn visit_seq<A: SeqAccess<'de>>(self, mut s: A) -> Result<(), A::Error> {
        while let Some(v) = s.next_element::<Value>()? {
            self.0
                .vertex(Vertex::from_value(v))
                .map_err(A::Error::custom)?;
        }
        Ok(())
    }
}

/// The tree structure of a document's city objects (by index in document order): which
/// tree each is in, and each tree's objects (its top-level object first, then its
/// descendants, as the edits' trees order them).
#[derive(Default)]
pub(crate) struct Structure {
    ids: Vec<u64>,
    index: HashMap<u64, u32>,
    parents: Vec<Box<[u64]>>,
    children: Vec<Box<[u64]>>,
}

impl Structure {
    /// Add the next object; a repeated id is refused.
    pub fn add(&mut self, id: &str, o: &Value) -> Result<(), String> {
        self.add_links(id, o.get("parents"), o.get("children"))
    }

    /// [`Structure::add`] of an object by its `parents` and `children` (the strings of
    /// arrays; anything else is no link).
    pub fn add_links(
        &mut self,
        id: &str,
        parents: Option<&Value>,
        children: Option<&Value>,
    ) -> Result<(), String> {
        let h = id_hash(id);
        let k = u32::try_from(self.ids.len()).map_err(|_| "too many city objects".to_string())?;
        if self.index.insert(h, k).is_some() {
            return Err(format!("city object id {id:?} given twice"));
        }
        let hashes = |v: Option<&Value>| -> Box<[u64]> {
            v.and_then(Value::as_array)
                .map(|a| a.iter().filter_map(Value::as_str).map(id_hash).collect())
                .unwrap_or_default()
        };
        self.ids.push(h);
        self.parents.push(hashes(parents));
        self.children.push(hashes(children));
        Ok(())
    }

    /// How many objects.
    pub fn len(&self) -> usize {
        self.ids.len()
    }

    /// The trees, in the edits' trees' order (`forest`).
    pub fn trees(&self) -> Vec<Vec<u32>> {
        forest(&self.index, &self.ids, &self.parents, &self.children)
    }

    /// Whether an object `id` was added.
    pub fn contains(&self, id: &str) -> bool {
        self.index.contains_key(&id_hash(id))
    }

    /// For each object, the last (in document order) of the objects linked to it through
    /// `parents` or `children`, either way and transitively: the objects from a place in the
    /// document on, up to the greatest such last object, hold every object they are linked
    /// with.
    pub fn reach(&self) -> Vec<u32> {
        // union-find over the links, each set's root its greatest index
        let mut up: Vec<u32> = (0..self.ids.len() as u32).collect();
        fn root(up: &mut [u32], mut i: u32) -> u32 {
            while up[i as usize] != i {
                let next = up[up[i as usize] as usize];
                up[i as usize] = next;
                i = next;
            }
            i
        }
        for (i, links) in self.parents.iter().zip(&self.children).enumerate() {
            for h in links.0.iter().chain(links.1.iter()) {
                if let Some(&j) = self.index.get(h) {
                    let (a, b) = (root(&mut up, i as u32), root(&mut up, j));
                    up[a.min(b) as usize] = a.max(b);
                }
            }
        }
        (0..up.len() as u32).map(|i| root(&mut up, i)).collect()
    }
}

/// A pass handing each city object to its function.
pub(crate) struct EachObject<F>(pub F);

impl<F: FnMut(String, Value) -> Result<(), String>> Pass for EachObject<F> {
    fn wants_objects(&self) -> bool {
        true
    }
    fn object(&mut self, id: String, o: Value) -> Result<(), String> {
        (self.0)(id, o)
    }
}

/// A pass handing each city object's JSON text to its function.
pub(crate) struct EachText<F>(pub F);

impl<F: FnMut(String, &RawValue) -> Result<(), String>> Pass for EachText<F> {
    fn wants_objects(&self) -> bool {
        true
    }
    fn wants_text(&self) -> bool {
        true
    }
    fn object_text(&mut self, id: String, o: &RawValue) -> Result<(), String> {
        (self.0)(id, o)
    }
}

/// A pass handing each vertex to its function.
pub(crate) struct EachVertex<F>(pub F);

impl<F: FnMut(Vertex) -> Result<(), String>> Pass for EachVertex<F> {
    fn wants_vertices(&self) -> bool {
        true
    }
    fn vertex(&mut self, v: Vertex) -> Result<(), String> {
        (self.0)(v)
    }
}
