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
//! rounding, [`crate::trace::BoxIndex`]). First the nearest box of every ray is built; then, round
//! after round, each pending ray is traced in the part built so far, and if a box it
//! crosses before its hit (any box, when it hits nothing; the `4^round` nearest until
//! round 4) is not built yet, those assets are added and the ray waits for the next round;
//! otherwise its answer is final. The part is built in the frame of the whole model
//! ([`crate::trace::SceneBuilder::with_frame`]: same origin, same f32 triangles, same node
//! growth) with its triangles in the whole model's order, so the f32 distances are those of
//! the whole model and ties go to the same triangle; and since every triangle a ray may hit
//! at or before its answer lies in a box the ray enters before that answer (with a slack of
//! 2e-3 relative plus the margin), no left-out triangle can win: every answer is the
//! whole model's, asset and distance to the bit
//! (`restricted_full_scene_answers_as_the_whole_model` checks it ray by ray). A part's
//! answer is never nearer than the whole model's, so the limits only shrink and each round
//! ends rays or adds assets. When the rays outnumber the model's full-detail polygons (many
//! POIs on a small model), the rounds would cost more than the BVH they avoid, and the whole
//! model is built at once, as before ([`Reference::whole`]). Measured (BENCHMARKS.md, "The
//! default error bound"): on the paper district, 6 POIs reach 2,951 of 57,530 assets.
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
//! use skylod::lod::bound::{bound, BoundOptions};
//! use skylod::lod::{lod, LodOptions};
//! use skylod::poi::Poi;
//! use skylod::synth::{generate, pois, Preset};
//! let opts = Preset::Small.defaults();
//! let mut xml = Vec::new();
//! generate(&opts, &mut xml).unwrap();
//! let model = skylod::citygml::read::read_bytes(&xml, "small.gml").unwrap();
//! let pois: Vec<Poi> = pois(&opts).into_iter().map(Into::into).collect();
//! let r = lod(&model, &pois, &LodOptions::default()).unwrap();
//! let b = BoundOptions { max_svf_error: Some(0.001), ..Default::default() };
//! let out = bound(&model, &r.rough, &r.selection.levels, &pois, &b, None).unwrap();
//! assert!(out.met);
//! for p in &out.pois {
//!     assert!(p.svf_error <= 0.001, "{}: {}", p.id, p.svf_error);
//! }
//! // levels only rise
//! assert!(out.levels.iter().zip(&r.selection.levels).all(|(a, b)| a >= b));
//! ```

use crate::lod::rough::RoughGeometry;
use crate::lod::scene::{detail_boxes, full_scene, full_scene_part, mixed_scene};
use crate::model::CityModel;
use crate::poi::{Poi, POI_OFFSET};
use crate::solar::irradiance::{IrradianceSetting, PlaneRays};
use crate::solar::sky::{Frame, SkyError};
use crate::solar::{SkyBundles, SunTable};
use crate::trace::{BoxIndex, Scene};
use foldhash::{HashMap, HashMapExt};
use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;

pub use super::bound_report::{BoundReport, PoiBound, Promotion};

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
    /// not bounded; needs a weather year, [`bound_with`]).
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
    #[error("an irradiance error bound needs a weather year (--weather)")]
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

