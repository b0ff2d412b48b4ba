//! `subset`: keep the top-level city objects that match a box, ids and types (citygml-tools'
//! `subset`), streamed (see [`super`]).
//!
//! A member matches when every filter given holds: its feature's `gml:id` is one of
//! [`Subset::ids`]; its feature's type (local name: `Building`, `CityFurniture`, ...) is one of
//! [`Subset::types`]; its box (of its coordinates, x and y) intersects or lies within
//! [`Subset::bbox`] (citygml-tools' rules), or the centroid of its own vertices lies in the
//! half-open box (cjio's rule, [`BboxMode::Centroid`]); that centroid lies within
//! [`Subset::radius`] (cjio's `--radius`). A member without coordinates never matches a box
//! or a radius. The centroid is cjio's: the mean of every vertex the top-level object's own
//! geometry uses, each use counted (a ring's closing point once), without its children's. [`Subset::invert`]
//! keeps what does not match; [`Subset::limit`] keeps the first N kept, in document order.
//!
//! # Example
//! ```
//! use skylod::export::transform::{BboxMode, Subset};
//! let s = Subset { bbox: Some([0.0, 0.0, 10.0, 10.0]), mode: BboxMode::Within, ..Subset::default() };
//! assert!(s.bbox_matches(&[1.0, 1.0, 9.0, 9.0]) && !s.bbox_matches(&[5.0, 5.0, 11.0, 9.0]));
//! ```

use super::tree::Tree;
use super::{run, Context, Decision, EditSummary, Rule};
use crate::io::citygml::write::WriteOptions;
use crate::io::citygml::WriteError;
use crate::model::crs::{build_transform, Crs, PointTransform};
use glam::DVec3;
use std::path::Path;

/// How a member's box is tested against [`Subset::bbox`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum BboxMode {
    /// The boxes share a point.
    #[default]
    Intersects,
    /// The member's box lies inside.
    Within,
    /// The centroid of the member's own vertices lies in the half-open box
    /// `x0 <= x < x1`, `y0 <= y < y1` (cjio's `subset --bbox`).
    Centroid,
}

/// What [`subset`] keeps.
#[derive(Debug, Clone, Default)]
pub struct Subset {
    /// `[x0, y0, x1, y1]`, in the document's CRS or in [`Subset::bbox_crs`].
    pub bbox: Option<[f64; 4]>,
    /// How the box is tested.
    pub mode: BboxMode,
    /// The CRS of [`Subset::bbox`] (its axis order), when not the document's: the box's
    /// corners are converted into the document's CRS (the box of the four converted corners).
    pub bbox_crs: Option<Crs>,
    /// Top-level `gml:id`s to keep (none: any).
    pub ids: Vec<String>,
    /// Top-level feature types to keep, by local name (none: any).
    pub types: Vec<String>,
    /// Keep what does not match instead.
    pub invert: bool,
    /// Keep at most this many.
    pub limit: Option<usize>,
    /// `[x, y, r]`: keep the members whose centroid lies closer than `r` to `(x, y)` in the
    /// document's CRS (cjio's `subset --radius`).
    pub radius: Option<[f64; 3]>,
    /// Keep this many of the members that match, at random (cjio's `subset --random`): the
    /// ones whose key (gml:id, or `#n` for the n-th member without one) ranks lowest by a
    /// hash seeded with [`Subset::seed`], so a seed picks the same members every run and in
    /// every format. All of them when fewer match.
    pub random: Option<usize>,
    /// The seed of [`Subset::random`].
    pub seed: u64,
}

impl Subset {
    /// Whether the box `b` (`[x0, y0, x1, y1]` in the box's CRS) passes the box test.
    pub fn bbox_matches(&self, b: &[f64; 4]) -> bool {
        self.bbox.is_none_or(|q| box_test(self.mode, &q, b))
    }

