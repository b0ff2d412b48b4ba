//! Error-bounded LoD (DESIGN.md "Regions and error bounds"): after the selection, compare the
//! mixed-LoD model with the full model at every POI with the *same* rays, and promote assets
//! (level 0 → 1, 1 → 2) where a POI's relative SVF, sun-hours or annual-irradiation error is
//! over the bound, until every POI holds.
//!
//! **Rays.** SVF uses the equal-projected-area bundle of [`SkyBundles`] in the POI's frame
//! (exactly as [`crate::solar::poi_sky_view`]: the figures here equal it); sun hours use every
//! step of a [`SunTable`] in front of the surface (as [`crate::solar::poi_sun_hours`]). Each
//! ray is traced to its first hit in both models: the full model once, the LoD model
//! ([`crate::lod::scene::mixed_scene`], the model `lod` writes) once per round.
//!
//! **Reference.** The full model is not built whole (its BVH was most of the bound's time
//! and memory: 805K triangles on the paper district, ~6 M on a 1 GB city), only the full
//! geometry of the assets the rays can reach, found lazily on one box per asset (the box of
//! its full-detail polygons, which holds its triangles, grown by a margin far above the f32
//! rounding, [`crate::solar::trace::BoxIndex`]). First the 4 nearest boxes of every ray are built
//! (a ray whose hit comes before the last of them is then final at once); then, round
//! after round, each pending ray is traced in the part built so far, and if a box it
//! crosses before its hit (any box, when it hits nothing; the `4^round` nearest until
//! round 4) is not built yet, those assets are added and the ray waits for the next round;
//! otherwise its answer is final. A round builds only the assets added since the last and
//! keeps each ray's nearest answer over the parts by (f32 distance, asset), the whole
//! model's order. The part is built in the frame of the whole model
//! ([`crate::solar::trace::SceneBuilder::with_frame`]: same origin, same f32 triangles, same node
//! growth) with its triangles in the whole model's order, so the f32 distances are those of
//! the whole model and ties go to the same triangle; and since every triangle a ray may hit
//! at or before its answer lies in a box the ray enters before that answer (with a slack of
//! 2e-3 relative plus the margin), no left-out triangle can win: every answer is the
//! whole model's, asset and distance to the bit
//! (`restricted_full_scene_answers_as_the_whole_model` checks it ray by ray). A part's
//! answer is never nearer than the whole model's, so the limits only shrink and each round
//! ends rays or adds assets. When the rays outnumber the model's full-detail polygons (many
//! POIs on a small model), the rounds would cost more than the BVH they avoid, and the whole
//! model is built at once ([`Reference::whole`]). On the paper district the 6 POIs' rays
//! reach 2,500 of 57,530 assets.
//! The full model is a [`FullSource`]: the whole model, or a document read hollow whose
//! assets are read back by span as the rounds and the LoD scene need them ([`HollowSource`]).
//! Where the source knows twins ([`FullSource::twins`]: assets whose full-detail polygons
//! are bit for bit an earlier asset's, [`crate::lod::hollow::Hollow::twin`]), an asset a
//! round adds is built as its twin: the same triangles, so the same distances, and the
//! earlier index wins the tie as in the whole model; the assets added, the rounds and every
//! answer are those without twins. A document that repeats its buildings in place (the
//! bench files: one street stacked ~150 times in 4 GB) so reads back one copy, not every
//! copy the rays reach.
//!
//! **Two halves.** The full model's answers depend on the POIs, the rays and the model, not
//! on the levels: [`full_answers`] makes them ([`FullAnswers`]) and [`bound_against`] checks
//! a set of levels against them and promotes; [`bound_with`] is the one after the other.
//! `lod` ([`crate::pipeline::levels`]) makes the first half beside the rough model and the
//! selection, so that each fills the other's one-core stretches (the boxes' index and the
//! part's BVH are built on one core, as are the selection scene and the POI checks).
//!
//! **Irradiance** ([`bound_with`] and a weather year): the annual global irradiation of the
//! POI's plane ([`crate::solar::irradiance`]) from the SVF rays above and one sun ray per
//! hour the sun is up in front of the plane ([`PlaneRays`]); both models' figures equal
//! [`crate::solar::poi_irradiance`] with the same bundle. Its rays weigh what they bring
//! ([`PlaneRays::weights`]: Wh/m² of diffuse light per sky ray, of beam and circumsolar
//! light per sun ray), so the culprits below are ranked by the irradiation they take away
//! or add, not by their rays.
//!
//! **Promotion.** At a POI over the bound, the rays whose answers differ tell which assets
//! are to blame. When the LoD model sees *less* sky than the full one, the culprits are the
//! assets the LoD model hits on rays that reach the sky in the full model (a rough box or
//! plane larger than the detail); when it sees *more*, they are the assets the full model
//! hits on rays that reach the sky in the LoD model (an asset dropped, or a rough plane
//! smaller than the detail, e.g. an asset hidden by a neighbour's rough box that becomes
//! visible through the neighbour's real geometry). Culprits below level 2 are promoted in
//! decreasing order of their rays until their rays cover the excess over the bound; when
//! none is left, any asset below level 2 hit by a differing ray (sky against hit, or two
//! different assets) is promoted. Levels only rise, so the loop ends; when a POI is over
//! the bound and nothing can be promoted (or [`BoundOptions::max_rounds`] is reached), the
//! result says which POIs fail ([`Bounded::met`] is false).
//!
//! # Example
//! ```
//! use skylod::lod::{BoundOptions, bound};
//! use skylod::lod::{lod, LodOptions};
//! use skylod::lod::poi::Poi;
//! use skylod::model::synth::{generate, pois, Preset};
//! let opts = Preset::Small.defaults();
//! let mut xml = Vec::new();
//! generate(&opts, &mut xml).unwrap();
//! let model = skylod::io::citygml::read_bytes(&xml, "small.gml").unwrap();
//! let pois: Vec<Poi> = pois(&opts).into_iter().map(Into::into).collect();
//! let r = lod(&model, &pois, &LodOptions::default(), &skylod::Silent).unwrap();
//! let b = BoundOptions { max_svf_error: Some(0.001), ..Default::default() };
//! let out = bound(&model, &r.rough, &r.selection.levels, &pois, &b, None).unwrap();
//! assert!(out.met);
//! for p in &out.pois {
//!     assert!(p.svf_error <= 0.001, "{}: {}", p.id, p.svf_error);
//! }
//! // levels only rise
//! assert!(out.levels.iter().zip(&r.selection.levels).all(|(a, b)| a >= b));
//! ```

