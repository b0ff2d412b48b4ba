//! `subset` / `filter-lods` of a `.city.json` document, streamed in three passes
//! ([`super::stream`]), the output the same bytes as the edit of the whole value gave:
//!
//! 1. the small top-level members, the tree structure of `CityObjects` (id hashes) and the
//!    vertices ([`Vertex`]: 16 bytes each);
//! 2. `CityObjects` again, one object at a time: an object waits until its tree is whole and
//!    the trees before it are decided, the rule decides, and the objects that stay come out
//!    in document order, their vertices numbered in order of first use (a `u32` table over
//!    the vertices); the ids that go are kept (8 bytes each), the box of the vertices that
//!    stay made;
//! 3. the same decisions again, written: the header with the recomputed extent, each object
//!    that stays (references to removed objects pruned, vertices renumbered), the vertices that
//!    stay in their new order.
//!
//! Memory: the objects of the trees being decided, plus about 20 bytes per vertex and 50 per
//! city object — not the 23 bytes per byte of the file that the whole value took.

use super::stream::{self, Pass, Structure, Vertex};
use super::{
    changed, cj, id_hash, prune_object, renumber_object, set_extent, srs_of, templates_of,
    transform_of, Ctx, Decision, TreeRule, Verts,
};
use crate::export::transform::citygml::edit::EditSummary;
use crate::io::citygml::error::WriteError;
use crate::model::Bbox;
use serde_json::{Map, Value};
use std::collections::{HashMap, HashSet};
use std::path::Path;

/// What the first pass keeps.
#[derive(Default)]
pub(super) struct Collected {
    /// The small top-level members, in document order.
    pub head: Map<String, Value>,
    pub structure: Structure,
    pub vertices: Vec<Vertex>,
}

impl Pass for Collected {
    fn members(&mut self) -> Option<&mut Map<String, Value>> {
        Some(&mut self.head)
    }
    fn wants_objects(&self) -> bool {
        true
    }
    fn object(&mut self, id: String, o: Value) -> Result<(), String> {
        self.structure.add(&id, &o)
    }
    fn wants_vertices(&self) -> bool {
        true
    }
    fn vertex(&mut self, v: Vertex) -> Result<(), String> {
        self.vertices.push(v);
        Ok(())
    }
}

/// A pass deciding on the trees as their objects arrive, handing the objects that stay to
/// `sink` in document order.
struct Decide<'a, 'r> {
    trees: &'a [Vec<u32>],
    tree_of: &'a [u32],
    /// Objects of each tree not yet arrived.
    left: Vec<usize>,
    /// The first tree not decided.
    next_tree: usize,
    arrived: u32,
    waiting: HashMap<u32, (String, Value)>,
    decided: HashMap<u32, Option<(String, Value)>>,
    /// The next object (document order) to hand on.
    emit_at: u32,
    rule: Box<dyn TreeRule + 'r>,
    ctx: Ctx<'a>,
    counts: &'a mut EditSummary,
    removed: &'a mut HashSet<u64>,
    sink: &'a mut dyn FnMut(String, Value) -> Result<(), String>,
}

impl Decide<'_, '_> {
    fn decide(&mut self, t: usize) -> Result<(), String> {
        let members = &self.trees[t];
        let mut ids = Vec::with_capacity(members.len());
        let mut objects = Map::new();
        for m in members {
            let (id, o) = self.waiting.remove(m).ok_or_else(changed)?;
            ids.push(id.clone());
            objects.insert(id, o);
        }
        self.counts.members += 1;
        let gone = match self.rule.tree(&ids, &mut objects, &self.ctx, self.counts)? {
            Decision::Drop => ids.clone(),
            Decision::Keep(gone) => {
                self.counts.members_kept += 1;
                gone
            }
        };
        for (m, id) in members.iter().zip(ids) {
            let stays = !gone.contains(&id);
            if !stays {
                self.removed.insert(id_hash(&id));
            }
            let o = objects.shift_remove(&id).filter(|_| stays);
            self.decided.insert(*m, o.map(|o| (id, o)));
        }
        Ok(())
    }

    /// Every tree decided, every object handed on (else the document changed between passes).
    fn finish(&self) -> Result<(), String> {
        match self.next_tree == self.trees.len() && self.decided.is_empty() {
            true => Ok(()),
            false => Err(changed()),
        }
    }
}

