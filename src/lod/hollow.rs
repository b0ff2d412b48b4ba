//! The hollow read of one CityGML document for `lod` (`lod` keeps only what the selection
//! needs): the whole read's model without the full polygons, and per asset what the
//! selection needs of them, made while they are in memory.
//!
//! The whole model as read holds every polygon with its points and ids, about half the
//! file's size, until the outputs are written, and the CityGML writer's index of the source
//! comes on top of it: too much for a large document in a job's memory. The
//! selection traces only rough forms; the full geometry it still needs is that of a few assets
//! (level 2, the bound's reference near its rays, the POIs' surroundings), which can be read
//! again by byte span.
//!
//! [`read_hollow`] reads the document in chunks of whole top-level members
//! ([`crate::io::citygml::read::Passes`], the chunked read of `stats` and `convert`). While a
//! chunk's polygons are in memory it computes, per asset:
//!
//! * its rough form ([`rough_asset`], what [`crate::lod::rough::rough_model`] gives the
//!   whole model: the rough stage looks at one asset at a time). The forms are in the
//!   document's coordinates: the hollow read serves a frame that is the identity (a projected
//!   metric CRS); a frame that depends on the whole model needs the whole read;
//! * its box ([`crate::model::Asset::bbox`]: min/max is exact in any order, so the model's box,
//!   the root envelope's and any union of them are the whole read's);
//! * the polygon count of each of its geometry properties (the report's polygon counts);
//! * its full-detail box ([`detail_boxes`], what the bound's lazy reference indexes), and the
//!   chunk's box of full-detail triangles, whose union over the chunks is the frame of the
//!   whole model's full-detail scene (each chunk's is exact, so their union is);
//! * the key of its full-detail polygons ([`detail_key`]), which finds each asset's twin
//!   ([`Hollow::twin`]: the first asset with the same polygons bit for bit, traced in its
//!   stead by the bound's reference);
//!
//! then drops the polygons, unless `keep` asks for the asset whole (e.g. the assets around a
//! POI, whose full geometry the inside-a-building check looks at: `keep` sees the chunk with
//! its polygons, so it can judge a building by all its assets). What is left of the chunk
//! (asset and building metadata, byte spans, the file's envelope sites and counts, warnings)
//! is put together with the other chunks as the whole read puts them
//! ([`crate::io::citygml::read::Chunk`]): a chunk's non-body assets follow the earlier chunks',
//! its bodies go after every non-body asset of the document, building and parent indices
//! shift with them, and the root envelope's box is the union of every chunk's content box.
//!
//! Where the stream declines (a reference across chunks, a DOCTYPE, a document that fails to
//! read), [`read_hollow`] gives `None`: the caller reads the document whole, which also
//! reports any error.
//!
//! The selection runs on a [`Hollow`] ([`crate::lod::lod`]): the rough forms are the
//! read's, the selection scene needs only metadata, the facts of the full polygons it takes
//! (each asset's lowest point, its polygons at a level: [`crate::lod::select::FullFacts`])
//! come from the read, and the full geometry it looks at (the assets whose rough box holds a
//! POI, the buildings whose box holds one: [`near_pois`]) is kept.
//!
//! **Reading back.** A chunk records where it starts ([`ChunkStart`]: its bytes and the state
//! the serial read stands in there) and each asset the chunk it was read in; so the full
//! geometry of any assets can be parsed again from the document ([`Hollow::read_back`] through
//! [`Reread`]): the top-level members that hold them (found from their top-level building's
//! byte span), a chunk's members next to each other in one parse, chunks in parallel, each
//! member parsed with the reader of the stream seeded with its chunk's state (the first
//! chunk's: the state after it), the pages read given back. Lines are counted from the
//! members on (an asset read back keeps the hollow model's metadata, so its lines; only its
//! geometry is taken from the parse, found by span). Members that do not read alone (a
//! reference to another member of the chunk) are read with their whole chunk.
//!
//! The error bound runs on it ([`crate::lod::bound::HollowSource`]): its reference reads back
//! the assets near the rays round by round, its LoD scene the assets above level 0; the
//! frame of the reference is [`Hollow::frame`], the whole model's, so every answer is the
//! whole model's to the bit. Parsing members again costs more than tracing the whole
//! model's reference where the rays reach many members (a document that repeats one street
//! in place: every copy near a ray), which is why a twin is traced in its copies' stead.
//! Tracing the reference chunk by chunk during the read instead would need the whole
//! model's full-detail frame before the first chunk, i.e. a second pass. A member holds
//! many assets and the rounds ask for them a few at a time, so the source keeps, of each
//! member it parses, the assets a later round may ask for ([`Hollow::read_back_keeping`]):
//! no member is parsed twice for them.
//!
//! The mixed CityGML writer runs on it too ([`crate::lod::mixed::MixedSource::Hollow`]: each
//! chunk's kept assets and buildings read back for its plan, [`Hollow::read_back_geometries`]),
//! so `lod` with a CityGML output runs on a [`Hollow`] ([`crate::pipeline::session::Study::read_hollow`]); OBJ and
//! CityJSON outputs still take the whole read.