use crate::lod::poi::{Poi, POI_OFFSET};
use crate::lod::rough::RoughGeometry;
use crate::model::{Bbox, CityModel};
use crate::solar::irradiance::{IrradianceSetting, PlaneRays};
use crate::solar::sky::{Frame, SkyError};
use crate::solar::trace::{BoxIndex, TraceScene};
use crate::solar::{SkyBundles, SunTable};
use foldhash::{HashMap, HashMapExt};
use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;
use std::sync::atomic::{AtomicBool, Ordering};

pub use super::bound_report::{BoundReport, PoiBound, Promotion};
pub use source::{FullSource, HollowSource};

mod source;

/// Options of [`bound`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoundOptions {
    /// Largest relative SVF error allowed at any POI (`None`: not bounded).
    pub max_svf_error: Option<f64>,
    /// Largest relative sun-hours error allowed at any POI (`None`: not bounded; needs a
    /// sun table).
    pub max_sun_error: Option<f64>,
    /// Rays of the SVF bundle.
    pub svf_rays: usize,
    /// Seed of the SVF bundle.
    pub svf_seed: u64,
    /// Most rounds of promotions before giving up.
    pub max_rounds: usize,
    /// Largest relative error of the annual global irradiation allowed at any POI (`None`:
    /// not bounded; needs a weather year, `bound_with`).
    pub max_irradiance_error: Option<f64>,
}

impl Default for BoundOptions {
    fn default() -> Self {
        BoundOptions {
            max_svf_error: None,
            max_sun_error: None,
            svf_rays: 20_000,
            svf_seed: 7,
            max_rounds: 64,
            max_irradiance_error: None,
        }
    }
}

/// Errors of [`bound`].
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BoundError {
    /// The SVF bundle could not be made.
    #[error("SVF bundle: {0}")]
    Sky(#[from] SkyError),
    /// A sun-hours bound without a sun table.
    #[error("a sun-hours error bound needs a sun table (site and year)")]
    NoSunTable,
    /// An irradiance bound without a weather year.
    #[error("an irradiance error bound needs a weather year")]
    NoWeather,
    /// A bound that is negative or not a number.
    #[error("error bound {0} is not a non-negative number")]
    BadBound(f64),
    /// One level per asset and one rough geometry per asset are needed.
    #[error("{levels} levels and {rough} rough geometries for {assets} assets")]
    Mismatch {
        /// Assets.
        assets: usize,
        /// Levels given.
        levels: usize,
        /// Rough geometries given.
        rough: usize,
    },
    /// The full geometry of assets of a document read hollow could not be read back from it.
    #[error("{}: the full geometry of {assets} asset(s) could not be read back", path.display())]
    ReadBack {
        /// The document.
        path: std::path::PathBuf,
        /// Assets asked for.
        assets: usize,
    },
}

/// What [`bound`] made.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Bounded {
    /// Levels after the promotions.
    pub levels: Vec<u8>,
    /// Figures per POI with the final levels, in POI order.
    pub pois: Vec<PoiBound>,
    /// Promotions in the order made.
    pub promotions: Vec<Promotion>,
    /// Rounds of tracing the LoD model (1 when nothing had to be promoted).
    pub rounds: usize,
    /// Whether every POI holds.
    pub met: bool,
    /// What tracing the full model took.
    pub reference: Reference,
}