    /// The box in the document's CRS `srs_name`.
    pub(crate) fn box_in(&self, srs_name: Option<&str>) -> Result<Option<[f64; 4]>, String> {
        let (Some(q), Some(from)) = (self.bbox, &self.bbox_crs) else {
            return Ok(self.bbox);
        };
        let Some(to) = srs_name.map(Crs::parse).filter(Crs::is_known) else {
            return Err(format!(
                "the box is given in {from}, but the document names no CRS to convert it into"
            ));
        };
        let t = build_transform();
        let mut out = [
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        ];
        for (x, y) in [(q[0], q[1]), (q[2], q[1]), (q[0], q[3]), (q[2], q[3])] {
            let p = t
                .position(from, &to, DVec3::new(x, y, 0.0))
                .map_err(|e| e.to_string())?;
            out = [
                out[0].min(p.x),
                out[1].min(p.y),
                out[2].max(p.x),
                out[3].max(p.y),
            ];
        }
        Ok(Some(out))
    }
}

fn box_test(mode: BboxMode, q: &[f64; 4], b: &[f64; 4]) -> bool {
    match mode {
        BboxMode::Intersects => b[0] <= q[2] && b[2] >= q[0] && b[1] <= q[3] && b[3] >= q[1],
        BboxMode::Within => b[0] >= q[0] && b[2] <= q[2] && b[1] >= q[1] && b[3] <= q[3],
        // a centroid as a point box: cjio's half-open test
        BboxMode::Centroid => b[0] >= q[0] && b[1] >= q[1] && b[0] < q[2] && b[1] < q[3],
    }
}

/// How [`Subset::random`] takes part in a pass.
#[derive(Clone, Copy)]
pub(crate) enum Sample<'a> {
    /// No sampling.
    All,
    /// The survey before the edit: every match's key is listed, nothing is kept.
    Survey(&'a std::cell::RefCell<Vec<String>>),
    /// The edit: only the drawn keys stay.
    Drawn(&'a foldhash::HashSet<String>),
}

/// A [`Subset`] applied to one document's members in order, whatever the format (the CityGML
/// rule here and the CityJSON one of [`crate::export::transform::cityjson`]): the box in the
/// document's CRS, once known, and how many members were seen and kept.
pub(crate) struct Matcher<'a> {
    s: &'a Subset,
    /// The box in the document's CRS, once known.
    bbox: Option<Option<[f64; 4]>>,
    sample: Sample<'a>,
    seen: usize,
    kept: usize,
}

impl<'a> Matcher<'a> {
    pub(crate) fn new(s: &'a Subset, sample: Sample<'a>) -> Self {
        Matcher {
            s,
            bbox: None,
            sample,
            seen: 0,
            kept: 0,
        }
    }

    /// The box of [`Subset::bbox`] in the document's CRS `srs_name` (converted once).
    pub(crate) fn bbox(&mut self, srs_name: Option<&str>) -> Result<Option<[f64; 4]>, String> {
        match self.bbox {
            Some(q) => Ok(q),
            None => Ok(*self.bbox.insert(self.s.box_in(srs_name)?)),
        }
    }

    /// Whether the next member stays (and count it if so): its feature's `id` and `ty`pe,
    /// `bbox` the box of its coordinates and `centroid` the mean of its own vertices (each
    /// asked only when a test needs it), `q` the box from [`Matcher::bbox`].
    pub(crate) fn keep(
        &mut self,
        q: Option<[f64; 4]>,
        id: Option<&str>,
        ty: Option<&str>,
        bbox: impl FnOnce() -> crate::model::Bbox,
        centroid: impl FnOnce() -> Option<DVec3>,
    ) -> bool {
        let s = self.s;
        let id_ok = s.ids.is_empty() || id.is_some_and(|id| s.ids.iter().any(|i| i == id));
        let type_ok = s.types.is_empty() || ty.is_some_and(|t| s.types.iter().any(|x| x == t));
        let needs_centroid = s.radius.is_some() || (q.is_some() && s.mode == BboxMode::Centroid);
        let c = if needs_centroid { centroid() } else { None };
        let box_ok = q.is_none_or(|q| match s.mode {
            BboxMode::Centroid => c.is_some_and(|c| box_test(s.mode, &q, &[c.x, c.y, c.x, c.y])),
            _ => {
                let b = bbox();
                !b.is_empty() && box_test(s.mode, &q, &[b.min.x, b.min.y, b.max.x, b.max.y])
            }
        });
        let radius_ok = s.radius.is_none_or(|[x, y, r]| {
            c.is_some_and(|c| (c.x - x).powi(2) + (c.y - y).powi(2) < r * r)
        });
        let matches = (id_ok && type_ok && box_ok && radius_ok) != s.invert;
        self.seen += 1;
        let key = || id.map_or_else(|| format!("#{}", self.seen), str::to_string);
        match self.sample {
            Sample::All => {}
            Sample::Survey(keys) => {
                if matches {
                    keys.borrow_mut().push(key());
                }
                return false;
            }
            Sample::Drawn(drawn) => {
                if !matches || !drawn.contains(&key()) {
                    return false;
                }
            }
        }
        if !matches || s.limit.is_some_and(|l| self.kept >= l) {
            return false;
        }
        self.kept += 1;
        true
    }
}