use crate::io::citygml::read::{Chunk, ChunkStart, Collected, Passes, Reread, StreamSummary};
use crate::lod::level::{polygon_count_of, rough_is_own};
use crate::lod::poi::checks::enclosure::ON_SURFACE;
use crate::lod::poi::checks::Surroundings;
use crate::lod::rough::{rough_asset, RoughGeometry, RoughOptions};
use crate::lod::scene::{detail_boxes, detail_key};
use crate::lod::select::FullFacts;
use crate::model::{content_bbox_of, Asset, Bbox, CityModel, LodGeometry};
use glam::DVec3;
use rayon::prelude::*;
use std::path::Path;

/// A document read hollow ([`read_hollow`]): the whole read's model, every asset's polygons
/// dropped but those `keep` asked for, and what the full polygons gave, per asset in the
/// whole model's order.
#[derive(Debug, Clone, Default)]
pub struct Hollow {
    /// The whole read's model, but for the polygons: an asset's geometry properties are all
    /// there (LoD, property, spans) with no polygons unless it was kept; a building's own
    /// geometry properties have none.
    pub model: CityModel,
    /// Whether each asset kept its polygons.
    pub kept: Vec<bool>,
    /// Each asset's rough form, from its full geometry.
    pub rough: Vec<RoughGeometry>,
    /// Each asset's box, from its full geometry.
    pub boxes: Vec<Bbox>,
    /// Each asset's full-detail box ([`detail_boxes`]).
    pub detail: Vec<Bbox>,
    /// Whether each asset's rough form is its own geometry ([`rough_is_own`]).
    pub own: Vec<bool>,
    /// The box of the full-detail scene's triangles (the second half of [`detail_boxes`]).
    pub frame: Bbox,
    /// Each asset's twin: the first asset of the model whose full-detail polygons are its
    /// own bit for bit ([`detail_key`]), so whose triangles in the full-detail scene are its
    /// own; the asset itself for most (and for an asset without full-detail polygons). The
    /// error bound's reference traces one asset of each such set
    /// ([`crate::lod::bound::FullSource::twins`]).
    pub twin: Vec<u32>,
    /// The box of every polygon of the document, assets' and buildings' own geometry
    /// ([`crate::model::content_bbox`] of the whole model: its root envelope's box).
    pub content: Bbox,
    /// Polygons per geometry property, every asset's in turn ([`Hollow::polygon_counts`]).
    counts: Vec<u32>,
    /// Where each asset's entries of `counts` start.
    count_starts: Vec<usize>,
    /// What the stream found of the whole document.
    pub summary: StreamSummary,
    /// The chunk each asset was read in.
    chunk_of: Vec<u32>,
    /// The chunk each building was read in.
    building_chunk: Vec<u32>,
    /// Where each chunk starts ([`Hollow::read_back`]).
    starts: Vec<ChunkStart>,
}