/// What tracing the full model took ([`Bounded::reference`]): how much of it was built.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct Reference {
    /// Assets whose full geometry was built into the reference scene.
    pub assets: usize,
    /// Of the model's assets with geometry.
    pub of: usize,
    /// Scenes built (rounds of the lazy reference trace).
    pub rounds: usize,
    /// Whether the whole model was built at once (more rays than full-detail polygons).
    pub whole: bool,
}

impl Bounded {
    /// Ids of the POIs over a bound.
    pub fn failing(&self) -> Vec<&str> {
        self.pois
            .iter()
            .filter(|p| !p.holds)
            .map(|p| p.id.as_str())
            .collect()
    }
}

/// Relative error of `a` against `b` (0 when both are 0, infinite when only `b` is): the
/// figure of the error bound and of `lod::evaluation`'s model figures.
pub(crate) fn rel(a: f64, b: f64) -> f64 {
    if b == 0.0 {
        if a == 0.0 {
            0.0
        } else {
            f64::INFINITY
        }
    } else {
        (a - b).abs() / b.abs()
    }
}

/// The rays of one POI: SVF directions, sun directions, then the sun directions of the
/// irradiance hours (world frame).
struct Probe {
    origin: DVec3,
    svf_dirs: Vec<DVec3>,
    sun_dirs: Vec<DVec3>,
    irr_dirs: Vec<DVec3>,
    plane: Option<PlaneRays>,
}

fn probe(
    poi: &Poi,
    bundles: &SkyBundles,
    table: Option<&SunTable>,
    irr: Option<&IrradianceSetting>,
) -> Probe {
    let n = poi
        .normal
        .and_then(|n| n.try_normalize())
        .unwrap_or(DVec3::Z);
    let frame = Frame::from_normal(n);
    let svf_dirs: Vec<DVec3> = bundles
        .projected_dirs_for(poi)
        .into_iter()
        .map(|l| frame.to_world(l))
        .filter(|d| d.z > 0.0)
        .collect();
    let plane = irr.map(|w| PlaneRays::new(&w.table, poi.normal, &svf_dirs, bundles.len()));
    let irr_dirs = match (irr, &plane) {
        (Some(w), Some(p)) => p.sun_dirs(&w.table),
        _ => Vec::new(),
    };
    let sun_dirs = table.map_or_else(Vec::new, |t| {
        t.steps()
            .iter()
            .filter(|s| s.above_horizon && n.dot(s.direction) > 0.0)
            .map(|s| s.direction)
            .collect()
    });
    Probe {
        origin: poi.ray_origin(),
        svf_dirs,
        sun_dirs,
        irr_dirs,
        plane,
    }
}

impl Probe {
    fn len(&self) -> usize {
        self.svf_dirs.len() + self.sun_dirs.len() + self.irr_dirs.len()
    }

    /// Ray `j`: SVF rays, then sun rays, then irradiance sun rays.
    fn dir(&self, j: usize) -> DVec3 {
        let (ns, nu) = (self.svf_dirs.len(), self.sun_dirs.len());
        let d = if j < ns {
            self.svf_dirs.get(j)
        } else if j < ns + nu {
            self.sun_dirs.get(j - ns)
        } else {
            self.irr_dirs.get(j - ns - nu)
        };
        d.copied().unwrap_or(DVec3::ZERO)
    }
}

/// Rounds of the reference trace after which a ray that hits nothing checks every asset
/// box it crosses at once; before, the `4^round` nearest ones not yet built.
const UNCAPPED_ROUND: u32 = 4;

/// First-hit tags of every ray of every probe in the full model, as [`tags`] on
/// [`crate::lod::scene::full_scene`] gives them, from a scene built only of the assets the
/// rays can reach (see [`full_tags`] in the module docs, "Reference").
#[allow(clippy::type_complexity)]
fn full_tags(
    src: &dyn FullSource,
    probes: &[Probe],
    boxes: &AssetBoxes,
) -> Result<(Vec<Vec<Option<u32>>>, Reference), BoundError> {
    let rays: usize = probes.iter().map(Probe::len).sum();
    let (polygons, of) = src.detail_polygons();
    if rays > polygons {
        // many rays, a small model: the lazy rounds would cost more than the whole BVH
        let whole = source::full_part(src, None, None)?;
        let reference = Reference {
            assets: of,
            of,
            rounds: 1,
            whole: true,
        };
        return Ok((probes.iter().map(|p| tags(&whole, p)).collect(), reference));
    }
    let lazy = lazy_hits_with(src, probes, boxes, SEED_BOXES);
    src.expect(None);
    let (hits, reference) = lazy?;
    let tags = hits
        .into_iter()
        .map(|v| v.into_iter().map(|h| h.map(|h| h.0)).collect())
        .collect();
    Ok((tags, reference))
}