impl Pass for Decide<'_, '_> {
    fn wants_objects(&self) -> bool {
        true
    }
    fn object(&mut self, id: String, o: Value) -> Result<(), String> {
        let k = self.arrived;
        self.arrived += 1;
        let t = *self.tree_of.get(k as usize).ok_or_else(changed)? as usize;
        self.waiting.insert(k, (id, o));
        self.left[t] -= 1;
        while self.next_tree < self.trees.len() && self.left[self.next_tree] == 0 {
            self.decide(self.next_tree)?;
            self.next_tree += 1;
        }
        while let Some(x) = self.decided.remove(&self.emit_at) {
            self.emit_at += 1;
            if let Some((id, o)) = x {
                (self.sink)(id, o)?;
            }
        }
        Ok(())
    }
}

/// One pass of decisions over `input` (its trees, and the tree of each object), the objects
/// that stay handed to `sink`.
fn decide_pass<'a>(
    input: &Path,
    (trees, tree_of): (&'a [Vec<u32>], &'a [u32]),
    rule: Box<dyn TreeRule + '_>,
    ctx: Ctx<'a>,
    counts: &'a mut EditSummary,
    removed: &'a mut HashSet<u64>,
    sink: &'a mut dyn FnMut(String, Value) -> Result<(), String>,
) -> Result<(), WriteError> {
    let mut pass = Decide {
        trees,
        tree_of,
        left: trees.iter().map(Vec::len).collect(),
        next_tree: 0,
        arrived: 0,
        waiting: HashMap::new(),
        decided: HashMap::new(),
        emit_at: 0,
        rule,
        ctx,
        counts,
        removed,
        sink,
    };
    stream::read(input, input, &mut pass)?;
    pass.finish().map_err(|m| cj(input, 0, None, m))
}

/// Edit the document at `input` (its first pass `first`, of `bytes_in` bytes) with the rules
/// `make` makes into `out` (module docs); with no `out`, the decisions only.
pub(super) fn run<'r>(
    input: &Path,
    out: Option<&Path>,
    first: Collected,
    bytes_in: u64,
    make: &dyn Fn() -> Box<dyn TreeRule + 'r>,
) -> Result<EditSummary, WriteError> {
    let Collected {
        head,
        structure,
        vertices,
    } = first;
    let mut head = Value::Object(head);
    let transform = transform_of(&head);
    let templates = templates_of(&head);
    let srs = srs_of(&head);
    let trees = structure.trees();
    let mut tree_of = vec![0u32; structure.len()];
    for (t, members) in trees.iter().enumerate() {
        for &m in members {
            tree_of[m as usize] = t as u32;
        }
    }
    drop(structure);
    let ctx = || Ctx {
        verts: Verts::Store(&vertices),
        transform,
        templates: templates.as_deref(),
        srs: srs.as_deref(),
    };
    let n = vertices.len();
    let mut map = vec![u32::MAX; n];
    let mut order: Vec<u32> = Vec::new();
    let mut removed = HashSet::new();
    let forest = (trees.as_slice(), tree_of.as_slice());
    let pass = |counts: &mut EditSummary,
                removed: &mut HashSet<u64>,
                sink: &mut dyn FnMut(String, Value) -> Result<(), String>| {
        decide_pass(input, forest, make(), ctx(), counts, removed, sink)
    };
    // pass 2: decisions, the vertices that stay numbered
    let mut scratch = EditSummary::default();
    let mut sink = |id: String, mut o: Value| renumber_object(&id, &mut o, &mut map, &mut order);
    pass(&mut scratch, &mut removed, &mut sink)?;
    let Some(out) = out else {
        return Ok(scratch);
    };
    let kept_box = {
        let c = ctx();
        let mut b = Bbox::EMPTY;
        for &i in &order {
            if let Some(p) = c.point(i as usize) {
                b.add(p);
            }
        }
        b
    };
    if let Some(h) = head.as_object_mut() {
        h.insert("CityObjects".into(), Value::Null);
        h.insert("vertices".into(), Value::Null);
    }
    set_extent(&mut head, &kept_box);
    // pass 3: the same decisions, written
    let mut counts = EditSummary::default();
    let mut pruned = 0;
    let mut again = HashSet::new();
    let head = match head {
        Value::Object(m) => m,
        _ => Map::new(),
    };
    let bytes_out = stream::write_document(out, &head, &mut |key, entries| {
        if key == "vertices" {
            for &i in &order {
                entries
                    .vertex(&vertices[i as usize])
                    .map_err(WriteError::Invalid)?;
            }
            return Ok(());
        }
        let mut sink = |id: String, mut o: Value| {
            prune_object(&mut o, &removed, &mut pruned);
            renumber_object(&id, &mut o, &mut map, &mut order)?;
            entries.object(&id, &o)
        };
        pass(&mut counts, &mut again, &mut sink)
    })?;
    counts.references_pruned += pruned;
    counts.bytes_in = bytes_in;
    counts.bytes_out = bytes_out;
    Ok(counts)
}