impl Hollow {
    /// The polygons of each geometry property of asset `a` in the full model
    /// (`asset.geometries[k].polygons.len()`), empty for an asset out of range.
    pub fn polygon_counts(&self, a: usize) -> &[u32] {
        let Some(&start) = self.count_starts.get(a) else {
            return &[];
        };
        let end = (self.count_starts.get(a + 1).copied()).unwrap_or(self.counts.len());
        self.counts.get(start..end).unwrap_or(&[])
    }

    /// Polygons of asset `a` over all its properties ([`Asset::polygon_count`] of the full
    /// asset).
    pub fn polygon_count(&self, a: usize) -> usize {
        self.polygon_counts(a).iter().map(|&n| n as usize).sum()
    }

    /// Polygons of asset `a` at `lod` (the count of [`Asset::polygons_at`] of the full asset).
    pub fn polygon_count_at(&self, a: usize, lod: u8) -> usize {
        let Some(asset) = self.model.assets.get(a) else {
            return 0;
        };
        (asset.geometries.iter().zip(self.polygon_counts(a)))
            .filter(|(g, _)| g.lod == lod)
            .map(|(_, &n)| n as usize)
            .sum()
    }
}

/// The geometry properties of one asset or building.
pub type Geometries = Vec<LodGeometry>;

impl Hollow {
    /// The span of the top-level member's city object that holds building `b` (its top-level
    /// ancestor's) or, without a building, `own`.
    fn anchor(&self, mut at: Option<usize>, own: &crate::model::Span) -> crate::model::Span {
        let b = &self.model.buildings;
        for _ in 0..b.len() {
            match at.and_then(|k| b.get(k)) {
                Some(x) if x.parent.is_some() => at = x.parent,
                Some(x) => return x.span.clone(),
                None => break,
            }
        }
        own.clone()
    }

    /// The assets `want` (indices of the model, each at most once) with their full geometry,
    /// in `want`'s order, read back from the document of `rr` (the one read hollow): the
    /// top-level members that hold them parsed again, a chunk's members next to each other
    /// at once, in parallel ([`Reread::parse`]; a chunk's whole when its members do not read
    /// alone). Each asset is the whole read's: the hollow one with the geometry read back
    /// (found by its span). `None` when one is out of range or cannot be read back.
    pub fn read_back(&self, rr: &Reread, want: &[usize]) -> Option<Vec<Asset>> {
        Some(self.read_back_keeping(rr, want, &[])?.0)
    }

    /// [`Hollow::read_back`] of `want`, and of the assets `also` (indices of the model, none
    /// of `want`'s) those that the members parsed for `want` hold, with their indices: what a
    /// caller that may ask for them later keeps, so as not to parse their members again.
    #[allow(clippy::type_complexity)]
    pub fn read_back_keeping(
        &self,
        rr: &Reread,
        want: &[usize],
        also: &[usize],
    ) -> Option<(Vec<Asset>, Vec<(usize, Asset)>)> {
        let (geometries, _, more) = self.read_back_with(rr, want, &[], also)?;
        let whole = |i: usize, g: Geometries| {
            let mut a = self.model.assets.get(i)?.clone();
            a.geometries = g;
            Some(a)
        };
        let wanted = (want.iter().zip(geometries))
            .map(|(&i, g)| whole(i, g))
            .collect::<Option<_>>()?;
        let more = (more.into_iter())
            .map(|(i, g)| Some((i, whole(i, g)?)))
            .collect::<Option<_>>()?;
        Some((wanted, more))
    }

    /// The full geometry properties of the assets `assets` and of the buildings' own geometry
    /// of `buildings` (indices of the model, each at most once), in their orders, read back
    /// as [`Hollow::read_back`] reads assets back (a building found by its span). `None` when
    /// one is out of range or cannot be read back.
    pub fn read_back_geometries(
        &self,
        rr: &Reread,
        assets: &[usize],
        buildings: &[usize],
    ) -> Option<(Vec<Geometries>, Vec<Geometries>)> {
        let (a, b, _) = self.read_back_with(rr, assets, buildings, &[])?;
        Some((a, b))
    }