/// Boxes per ray looked up before the first round: the [`SEED_BOXES`] nearest ones
/// ([`BoxIndex::nearest_k`]). Their assets make the first part, and a ray whose answer
/// there comes before the last of them is final without another box query. On the paper
/// district (6 POIs, 118,888 rays) 1 box builds 2,816 assets in 3 rounds, 4 boxes 2,500 in
/// 2 rounds (the least work), 8 boxes 5,031 in one round (boxes behind the answer are built
/// too).
const SEED_BOXES: usize = 4;

/// [`full_tags`] through the lazy rounds (see the module docs, "Reference"), with the
/// distance of each hit.
#[allow(clippy::type_complexity)]
#[cfg(test)]
fn lazy_hits(model: &CityModel, probes: &[Probe]) -> (Vec<Vec<Option<(u32, f64)>>>, Reference) {
    lazy_hits_with(model, probes, &AssetBoxes::new(model), SEED_BOXES).unwrap_or_default()
}

/// The boxes of the lazy reference: per asset the box of its full-detail polygons
/// ([`detail_boxes`]) grown by `margin`, indexed, in the frame of the whole full scene.
struct AssetBoxes {
    /// `None` when the model has no full-detail triangle.
    index: Option<BoxIndex>,
    frame: Bbox,
    margin: f64,
    /// Assets with a box.
    of: usize,
}

impl AssetBoxes {
    fn new(src: &dyn FullSource) -> AssetBoxes {
        let (boxes, frame) = src.detail_boxes();
        let of = boxes.iter().filter(|b| !b.is_empty()).count();
        // Far above the f32 rounding of the scene (its node growth): a triangle's hit
        // point lies inside its asset's grown box.
        let far = (frame.max - frame.center()).abs().max_element().max(1.0);
        let margin = far / 32768.0 + 1e-3;
        let index = (!frame.is_empty()).then(|| BoxIndex::new(boxes, margin));
        AssetBoxes {
            index,
            frame,
            margin,
            of,
        }
    }
}

/// [`lazy_hits`] seeded with the `seed_boxes` nearest boxes of every ray (at least 1).
///
/// Each round builds only the assets added since the round before (a pending ray was
/// traced in every earlier part) and keeps, per ray, the nearest answer of the parts so
/// far by (f32 distance, asset): the answer of their union, since the whole model orders
/// its triangles by asset and breaks ties of the f32 distance by that order.
#[allow(clippy::type_complexity)]
fn lazy_hits_with(
    src: &dyn FullSource,
    probes: &[Probe],
    boxes: &AssetBoxes,
    seed_boxes: usize,
) -> Result<(Vec<Vec<Option<(u32, f64)>>>, Reference), BoundError> {
    let seed_boxes = seed_boxes.max(1);
    let mut out: Vec<Vec<Option<(u32, f64)>>> =
        probes.iter().map(|p| vec![None; p.len()]).collect();
    let mut reference = Reference {
        of: boxes.of,
        ..Default::default()
    };
    let (Some(index), frame, margin) = (&boxes.index, boxes.frame, boxes.margin) else {
        return Ok((out, reference));
    };
    let rays: Vec<(u32, u32)> = probes
        .iter()
        .enumerate()
        .flat_map(|(k, p)| (0..p.len()).map(move |j| (k as u32, j as u32)))
        .collect();
    // seed: the nearest boxes of every ray, all built in the first round
    let seeded: Vec<AtomicBool> = (0..src.asset_count())
        .map(|_| AtomicBool::new(false))
        .collect();
    let known: Vec<f32> = rays
        .par_iter()
        .with_min_len(512)
        .map_init(Vec::new, |v, &(k, j)| {
            let p = &probes[k as usize];
            v.clear();
            index.nearest_k(p.origin, p.dir(j as usize), seed_boxes, v);
            for &(_, a) in v.iter() {
                if let Some(x) = seeded.get(a as usize) {
                    x.store(true, Ordering::Relaxed);
                }
            }
            // a box not listed is entered at this distance or later (rounded down)
            v.get(seed_boxes - 1)
                .map_or(f32::INFINITY, |x| (x.0 * (1.0 - 1e-6) - 1e-3) as f32)
        })
        .collect();
    let mut include: Vec<bool> = seeded.into_iter().map(AtomicBool::into_inner).collect();
    // an asset is built as its twin, whose triangles are its own and whose index comes
    // first: the whole model's answer to a tie of the two
    let as_twins = |of: &[bool]| source::as_twins(src, of);
    let mut built = vec![false; include.len()];
    let mut pending: Vec<Pending> = rays
        .into_iter()
        .zip(known)
        .map(|((probe, ray), known)| Pending {
            probe,
            ray,
            known,
            crossed: None,
            best: None,
        })
        .collect();
    loop {
        reference.rounds += 1;
        let new: Vec<bool> = (as_twins(&include).into_iter().zip(&built))
            .map(|(i, &b)| i && !b)
            .collect();
        src.expect(Some(&as_twins(&later_of(&pending, &new, &include))));
        let scene = source::full_part(src, Some(&new), Some((frame, pending.len())))?;
        built.iter_mut().zip(&new).for_each(|(b, &n)| *b |= n);
        let cap = if reference.rounds as u32 >= UNCAPPED_ROUND {
            usize::MAX
        } else {
            1 << (2 * reference.rounds)
        };
        let include_ref = &include;
        // the assets each ray still needs (none: its answer is final)
        let missing: Vec<Vec<u32>> = pending
            .par_iter_mut()
            .with_min_len(256)
            .map_init(Vec::new, |v, p| {
                let (o, d) = (
                    probes[p.probe as usize].origin,
                    probes[p.probe as usize].dir(p.ray as usize),
                );
                if let Some((h, t32)) = scene.first_hit_f32(o, d, POI_OFFSET, f64::INFINITY) {
                    // nearer, or as near and of an asset earlier in the model
                    if p.best.is_none_or(|b| (t32, h.tag) < (b.t32, b.tag)) {
                        p.best = Some(Best {
                            t32,
                            tag: h.tag,
                            t: h.t,
                        });
                    }
                }
                let h = p.best;
                // every asset a triangle of which the ray may hit as close as `h`
                let limit = h.map_or(f64::INFINITY, |h| h.t + 2e-3 * (1.0 + h.t.abs()) + margin);
                if p.known == f32::INFINITY || limit < f64::from(p.known) {
                    // every box entered up to `limit` was seeded, so built
                    return Vec::new();
                }
                let missing_of = |it: &mut dyn Iterator<Item = u32>| -> Vec<u32> {
                    it.filter(|&a| !include_ref.get(a as usize).copied().unwrap_or(true))
                        .take(if h.is_some() { usize::MAX } else { cap })
                        .collect()
                };
                let missing = match &p.crossed {
                    // every box the ray crosses, known from an earlier round
                    Some(list) => missing_of(
                        &mut list
                            .iter()
                            .take_while(|x| f64::from(x.0) <= limit)
                            .map(|x| x.1),
                    ),
                    None => {
                        v.clear();
                        index.crossed(o, d, limit, v);
                        if h.is_none() {
                            // entries rounded down: a later limit keeps every box it must
                            p.crossed = Some(
                                v.iter()
                                    .map(|&(t, i)| ((t * (1.0 - 1e-6) - 1e-3) as f32, i))
                                    .collect(),
                            );
                        }
                        missing_of(&mut v.iter().map(|x| x.1))
                    }
                };
                missing
            })
            .collect();
        drop(scene);
        let mut next = Vec::new();
        for (p, missing) in pending.into_iter().zip(missing) {
            if missing.is_empty() {
                out[p.probe as usize][p.ray as usize] = p.best.map(|b| (b.tag, b.t));
            } else {
                next.push(p);
                for a in missing {
                    include[a as usize] = true;
                }
            }
        }
        if next.is_empty() {
            reference.assets = include.iter().filter(|&&x| x).count();
            return Ok((out, reference));
        }
        pending = next;
    }
}