/// Relative error of `a` against `b` (0 when both are 0, infinite when only `b` is).
fn rel(a: f64, b: f64) -> f64 {
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
        .for_poi(poi)
        .projected_dirs()
        .iter()
        .map(|&l| frame.to_world(l))
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
fn full_tags(model: &CityModel, probes: &[Probe]) -> (Vec<Vec<Option<u32>>>, Reference) {
    let rays: usize = probes.iter().map(Probe::len).sum();
    let polygons: usize = model.assets.iter().map(|a| a.detail_polygons().len()).sum();
    if rays > polygons {
        // many rays, a small model: the lazy rounds would cost more than the whole BVH
        let whole = full_scene(model);
        let of = model
            .assets
            .iter()
            .filter(|a| !a.detail_polygons().is_empty())
            .count();
        let reference = Reference {
            assets: of,
            of,
            rounds: 1,
            whole: true,
        };
        return (probes.iter().map(|p| tags(&whole, p)).collect(), reference);
    }
    let (hits, reference) = lazy_hits(model, probes);
    let tags = hits
        .into_iter()
        .map(|v| v.into_iter().map(|h| h.map(|h| h.0)).collect())
        .collect();
    (tags, reference)
}

/// [`full_tags`] through the lazy rounds (see the module docs, "Reference"), with the
/// distance of each hit.
#[allow(clippy::type_complexity)]
fn lazy_hits(model: &CityModel, probes: &[Probe]) -> (Vec<Vec<Option<(u32, f64)>>>, Reference) {
    let mut out: Vec<Vec<Option<(u32, f64)>>> =
        probes.iter().map(|p| vec![None; p.len()]).collect();
    let (boxes, frame) = detail_boxes(model);
    let mut reference = Reference {
        of: boxes.iter().filter(|b| !b.is_empty()).count(),
        ..Default::default()
    };
    if frame.is_empty() {
        return (out, reference);
    }
    // Far above the f32 rounding of the scene (its node growth): a triangle's hit point
    // lies inside its asset's grown box.
    let far = (frame.max - frame.center()).abs().max_element().max(1.0);
    let margin = far / 32768.0 + 1e-3;
    let index = BoxIndex::new(boxes, margin);
    let mut include = vec![false; model.assets.len()];
    let mut pending: Vec<Pending> = probes
        .iter()
        .enumerate()
        .flat_map(|(k, p)| (0..p.len()).map(move |j| (k, j, None)))
        .collect();
    // seed: the nearest box of every ray
    let seed: Vec<u32> = pending
        .par_iter()
        .with_min_len(512)
        .map(|&(k, j, _)| {
            index
                .nearest(probes[k].origin, probes[k].dir(j))
                .unwrap_or(u32::MAX)
        })
        .collect();
    for a in seed {
        if let Some(x) = include.get_mut(a as usize) {
            *x = true;
        }
    }
    loop {
        reference.rounds += 1;
        let scene = full_scene_part(model, &include, frame, pending.len());
        let cap = if reference.rounds as u32 >= UNCAPPED_ROUND {
            usize::MAX
        } else {
            1 << (2 * reference.rounds)
        };
        let include_ref = &include;
        let results: Vec<(Pending, Option<(u32, f64)>, Vec<u32>)> = pending
            .into_par_iter()
            .with_min_len(256)
            .map_init(Vec::new, |v, (k, j, mut all)| {
                let (o, d) = (probes[k].origin, probes[k].dir(j));
                let h = scene.first_hit(o, d, POI_OFFSET, f64::INFINITY);
                // every asset a triangle of which the ray may hit as close as `h`
                let limit = h.map_or(f64::INFINITY, |h| h.t + 2e-3 * (1.0 + h.t.abs()) + margin);
                let missing_of = |it: &mut dyn Iterator<Item = u32>| -> Vec<u32> {
                    it.filter(|&a| !include_ref.get(a as usize).copied().unwrap_or(true))
                        .take(if h.is_some() { usize::MAX } else { cap })
                        .collect()
                };
                let missing = match &all {
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
                            all = Some(
                                v.iter()
                                    .map(|&(t, i)| ((t * (1.0 - 1e-6) - 1e-3) as f32, i))
                                    .collect(),
                            );
                        }
                        missing_of(&mut v.iter().map(|x| x.1))
                    }
                };
                ((k, j, all), h.map(|h| (h.tag, h.t)), missing)
            })
            .collect();
        drop(scene);
        let mut next = Vec::new();
        for (p, hit, missing) in results {
            if missing.is_empty() {
                out[p.0][p.1] = hit;
            } else {
                next.push(p);
                for a in missing {
                    include[a as usize] = true;
                }
            }
        }
        if next.is_empty() {
            reference.assets = include.iter().filter(|&&x| x).count();
            return (out, reference);
        }
        pending = next;
    }
}

/// A ray of the reference trace still open: probe, ray, and every box it crosses (entry
/// rounded down, nearest first) once it was seen to hit nothing.
type Pending = (usize, usize, Option<Vec<(f32, u32)>>);