    /// Give the kept assets ([`Hollow::kept`]) of a document read without polygon ids
    /// ([`crate::io::citygml::read::ReadOptions::polygon_ids`]) their polygons with ids, read
    /// back from it through `rr` (read with them): the hollow model the read with polygon ids
    /// gives. `None` where they cannot be read back.
    pub fn kept_with_ids(&mut self, rr: &Reread) -> Option<()> {
        let kept: Vec<usize> = (self.kept.iter().enumerate())
            .filter_map(|(i, &k)| k.then_some(i))
            .collect();
        if kept.is_empty() {
            return Some(());
        }
        let (geometries, _) = self.read_back_geometries(rr, &kept, &[])?;
        for (i, g) in kept.into_iter().zip(geometries) {
            self.model.assets.get_mut(i)?.geometries = g;
        }
        Some(())
    }

    /// [`Hollow::read_back_geometries`], and the geometry of the assets `also` (none of
    /// `assets`) that the members parsed hold, with their indices.
    #[allow(clippy::type_complexity)]
    fn read_back_with(
        &self,
        rr: &Reread,
        assets: &[usize],
        buildings: &[usize],
        also: &[usize],
    ) -> Option<(Vec<Geometries>, Vec<Geometries>, Vec<(usize, Geometries)>)> {
        let m = &self.model;
        let asset_at = |i: usize| {
            let a = m.assets.get(i)?;
            Some((*self.chunk_of.get(i)?, self.anchor(a.building, &a.span)))
        };
        let building_at = |i: usize| {
            let b = m.buildings.get(i)?;
            Some((*self.building_chunk.get(i)?, self.anchor(Some(i), &b.span)))
        };
        let mut ranges: Vec<(u32, crate::model::Span)> = (assets.iter().map(|&i| asset_at(i)))
            .chain(buildings.iter().map(|&i| building_at(i)))
            .map(|at| {
                let (c, anchor) = at?;
                Some((c, rr.members(self.starts.get(c as usize)?, anchor)))
            })
            .collect::<Option<_>>()?;
        ranges.sort_unstable_by_key(|(c, r)| (*c, r.start, r.end));
        let mut merged: Vec<(u32, crate::model::Span)> = Vec::new();
        for (c, r) in ranges {
            match merged.last_mut() {
                Some((lc, lr)) if *lc == c && r.start <= lr.end => lr.end = lr.end.max(r.end),
                _ => merged.push((c, r)),
            }
        }
        // assets by span and whether a body, buildings by span (after the assets)
        let key = |s: &crate::model::Span, body: bool| (s.start, s.end, body);
        let mut at: foldhash::HashMap<(u64, u64, bool), usize> = Default::default();
        // slots: `assets`, then `buildings`, then `also`
        let also_from = assets.len() + buildings.len();
        for (k, &i) in also.iter().enumerate() {
            let a = m.assets.get(i)?;
            at.insert(
                key(&a.span, a.kind == crate::model::AssetKind::Body),
                also_from + k,
            );
        }
        for (k, &i) in assets.iter().enumerate() {
            let a = m.assets.get(i)?;
            at.insert(key(&a.span, a.kind == crate::model::AssetKind::Body), k);
        }
        let mut at_b: foldhash::HashMap<(u64, u64), usize> = Default::default();
        for (k, &i) in buildings.iter().enumerate() {
            let b = m.buildings.get(i)?;
            at_b.insert((b.span.start, b.span.end), assets.len() + k);
        }
        let found: Vec<Vec<(usize, Vec<LodGeometry>)>> = (merged.par_iter())
            .map(|(c, r)| {
                let start = self.starts.get(*c as usize)?;
                let m = (rr.parse(start, Some(r.clone()))).or_else(|| rr.parse(start, None))?;
                let body = |a: &Asset| a.kind == crate::model::AssetKind::Body;
                let taken = (m.assets.into_iter())
                    .filter_map(|a| Some((*at.get(&key(&a.span, body(&a)))?, a.geometries)))
                    .chain((m.buildings.into_iter()).filter_map(|b| {
                        Some((*at_b.get(&(b.span.start, b.span.end))?, b.geometries))
                    }))
                    .collect();
                Some(taken)
            })
            .collect::<Option<_>>()?;
        let mut geometries: Vec<Option<Vec<LodGeometry>>> = vec![None; also_from + also.len()];
        for (k, g) in found.into_iter().flatten() {
            if let Some(slot) = geometries.get_mut(k) {
                *slot = Some(g);
            }
        }
        // the `also` assets found, where their members were parsed
        let more = (also.iter().zip(geometries.split_off(also_from)))
            .filter_map(|(&i, g)| Some((i, g?)))
            .collect();
        let mut all: Vec<Vec<LodGeometry>> = geometries.into_iter().collect::<Option<_>>()?;
        let of_buildings = all.split_off(assets.len());
        Some((all, of_buildings, more))
    }
}