/// The assets a round of [`lazy_hits_with`] builds (`new`) and those a later round may add
/// ([`FullSource::expect`]): the boxes not included yet that a pending ray which hit nothing
/// so far crosses (a ray that hit something added every box before its hit at once, and its
/// limit only shrinks).
fn later_of(pending: &[Pending], new: &[bool], include: &[bool]) -> Vec<bool> {
    let mut later = new.to_vec();
    for p in pending.iter().filter(|p| p.best.is_none()) {
        for &(_, a) in p.crossed.iter().flat_map(|c| c.iter()) {
            if let (Some(l), Some(false)) = (later.get_mut(a as usize), include.get(a as usize)) {
                *l = true;
            }
        }
    }
    later
}

/// A ray of the reference trace still open.
struct Pending {
    /// Probe and ray.
    probe: u32,
    ray: u32,
    /// Entry of the last seeded box, rounded down (infinite when the ray crosses no
    /// other): every box entered before it is built.
    known: f32,
    /// Every box it crosses (entry rounded down, nearest first), once it was seen to hit
    /// nothing.
    crossed: Option<Box<[(f32, u32)]>>,
    /// Its nearest hit in the parts built so far.
    best: Option<Best>,
}

/// A hit of the reference trace: f32 distance and asset (what orders hits), and the
/// distance ([`crate::solar::trace::Hit::t`]).
#[derive(Clone, Copy)]
struct Best {
    t32: f32,
    tag: u32,
    t: f64,
}

/// First-hit tags of every ray of a probe (SVF rays, sun rays, irradiance sun rays).
fn tags(scene: &TraceScene, p: &Probe) -> Vec<Option<u32>> {
    p.svf_dirs
        .par_iter()
        .chain(p.sun_dirs.par_iter())
        .chain(p.irr_dirs.par_iter())
        .with_min_len(512)
        .map(|&d| {
            scene
                .first_hit(p.origin, d, POI_OFFSET, f64::INFINITY)
                .map(|h| h.tag)
        })
        .collect()
}