/// First-hit tags of every ray of a probe (SVF rays, sun rays, irradiance sun rays).
fn tags(scene: &Scene, p: &Probe) -> Vec<Option<u32>> {
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
    let n = model.assets.len();
    if levels.len() != n || rough.len() != n {
        return Err(BoundError::Mismatch {
            assets: n,
            levels: levels.len(),
            rough: rough.len(),
        });
    }
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
    let probes: Vec<Probe> = (pois.iter())
        .map(|p| probe(p, &bundles, table, irr))
        .collect();
    // per POI, what each of its rays brings to the irradiation (all rays, 0 but for the
    // SVF and irradiance ones)
    let weights: Vec<Option<Vec<f64>>> = (probes.iter())
        .map(|p| Some(irradiance_weights(p, irr?)))
        .collect();
    let (full_tags, reference) = full_tags(model, &probes);

    let mut levels: Vec<u8> = levels.iter().map(|&l| l.min(2)).collect();
    let mut promotions = Vec::new();
    let mut rounds = 0;
    loop {
        rounds += 1;
        let scene = mixed_scene(model, rough, &levels);
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
                    id: model.assets[i].id.as_deref().map(str::to_owned),
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
mod tests {
    use super::*;
    use crate::lod::scene::full_scene;
    use crate::model::{Asset, AssetKind, LodGeometry, Polygon};
    use crate::solar::poi_sky_view;

    fn quad(x0: f64, x1: f64, y0: f64, y1: f64, z: f64) -> Polygon {
        Polygon::new(vec![
            DVec3::new(x0, y0, z),
            DVec3::new(x1, y0, z),
            DVec3::new(x1, y1, z),
            DVec3::new(x0, y1, z),
        ])
    }

    fn asset(kind: AssetKind, polys: Vec<Polygon>) -> Asset {
        Asset::new(
            kind,
            Some(&format!("{}", polys.len())),
            "X",
            vec![LodGeometry {
                lod: 3,
                property: "lod3MultiSurface".into(),
                polygons: polys,
                ..Default::default()
            }],
        )
    }

    /// An L-shaped canopy over the POI whose rough geometry is its full square (a rough
    /// model too big), and a small roof far off that the selection dropped.
    fn scene() -> (CityModel, Vec<RoughGeometry>, Vec<u8>) {
        let mut m = CityModel::default();
        m.assets.push(asset(
            AssetKind::Roof,
            vec![
                quad(-5.0, 5.0, -5.0, 0.0, 4.0),
                quad(-5.0, 0.0, 0.0, 5.0, 4.0),
            ],
        ));
        m.assets.push(asset(
            AssetKind::Roof,
            vec![quad(20.0, 30.0, -5.0, 5.0, 3.0)],
        ));
        let rough = vec![
            RoughGeometry {
                polygons: vec![quad(-5.0, 5.0, -5.0, 5.0, 4.0)],
                obb: None,
                lod: 3,
            },
            RoughGeometry {
                polygons: vec![quad(20.0, 30.0, -5.0, 5.0, 3.0)],
                obb: None,
                lod: 3,
            },
        ];
        (m, rough, vec![1, 0])
    }

    fn poi() -> Poi {
        Poi {
            id: "p".into(),
            position: DVec3::ZERO,
            normal: None,
        }
    }

    #[test]
    fn figures_equal_poi_sky_view() {
        let (m, rough, levels) = scene();
        let opts = BoundOptions {
            max_svf_error: Some(10.0),
            svf_rays: 4000,
            ..Default::default()
        };
        let b = bound(&m, &rough, &levels, &[poi()], &opts, None).unwrap();
        assert!(b.met && b.promotions.is_empty() && b.rounds == 1);
        // 3 polygons, thousands of rays: the whole model at once
        assert!(
            b.reference.whole && b.reference.assets == 2,
            "{:?}",
            b.reference
        );
        let bundles = SkyBundles::new(4000, 7).unwrap();
        let full = poi_sky_view(&full_scene(&m), &poi(), &bundles).svf;
        let lod = poi_sky_view(&mixed_scene(&m, &rough, &levels), &poi(), &bundles).svf;
        assert_eq!(b.pois[0].svf_full, full);
        assert_eq!(b.pois[0].svf_lod, lod);
        assert!(lod < full);
    }

    #[test]
    fn promotes_the_too_big_rough_asset_and_not_the_far_one() {
        let (m, rough, levels) = scene();
        let opts = BoundOptions {
            max_svf_error: Some(0.01),
            svf_rays: 4000,
            ..Default::default()
        };
        let b = bound(&m, &rough, &levels, &[poi()], &opts, None).unwrap();
        assert!(b.met);
        assert_eq!(b.levels, vec![2, 0]);
        assert_eq!(b.promotions.len(), 1);
        assert_eq!((b.promotions[0].asset, b.promotions[0].from), (0, 1));
        // what is left is the far roof, within the bound
        assert!(b.pois[0].svf_error > 0.0 && b.pois[0].svf_error <= 0.01);
    }

    #[test]
    fn a_dropped_asset_that_is_seen_comes_back() {
        let (m, rough, _) = scene();
        // everything dropped: the LoD model sees the whole sky
        let opts = BoundOptions {
            max_svf_error: Some(0.0),
            svf_rays: 4000,
            ..Default::default()
        };
        let b = bound(&m, &rough, &[0, 0], &[poi()], &opts, None).unwrap();
        assert!(b.met, "{:?}", b.pois);
        assert_eq!(b.levels[0], 2);
        assert!(b.promotions.iter().any(|p| p.from == 0));
    }

    #[test]
    fn unmet_bound_names_the_poi_and_bad_input_is_an_error() {
        let (m, rough, levels) = scene();
        let opts = BoundOptions {
            max_svf_error: Some(0.0),
            svf_rays: 2000,
            max_rounds: 0,
            ..Default::default()
        };
        let b = bound(&m, &rough, &levels, &[poi()], &opts, None).unwrap();
        assert!(!b.met);
        assert_eq!(b.failing(), vec!["p"]);
        let bad = BoundOptions {
            max_svf_error: Some(f64::NAN),
            ..Default::default()
        };
        assert!(bound(&m, &rough, &levels, &[poi()], &bad, None).is_err());
        let sun = BoundOptions {
            max_sun_error: Some(0.01),
            ..Default::default()
        };
        assert!(matches!(
            bound(&m, &rough, &levels, &[poi()], &sun, None),
            Err(BoundError::NoSunTable)
        ));
        assert!(bound(&m, &rough, &[1], &[poi()], &opts, None).is_err());
    }

    #[test]
    fn sun_hours_bound() {
        let (m, rough, levels) = scene();
        let site = crate::solar::Site::new(41.39, 2.17);
        let table = SunTable::year(2025, 60, &site).unwrap();
        let opts = BoundOptions {
            max_sun_error: Some(0.0),
            svf_rays: 1000,
            ..Default::default()
        };
        let b = bound(&m, &rough, &levels, &[poi()], &opts, Some(&table)).unwrap();
        assert!(b.met);
        let p = &b.pois[0];
        assert_eq!(p.sun_hours_error, Some(0.0));
        assert!(p.sun_hours_full.unwrap() > 0.0);
    }

    /// The lazy reference trace gives every ray the answer of the whole-model scene (same
    /// asset, same distance to the bit) on a synth district with low sun rays, while it
    /// builds only part of the model.
    #[test]
    fn restricted_full_scene_answers_as_the_whole_model() {
        use crate::synth::{generate, pois, Preset};
        let mut opts = Preset::Paper.defaults();
        (opts.blocks_x, opts.blocks_y) = (3, 2);
        let mut xml = Vec::new();
        generate(&opts, &mut xml).unwrap();
        let model = crate::citygml::read::read_bytes(&xml, "paper.gml").unwrap();
        let mut ps: Vec<Poi> = pois(&opts).into_iter().map(Into::into).collect();
        // and a POI on the ground in the open, facing up
        ps.push(Poi {
            id: "open".into(),
            position: ps[0].position + DVec3::new(3.0, -2.0, 0.0),
            normal: None,
        });
        assert!(ps.len() >= 3);
        let site = crate::solar::Site::new(48.76, 11.42);
        let table = SunTable::year(2025, 30, &site).unwrap();
        let bundles = SkyBundles::new(3000, 7).unwrap();
        let probes: Vec<Probe> = ps
            .iter()
            .map(|p| probe(p, &bundles, Some(&table), None))
            .collect();
        let (hits, reference) = lazy_hits(&model, &probes);
        let whole = full_scene(&model);
        let (mut compared, mut hit) = (0, 0);
        for (p, got) in probes.iter().zip(&hits) {
            assert_eq!(got.len(), p.len());
            for (j, g) in got.iter().enumerate() {
                let want = whole
                    .first_hit(p.origin, p.dir(j), POI_OFFSET, f64::INFINITY)
                    .map(|h| (h.tag, h.t));
                match (g, want) {
                    (Some((a, t)), Some((b, u))) => {
                        assert_eq!((*a, t.to_bits()), (b, u.to_bits()), "ray {j}");
                        hit += 1;
                    }
                    (a, b) => assert_eq!(a.map(|x| x.0), b.map(|x| x.0), "ray {j}"),
                }
                compared += 1;
            }
        }
        assert!(hit > 100 && hit < compared, "{hit} of {compared} rays hit");
        assert!(
            reference.assets > 0 && reference.assets < reference.of,
            "{reference:?}"
        );
        assert!(reference.rounds >= 2 && !reference.whole, "{reference:?}");
        // `bound` uses these tags, or (more rays than polygons here) the whole model's
        let (tags, r) = full_tags(&model, &probes);
        assert!(r.whole, "{r:?}");
        for (p, (t, h)) in probes.iter().zip(tags.iter().zip(&hits)) {
            assert_eq!(t, &tags_of(&whole, p));
            assert_eq!(t, &h.iter().map(|h| h.map(|h| h.0)).collect::<Vec<_>>());
        }
    }

    fn tags_of(scene: &Scene, p: &Probe) -> Vec<Option<u32>> {
        tags(scene, p)
    }
}