impl FullFacts for Hollow {
    fn min_z(&self, i: usize) -> f64 {
        self.boxes.get(i).map_or(f64::INFINITY, |b| b.min.z)
    }

    fn polygon_count(&self, i: usize, rough: Option<&RoughGeometry>, level: u8) -> usize {
        let (Some(a), Some(&own)) = (self.model.assets.get(i), self.own.get(i)) else {
            return 0;
        };
        polygon_count_of(a, self.polygon_counts(i), rough, level, own)
    }

    fn polygons(&self, i: usize) -> usize {
        Hollow::polygon_count(self, i)
    }
}

/// What the hollow read made of an asset from its full geometry, before its polygons went.
struct Made {
    kept: bool,
    rough: RoughGeometry,
    bbox: Bbox,
    detail: Bbox,
    own: bool,
    /// Polygons per geometry property.
    counts: Vec<u32>,
    /// The chunk it was read in.
    chunk: u32,
    /// [`detail_key`] of it (0: none).
    key: u128,
}

/// Which assets of a chunk keep their polygons in [`read_hollow`]: `keep(chunk, rough, boxes)`
/// gets the chunk's model with its polygons, and each asset's rough form and box.
pub type Keep<'a> = dyn Fn(&CityModel, &[RoughGeometry], &[Bbox]) -> Vec<bool> + 'a;

/// Read the CityGML document at `path` hollow (see the module docs): in chunks of `passes`
/// (pass 0 of its progress), each asset's rough form made with `rough`, its polygons kept
/// only where `keep` says so (`keep(chunk, rough, boxes)`: for each asset of a chunk's model,
/// with its polygons, rough forms and boxes, whether it keeps them; e.g. [`near_pois`]). The
/// chunks are put together as the whole read's (the same model, but for the polygons). `None` where the document is to be read whole instead (the stream declines).
pub fn read_hollow(
    path: &Path,
    passes: &Passes<'_>,
    rough: &RoughOptions,
    keep: &Keep<'_>,
) -> Option<Hollow> {
    let mut all: Collected<Made> = Collected::default();
    let mut building_chunk = Vec::new();
    let mut frame = Bbox::EMPTY;
    let mut starts = Vec::new();
    let summary = passes.pass_citygml(path, 0, |mut c: Chunk| {
        let Some(start) = c.start.clone() else {
            return Err(());
        };
        let chunk = u32::try_from(starts.len()).map_err(|_| ())?;
        starts.push(start);
        let model = &mut c.model;
        let (rough, (boxes, keys)): (Vec<RoughGeometry>, (Vec<Bbox>, Vec<u128>)) =
            (model.assets.par_iter())
                .map(|a| {
                    let key = detail_key(a).unwrap_or(0);
                    (rough_asset(a, rough), (a.bbox(), key))
                })
                .unzip();
        // the chunk's content box from its assets' boxes (content_bbox)
        let content = content_bbox_of(boxes.iter().copied(), &model.buildings);
        let (detail, tris) = detail_boxes(model);
        frame.union(&tris);
        let kept = keep(model, &rough, &boxes);
        let made = rough.into_iter().zip(boxes).zip(detail).zip(keys).zip(kept);
        let made = (model.assets.iter_mut().zip(made))
            .map(|(a, ((((rough, bbox), detail), key), kept))| {
                let made = Made {
                    own: rough_is_own(a, &rough),
                    counts: (a.geometries.iter())
                        .map(|g| u32::try_from(g.polygons.len()).unwrap_or(u32::MAX))
                        .collect(),
                    kept,
                    rough,
                    bbox,
                    detail,
                    key,
                    chunk,
                };
                if !kept {
                    drop_polygons(&mut a.geometries);
                }
                made
            })
            .collect();
        for b in &mut model.buildings {
            drop_polygons(&mut b.geometries);
            building_chunk.push(chunk);
        }
        all.add(c, content, made);
        Ok::<(), ()>(())
    });
    let Ok(Some(summary)) = summary else {
        return None;
    };
    let content = all.content();
    let (model, made) = all.finish(&summary)?;
    let mut h = Hollow {
        model,
        content,
        frame,
        summary,
        starts,
        building_chunk,
        ..Hollow::default()
    };
    // a compressed document is streamed from its decompressed copy
    h.model.files[0].gzip = crate::io::files::is_gzip_file(path);
    h.twin = twins(made.iter().map(|m| &m.key));
    for m in made {
        h.kept.push(m.kept);
        h.rough.push(m.rough);
        h.boxes.push(m.bbox);
        h.detail.push(m.detail);
        h.own.push(m.own);
        h.chunk_of.push(m.chunk);
        h.count_starts.push(h.counts.len());
        h.counts.extend(m.counts);
    }
    Some(h)
}