/// A POI over a bound: its index, the range of its rays that measure the metric, the
/// excess over the bound (in rays, or in Wh/m² with weights), whether the LoD model gives
/// less than the full one, and the weights of all its rays (irradiance only).
type Over<'a> = (usize, std::ops::Range<usize>, f64, bool, Option<&'a [f64]>);

/// What each ray of a probe brings to the irradiation ([`PlaneRays::weights`]): SVF rays
/// and irradiance sun rays; 0 for the sun-hours rays.
fn irradiance_weights(p: &Probe, w: &IrradianceSetting) -> Vec<f64> {
    let Some(plane) = &p.plane else {
        return vec![0.0; p.len()];
    };
    let pw = plane.weights(&w.table, &w.opts);
    let ns = p.svf_dirs.len();
    let mut out = Vec::with_capacity(p.len());
    out.extend_from_slice(&pw[..ns.min(pw.len())]);
    out.extend(std::iter::repeat_n(0.0, p.sun_dirs.len()));
    out.extend_from_slice(pw.get(ns..).unwrap_or(&[]));
    out
}

/// Sky rays among `tags[range]`.
fn sky(tags: &[Option<u32>]) -> usize {
    tags.iter().filter(|t| t.is_none()).count()
}

/// Check the mixed-LoD model given by `levels` against the full model at every POI and
/// promote assets until every POI is within the bounds of `opts` (see the module docs).
/// `rough[i]` and `levels[i]` belong to `model.assets[i]`.
///
/// # Errors
/// [`BoundError`] for a bad bound, a sun-hours bound without `table`, mismatched lengths or
/// an SVF bundle that cannot be made. A bound that cannot be met is not an error: see
/// [`Bounded::met`].
pub fn bound(
    model: &CityModel,
    rough: &[RoughGeometry],
    levels: &[u8],
    pois: &[Poi],
    opts: &BoundOptions,
    table: Option<&SunTable>,
) -> Result<Bounded, BoundError> {
    bound_with(model, rough, levels, pois, opts, table, None)
}

/// [`bound`], and with `irradiance` (a weather year) the annual-irradiation bound of
/// [`BoundOptions::max_irradiance_error`] (see the module docs, "Irradiance").
///
/// # Errors
/// As [`bound`], and [`BoundError::NoWeather`] for an irradiance bound without
/// `irradiance`.
pub fn bound_with(
    model: &CityModel,
    rough: &[RoughGeometry],
    levels: &[u8],
    pois: &[Poi],
    opts: &BoundOptions,
    table: Option<&SunTable>,
    irradiance: Option<&IrradianceSetting>,
) -> Result<Bounded, BoundError> {
    mismatch(model.assets.len(), rough, levels)?;
    let full = full_answers(model, pois, opts, table, irradiance)?;
    bound_against(model, rough, levels, &full)
}

/// The levels and rough geometries must be one per asset.
fn mismatch(n: usize, rough: &[RoughGeometry], levels: &[u8]) -> Result<(), BoundError> {
    if levels.len() != n || rough.len() != n {
        return Err(BoundError::Mismatch {
            assets: n,
            levels: levels.len(),
            rough: rough.len(),
        });
    }
    Ok(())
}

/// The full model's side of [`bound_with`], which does not depend on the levels: the rays
/// of every POI and their first hits in the full model (module docs, "Reference"). Made by
/// [`full_answers`], e.g. beside the selection ([`crate::pipeline::levels`]); used by
/// [`bound_against`] with the model it was made from.
pub struct FullAnswers<'a> {
    pois: &'a [Poi],
    opts: BoundOptions,
    /// The sun table when sun hours are bounded.
    table: Option<&'a SunTable>,
    irr: Option<&'a IrradianceSetting>,
    /// Rays of the SVF bundle, and hours of a sun step.
    total: f64,
    step_h: f64,
    probes: Vec<Probe>,
    /// Per POI, what each of its rays brings to the irradiation (all rays, 0 but for the
    /// SVF and irradiance ones).
    weights: Vec<Option<Vec<f64>>>,
    tags: Vec<Vec<Option<u32>>>,
    reference: Reference,
    assets: usize,
}

impl std::fmt::Debug for FullAnswers<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FullAnswers")
            .field("pois", &self.pois.len())
            .field("rays", &self.probes.iter().map(Probe::len).sum::<usize>())
            .field("reference", &self.reference)
            .finish()
    }
}

/// The full model's answers to every ray of the bound of `opts` at `pois` ([`FullAnswers`]):
/// the first half of [`bound_with`], which needs no levels.
///
/// # Errors
/// As [`bound_with`], but for [`BoundError::Mismatch`].
pub fn full_answers<'a>(
    model: &CityModel,
    pois: &'a [Poi],
    opts: &BoundOptions,
    table: Option<&'a SunTable>,
    irradiance: Option<&'a IrradianceSetting>,
) -> Result<FullAnswers<'a>, BoundError> {
    full_answers_from(model, pois, opts, table, irradiance)
}