struct SubsetRule<'a>(Matcher<'a>);

impl Rule for SubsetRule<'_> {
    fn member(
        &mut self,
        tree: &Tree,
        ctx: &Context<'_>,
        _counts: &mut EditSummary,
    ) -> Result<Decision, String> {
        let q = self.0.bbox(ctx.srs_name)?;
        let boxed = || {
            let mut b = crate::model::Bbox::EMPTY;
            for n in &tree.nodes {
                if !n.bbox.is_empty() {
                    b.add(n.bbox.min);
                    b.add(n.bbox.max);
                }
            }
            b
        };
        let centroid = || tree.own_centroid();
        let (id, ty) = (tree.feature_id.as_deref(), tree.feature_type());
        Ok(if self.0.keep(q, id, ty, boxed, centroid) {
            Decision::Keep(Vec::new())
        } else {
            Decision::Drop
        })
    }
}

/// Write the members of the document at `input` that `rule` keeps to `out` (atomically;
/// `-` for standard output; gzip for a name ending in `.gz`), streamed (see `super`).
///
/// # Errors
/// A refused target, a source that cannot be read or is not CityGML, a box that cannot be
/// converted into the document's CRS, I/O errors.
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

/// A subset in either format, `edit(sample, out)` running the format's edit: with
/// [`Subset::random`], first a survey (no output) that lists the candidates, then the edit
/// of the drawn ones into `out`; else the edit alone.
pub(crate) fn with_draw<E>(
    rule: &Subset,
    out: &Path,
    edit: impl Fn(Sample<'_>, Option<&Path>) -> Result<EditSummary, E>,
) -> Result<EditSummary, E> {
    let drawn = drawn(rule, |sample| edit(sample, None))?;
    edit(drawn.as_ref().map_or(Sample::All, Sample::Drawn), Some(out))
}

/// The keys [`Subset::random`] draws, `None` without it: `survey` runs the rule over the
/// document with the [`Sample`] it is given, which lists the keys of the members that match;
/// the `n` with the lowest rank under the seed are drawn.
fn drawn<E>(
    rule: &Subset,
    survey: impl FnOnce(Sample<'_>) -> Result<EditSummary, E>,
) -> Result<Option<foldhash::HashSet<String>>, E> {
    let Some(n) = rule.random else {
        return Ok(None);
    };
    let keys = std::cell::RefCell::new(Vec::new());
    survey(Sample::Survey(&keys))?;
    let mut ranked: Vec<(u64, String)> = keys
        .take()
        .into_iter()
        .map(|k| (rank(rule.seed, &k), k))
        .collect();
    ranked.sort_unstable();
    Ok(Some(ranked.into_iter().take(n).map(|(_, k)| k).collect()))
}

/// A key's place in the draw of `seed`: FNV-1a of the key, mixed with the seed by
/// SplitMix64's finaliser (fixed here, so a seed draws the same members in every version).
fn rank(seed: u64, key: &str) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in key.bytes() {
        h = (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3);
    }
    let mut z = h ^ seed.wrapping_mul(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}