/// The assets whose full geometry the POI checks of `lod` look at, for POIs at `points` (in
/// the document's coordinates), as a `keep` of [`read_hollow`]: every asset of a building
/// whose box, grown by `ON_SURFACE`, holds a POI ([`Surroundings::assets_holding`]: the
/// inside-a-building and normal checks) and every asset whose rough box holds one
/// (`crate::lod::select::rough_holds_poi_full_not`). A building and its parts are one
/// top-level member, so a chunk sees each whole.
pub fn near_pois(
    points: &[DVec3],
) -> impl Fn(&CityModel, &[RoughGeometry], &[Bbox]) -> Vec<bool> + '_ {
    move |chunk, rough, boxes| {
        let around = Surroundings::with_boxes(chunk, boxes);
        let mut keep = vec![false; chunk.assets.len()];
        for &p in points {
            for i in around.assets_holding(p, ON_SURFACE) {
                if let Some(k) = keep.get_mut(i as usize) {
                    *k = true;
                }
            }
            for (k, r) in keep.iter_mut().zip(rough) {
                *k |= r.obb.as_ref().is_some_and(|b| b.contains(p, 0.0));
            }
        }
        keep
    }
}

/// Each asset's twin ([`Hollow::twin`]) from their [`detail_key`]s in the model's order
/// (0: none).
fn twins<'k>(keys: impl Iterator<Item = &'k u128>) -> Vec<u32> {
    let mut first: foldhash::HashMap<u128, u32> = Default::default();
    keys.enumerate()
        .map(|(i, &k)| {
            let i = u32::try_from(i).unwrap_or(u32::MAX);
            if k == 0 {
                i
            } else {
                *first.entry(k).or_insert(i)
            }
        })
        .collect()
}

/// `geometries` without their polygons (LoD, property and spans kept): what [`read_hollow`]
/// leaves of the geometry of an asset not kept and of a building.
pub fn drop_polygons(geometries: &mut [LodGeometry]) {
    geometries.iter_mut().for_each(|g| g.polygons = Vec::new());
}

/// `model`, the whole read of a document, as [`read_hollow`] leaves it where it keeps the
/// assets of `kept`: what a hollow read must equal.
pub fn hollowed(mut model: CityModel, kept: &[bool]) -> CityModel {
    for (a, &k) in model.assets.iter_mut().zip(kept) {
        if !k {
            drop_polygons(&mut a.geometries);
        }
    }
    (model.buildings.iter_mut()).for_each(|b| drop_polygons(&mut b.geometries));
    model
}

#[cfg(test)]
mod tests;