/// `full_answers` of the full model `src` (e.g. a document read hollow, its assets read
/// back by span: [`HollowSource`]): the same answers as of the whole model.
///
/// # Errors
/// As `full_answers`, and [`BoundError::ReadBack`].
pub fn full_answers_from<'a>(
    src: &dyn FullSource,
    pois: &'a [Poi],
    opts: &BoundOptions,
    table: Option<&'a SunTable>,
    irradiance: Option<&'a IrradianceSetting>,
) -> Result<FullAnswers<'a>, BoundError> {
    let max_irr = opts.max_irradiance_error;
    for b in [opts.max_svf_error, opts.max_sun_error, max_irr]
        .into_iter()
        .flatten()
    {
        if b.is_nan() || b < 0.0 {
            return Err(BoundError::BadBound(b));
        }
    }
    if opts.max_sun_error.is_some() && table.is_none() {
        return Err(BoundError::NoSunTable);
    }
    if max_irr.is_some() && irradiance.is_none() {
        return Err(BoundError::NoWeather);
    }
    let irr = if max_irr.is_some() { irradiance } else { None };
    let bundles = SkyBundles::new(opts.svf_rays, opts.svf_seed)?;
    let total = bundles.len().max(1) as f64;
    let step_h = table.map_or(0.0, SunTable::step_hours);
    let table = if opts.max_sun_error.is_some() {
        table
    } else {
        None
    };
    // the boxes' index is built on one core: the probes beside it
    let (boxes, probes) = rayon::join(
        || AssetBoxes::new(src),
        || -> Vec<Probe> {
            (pois.par_iter())
                .map(|p| probe(p, &bundles, table, irr))
                .collect()
        },
    );
    let weights: Vec<Option<Vec<f64>>> = (probes.iter())
        .map(|p| Some(irradiance_weights(p, irr?)))
        .collect();
    let (tags, reference) = full_tags(src, &probes, &boxes)?;
    Ok(FullAnswers {
        pois,
        opts: *opts,
        table,
        irr,
        total,
        step_h,
        probes,
        weights,
        tags,
        reference,
        assets: src.asset_count(),
    })
}

/// The second half of [`bound_with`]: the LoD model of `levels` against `full` (made from
/// the same `model` by [`full_answers`]), assets promoted until every POI holds.
///
/// # Errors
/// [`BoundError::Mismatch`] when `levels` or `rough` are not one per asset of the model
/// `full` was made from.
pub fn bound_against(
    model: &CityModel,
    rough: &[RoughGeometry],
    levels: &[u8],
    full: &FullAnswers<'_>,
) -> Result<Bounded, BoundError> {
    bound_against_from(model, rough, levels, full)
}

