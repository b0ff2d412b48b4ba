//! The rules of [`crate::export::transform::citygml::edit`]'s `subset` and `filter-lods` on CityJSON trees.

use super::{run, Ctx, Decision, TreeRule};
use crate::export::transform::citygml::edit::subset::{with_draw, Matcher};
use crate::export::transform::citygml::edit::{EditSummary, Lods, Subset};
use crate::io::citygml::error::WriteError;
use crate::io::citygml::write::WriteOptions;
use crate::model::Bbox;
use serde_json::{Map, Value};
use std::path::Path;

struct SubsetRule<'a>(Matcher<'a>);

impl TreeRule for SubsetRule<'_> {
    fn tree(
        &mut self,
        ids: &[String],
        objects: &mut Map<String, Value>,
        ctx: &Ctx<'_>,
        _counts: &mut EditSummary,
    ) -> Result<Decision, String> {
        let q = self.0.bbox(ctx.srs)?;
        let Some(top) = ids.first() else {
            return Ok(Decision::Drop);
        };
        let ty = objects
            .get(top.as_str())
            .and_then(|o| o.get("type"))
            .and_then(Value::as_str)
            .unwrap_or("");
        let boxed = || {
            let mut b = Bbox::EMPTY;
            for g in ids.iter().flat_map(|id| geometries(objects, id)) {
                ctx.add_box(g, &mut b);
            }
            b
        };
        // cjio's centroid: the top-level object's own geometry, not its children's
        let centroid = || {
            let mut uses = (glam::DVec3::ZERO, 0u64);
            for g in geometries(objects, top) {
                ctx.add_uses(g, &mut uses);
            }
            (uses.1 > 0).then(|| uses.0 / uses.1 as f64)
        };
        Ok(
            if self
                .0
                .keep(q, Some(top.as_str()), Some(ty), boxed, centroid)
            {
                Decision::Keep(Vec::new())
            } else {
                Decision::Drop
            },
        )
    }
}

/// The geometries of object `id`.
fn geometries<'a>(objects: &'a Map<String, Value>, id: &str) -> &'a [Value] {
    objects
        .get(id)
        .and_then(|o| o.get("geometry"))
        .and_then(Value::as_array)
        .map_or(&[], Vec::as_slice)
}

struct LodRule<'a>(&'a Lods);

impl TreeRule for LodRule<'_> {
    fn tree(
        &mut self,
        ids: &[String],
        objects: &mut Map<String, Value>,
        ctx: &Ctx<'_>,
        counts: &mut EditSummary,
    ) -> Result<Decision, String> {
        let has: Vec<u8> = ids
            .iter()
            .flat_map(|id| geometries(objects, id))
            .filter_map(|g| ctx.lod(g))
            .collect();
        let kept = self.0.kept(&has);
        // geometries removed per object (a geometry without a LoD stays)
        let mut lost = vec![false; ids.len()];
        let mut removed = 0usize;
        for (k, id) in ids.iter().enumerate() {
            let Some(Value::Array(gs)) = objects
                .get_mut(id.as_str())
                .and_then(|o| o.get_mut("geometry"))
            else {
                continue;
            };
            let before = gs.len();
            gs.retain(|g| ctx.lod(g).is_none_or(|n| kept.contains(&n)));
            if gs.len() < before {
                lost[k] = true;
                removed += before - gs.len();
            }
        }
        counts.lod_properties_removed += removed;
        if removed == 0 || self.0.keep_empty {
            return Ok(Decision::Keep(Vec::new()));
        }
        let has_geometry =
            |objects: &Map<String, Value>, id: &str| !geometries(objects, id).is_empty();
        if !ids.iter().any(|id| has_geometry(objects, id)) {
            counts.lod_properties_removed -= removed;
            return Ok(Decision::Drop);
        }
        // nested objects that lost geometry and have none left in their subtree go, with it
        let mut gone: Vec<String> = Vec::new();
        for (k, id) in ids.iter().enumerate().skip(1) {
            if !lost[k] || gone.contains(id) {
                continue;
            }
            let sub = subtree(objects, ids, id);
            if sub.iter().any(|s| has_geometry(objects, s)) {
                continue;
            }
            counts.features_removed += 1;
            for s in sub {
                if !gone.contains(&s) {
                    gone.push(s);
                }
            }
        }
        Ok(Decision::Keep(gone))
    }
}

/// `id` and its descendants among `ids` (the tree).
fn subtree(objects: &Map<String, Value>, ids: &[String], id: &str) -> Vec<String> {
    let mut out = vec![id.to_string()];
    let mut at = 0;
    while at < out.len() {
        let kids: Vec<String> = objects
            .get(out[at].as_str())
            .and_then(|o| o.get("children"))
            .and_then(Value::as_array)
            .map(|a| {
                a.iter()
                    .filter_map(Value::as_str)
                    .filter(|k| ids.iter().any(|i| i == k))
                    .map(str::to_string)
                    .collect()
            })
            .unwrap_or_default();
        for k in kids {
            if !out.contains(&k) {
                out.push(k);
            }
        }
        at += 1;
    }
    out
}

/// [`subset`](fn@crate::export::transform::citygml::edit::subset) of a CityJSON / CityJSONSeq document: the trees
/// (top-level objects with their descendants) that `rule` keeps, written to `out` as CityJSON
/// (CityJSONSeq for CityJSONSeq; atomically; `-` for standard output; gzip for a name ending
/// in `.gz`; see `super`).
///
/// # Errors
/// A refused target (a CityGML name among them), a source that cannot be read or is not
/// CityJSON, a box that cannot be converted into the document's CRS, I/O errors.
pub fn subset(
    input: &Path,
    out: &Path,
    rule: &Subset,
    opts: &WriteOptions,
) -> Result<EditSummary, WriteError> {
    with_draw(rule, out, |sample, out| {
        run(input, out, opts, &|| {
            Box::new(SubsetRule(Matcher::new(rule, sample)))
        })
    })
}

/// [`crate::export::transform::citygml::edit::filter_lods`] of a CityJSON / CityJSONSeq document: a
/// geometry's LoD is its integer part (`"2.2"` → 2; a `GeometryInstance`'s is its
/// template's); the mode picks, per tree, the LoDs that stay; the other geometries go; a
/// nested object that lost geometry and has none left in its subtree goes, a tree left
/// without geometry goes whole (unless [`Lods::keep_empty`]); written as [`subset`] writes.
///
/// # Errors
/// As [`subset`].
pub fn filter_lods(
    input: &Path,
    out: &Path,
    rule: &Lods,
    opts: &WriteOptions,
) -> Result<EditSummary, WriteError> {
    run(input, Some(out), opts, &|| Box::new(LodRule(rule)))
}