/// `bound_against` for the full model `src` ([`full_answers_from`]): the assets of the
/// LoD scene read from it as they rise above level 0.
///
/// # Errors
/// As `bound_against`, and [`BoundError::ReadBack`].
pub fn bound_against_from(
    src: &dyn FullSource,
    rough: &[RoughGeometry],
    levels: &[u8],
    full: &FullAnswers<'_>,
) -> Result<Bounded, BoundError> {
    mismatch(src.asset_count(), rough, levels)?;
    if full.assets != src.asset_count() {
        return Err(BoundError::Mismatch {
            assets: full.assets,
            levels: levels.len(),
            rough: rough.len(),
        });
    }
    let n = src.asset_count();
    let FullAnswers {
        pois,
        opts,
        table,
        irr,
        total,
        step_h,
        ref probes,
        ref weights,
        tags: ref full_tags,
        reference,
        ..
    } = *full;
    let opts = &opts;
    let max_irr = opts.max_irradiance_error;

    let mut levels: Vec<u8> = levels.iter().map(|&l| l.min(2)).collect();
    let mut promotions = Vec::new();
    let mut rounds = 0;
    let mut lod_assets = source::LodAssets::default();
    loop {
        rounds += 1;
        let scene = lod_assets.scene(src, rough, &levels)?;
        let lod_tags: Vec<Vec<Option<u32>>> = probes.iter().map(|p| tags(&scene, p)).collect();
        let mut figures = Vec::with_capacity(pois.len());
        // (poi, metric range, excess (rays, or weight), lod sees less sky, ray weights)
        let mut over: Vec<Over> = Vec::new();
        for (k, poi) in pois.iter().enumerate() {
            let ns = probes[k].svf_dirs.len();
            let (f, l) = (&full_tags[k], &lod_tags[k]);
            let (sf, sl) = (sky(&f[..ns]), sky(&l[..ns]));
            let svf_full = sf as f64 / total;
            let svf_lod = sl as f64 / total;
            let svf_error = rel(svf_lod, svf_full);
            let mut holds = true;
            if let Some(b) = opts.max_svf_error {
                if svf_error > b {
                    holds = false;
                    let excess = sf.abs_diff(sl) as f64 - b * sf as f64;
                    over.push((k, 0..ns, excess, sl < sf, None));
                }
            }
            let (mut sun_full, mut sun_lod, mut sun_err) = (None, None, None);
            let sun_end = ns + probes[k].sun_dirs.len();
            if table.is_some() {
                let (uf, ul) = (sky(&f[ns..sun_end]), sky(&l[ns..sun_end]));
                let e = rel(ul as f64, uf as f64);
                sun_full = Some(uf as f64 * step_h);
                sun_lod = Some(ul as f64 * step_h);
                sun_err = Some(e);
                if let Some(b) = opts.max_sun_error {
                    if e > b {
                        holds = false;
                        let excess = uf.abs_diff(ul) as f64 - b * uf as f64;
                        over.push((k, ns..sun_end, excess, ul < uf, None));
                    }
                }
            }
            let (mut irr_full, mut irr_lod, mut irr_err) = (None, None, None);
            if let (Some(w), Some(plane), Some(b)) = (irr, &probes[k].plane, max_irr) {
                let at = |t: &[Option<u32>]| {
                    let sky_free = |j: usize| t.get(j).is_some_and(Option::is_none);
                    let sun_free = |i: usize| t.get(sun_end + i).is_some_and(Option::is_none);
                    plane
                        .irradiance(&w.table, &w.opts, sky_free, sun_free)
                        .global_kwh_m2
                };
                let (gf, gl) = (at(f), at(l));
                let e = rel(gl, gf);
                (irr_full, irr_lod, irr_err) = (Some(gf), Some(gl), Some(e));
                if e > b {
                    holds = false;
                    let excess = 1000.0 * ((gf - gl).abs() - b * gf.abs());
                    over.push((k, 0..f.len(), excess, gl < gf, weights[k].as_deref()));
                }
            }
            figures.push(PoiBound {
                id: poi.id.clone(),
                svf_full,
                svf_lod,
                svf_error,
                sun_hours_full: sun_full,
                sun_hours_lod: sun_lod,
                sun_hours_error: sun_err,
                irradiance_full_kwh_m2: irr_full,
                irradiance_lod_kwh_m2: irr_lod,
                irradiance_error: irr_err,
                holds,
            });
        }
        if over.is_empty() || rounds > opts.max_rounds {
            return Ok(Bounded {
                met: over.is_empty(),
                levels,
                pois: figures,
                promotions,
                rounds,
                reference,
            });
        }
        let mut promoted_any = false;
        let mut promoted: Vec<bool> = vec![false; n];
        for (k, range, excess, lod_less, weights) in over {
            let start = range.start;
            let (f, l) = (&full_tags[k][range.clone()], &lod_tags[k][range]);
            // culprits: rays that move the metric in the direction of the error, with
            // their weight (1 per ray but for irradiance) and their rays
            let mut culprit: HashMap<u32, (f64, usize)> = HashMap::new();
            let mut other: HashMap<u32, (f64, usize)> = HashMap::new();
            let add = |m: &mut HashMap<u32, (f64, usize)>, t: u32, w: f64| {
                let e = m.entry(t).or_insert((0.0, 0));
                e.0 += w.abs();
                e.1 += 1;
            };
            for (j, (a, b)) in f.iter().zip(l).enumerate() {
                let w = weights.map_or(1.0, |w| w.get(start + j).copied().unwrap_or(0.0));
                if w == 0.0 {
                    continue;
                }
                // a free ray adds `w`: a ray free in the full model only takes it away
                match (a, b) {
                    (None, Some(t)) if lod_less == (w > 0.0) => add(&mut culprit, *t, w),
                    (Some(t), None) if lod_less == (w < 0.0) => add(&mut culprit, *t, w),
                    (x, y) if x != y => {
                        for t in [x, y].into_iter().flatten() {
                            add(&mut other, *t, w);
                        }
                    }
                    _ => {}
                }
            }
            let promotable = |t: &u32| levels.get(*t as usize).is_some_and(|&l| l < 2);
            let mut ranked: Vec<(u32, (f64, usize))> =
                culprit.into_iter().filter(|(t, _)| promotable(t)).collect();
            if ranked.is_empty() {
                ranked = other.into_iter().filter(|(t, _)| promotable(t)).collect();
            }
            ranked.sort_unstable_by(|a, b| b.1 .0.total_cmp(&a.1 .0).then(a.0.cmp(&b.0)));
            let mut covered = 0.0;
            for (t, (weight, rays)) in ranked {
                if covered >= excess && promoted_any {
                    break;
                }
                let i = t as usize;
                covered += weight;
                if promoted[i] {
                    continue;
                }
                promoted[i] = true;
                promoted_any = true;
                let from = levels[i];
                levels[i] = from + 1;
                promotions.push(Promotion {
                    round: rounds,
                    asset: i,
                    id: src.id(i).map(str::to_owned),
                    from,
                    to: from + 1,
                    poi: pois[k].id.clone(),
                    rays,
                });
            }
        }
        if !promoted_any {
            return Ok(Bounded {
                met: false,
                levels,
                pois: figures,
                promotions,
                rounds,
                reference,
            });
        }
    }
}

#[cfg(test)]
mod tests;
