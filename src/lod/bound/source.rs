//! Where the error bound takes the full model's geometry from ([`FullSource`]): the whole
//! model in memory ([`CityModel`]), or a document read hollow ([`crate::lod::hollow`]) whose
//! assets the bound needs are read back from the document by byte span ([`HollowSource`]:
//! the reference's assets near the rays, round by round, and the LoD scene's assets above
//! level 0).
//!
//! The scenes are the same either way, so are the answers, to the bit: a scene is built from
//! the same assets with the same triangles in the same order ([`full_scene_of`],
//! [`mixed_scene_of`]), and the reference's frame is the whole model's full-detail frame,
//! which the hollow read computes exactly chunk by chunk ([`Hollow::frame`]); an asset read
//! back is the whole read's ([`Hollow::read_back`]).

use super::BoundError;
use crate::io::citygml::read::Reread;
use crate::lod::hollow::Hollow;
use crate::lod::rough::RoughGeometry;
use crate::lod::scene::{detail_boxes, full_scene_of, mixed_scene_of};
use crate::model::{Asset, Bbox, CityModel};
use crate::solar::trace::TraceScene;
use std::borrow::Cow;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Mutex, PoisonError};

/// The full model the bound compares with: its boxes, counts and ids, and the full geometry
/// of the assets asked for.
pub trait FullSource: Sync {
    /// Assets of the model.
    fn asset_count(&self) -> usize;
    /// [`detail_boxes`] of the model.
    fn detail_boxes(&self) -> (Vec<Bbox>, Bbox);
    /// Full-detail polygons of the model ([`Asset::detail_polygons`]), and the assets that
    /// have some.
    fn detail_polygons(&self) -> (usize, usize);
    /// The gml:id of asset `i`.
    fn id(&self, i: usize) -> Option<&str>;
    /// The assets `which` (increasing indices) with their full geometry.
    ///
    /// # Errors
    /// [`BoundError::ReadBack`] when they cannot be read back.
    fn assets(&self, which: &[usize]) -> Result<Vec<Cow<'_, Asset>>, BoundError>;

    /// The assets a later call of [`FullSource::assets`] may ask for (`later[i]`), so that a
    /// source that reads assets back keeps those it reads on the way rather than read them
    /// again; `None`: no more, what is kept is given back. What [`FullSource::assets`] gives
    /// does not change.
    fn expect(&self, later: Option<&[bool]>) {
        let _ = later;
    }

    /// Each asset's twin, where known: an asset (of an index at most its own) whose
    /// full-detail triangles are its own (`Hollow::twin`), which the reference traces in
    /// its stead. `None`: every asset is its own.
    fn twins(&self) -> Option<&[u32]> {
        None
    }
}

impl FullSource for CityModel {
    fn asset_count(&self) -> usize {
        self.assets.len()
    }

    fn detail_boxes(&self) -> (Vec<Bbox>, Bbox) {
        detail_boxes(self)
    }

    fn detail_polygons(&self) -> (usize, usize) {
        let each = self.assets.iter().map(|a| a.detail_polygons().len());
        each.fold((0, 0), |(n, k), c| (n + c, k + usize::from(c > 0)))
    }

    fn id(&self, i: usize) -> Option<&str> {
        self.assets.get(i)?.id.as_deref()
    }

    fn assets(&self, which: &[usize]) -> Result<Vec<Cow<'_, Asset>>, BoundError> {
        let all = which.iter().filter_map(|&i| self.assets.get(i));
        Ok(all.map(Cow::Borrowed).collect())
    }
}

/// A document read hollow, its assets read back by span from `reread` (the same document).
///
/// A top-level member parsed for the assets asked for holds others (a building's other
/// surfaces): those the caller may ask for later ([`FullSource::expect`]) are kept from
/// the parse and given from memory when asked for, so that no member is parsed again for
/// them.
#[derive(Debug)]
pub struct HollowSource<'a> {
    hollow: &'a Hollow,
    reread: &'a Reread,
    read_back: AtomicUsize,
    from_kept: AtomicUsize,
    kept: Mutex<Kept>,
}

/// What a [`HollowSource`] keeps of its parses.
#[derive(Debug, Default)]
struct Kept {
    /// The assets that may be asked for later ([`FullSource::expect`]).
    later: Vec<bool>,
    /// Assets read back on the way, not asked for yet.
    assets: foldhash::HashMap<usize, Asset>,
}

impl<'a> HollowSource<'a> {
    /// The full model of `hollow`, read back from `reread`.
    pub fn new(hollow: &'a Hollow, reread: &'a Reread) -> Self {
        HollowSource {
            hollow,
            reread,
            read_back: AtomicUsize::new(0),
            from_kept: AtomicUsize::new(0),
            kept: Mutex::default(),
        }
    }

    /// Assets read back so far (an asset asked for twice counts twice; one kept from an
    /// earlier parse counts when asked for).
    pub fn read_back(&self) -> usize {
        self.read_back.load(Ordering::Relaxed)
    }

    /// Of [`HollowSource::read_back`], the assets given from what an earlier parse kept.
    pub fn from_kept(&self) -> usize {
        self.from_kept.load(Ordering::Relaxed)
    }
}

impl FullSource for HollowSource<'_> {
    fn asset_count(&self) -> usize {
        self.hollow.model.assets.len()
    }

    fn detail_boxes(&self) -> (Vec<Bbox>, Bbox) {
        (self.hollow.detail.clone(), self.hollow.frame)
    }

    fn detail_polygons(&self) -> (usize, usize) {
        let h = self.hollow;
        let each = (h.model.assets.iter().enumerate()).map(|(i, a)| {
            let k = a.detail_geometry();
            k.and_then(|k| h.polygon_counts(i).get(k))
                .map_or(0, |&n| n as usize)
        });
        each.fold((0, 0), |(n, k), c| (n + c, k + usize::from(c > 0)))
    }

    fn id(&self, i: usize) -> Option<&str> {
        self.hollow.model.assets.get(i)?.id.as_deref()
    }

    fn assets(&self, which: &[usize]) -> Result<Vec<Cow<'_, Asset>>, BoundError> {
        self.read_back.fetch_add(which.len(), Ordering::Relaxed);
        let mut kept = self.kept.lock().unwrap_or_else(PoisonError::into_inner);
        let mut out: Vec<Option<Asset>> = which.iter().map(|i| kept.assets.remove(i)).collect();
        let rest: Vec<usize> = (which.iter().zip(&out))
            .filter(|(_, a)| a.is_none())
            .map(|(&i, _)| i)
            .collect();
        (self.from_kept).fetch_add(which.len() - rest.len(), Ordering::Relaxed);
        if rest.is_empty() {
            return Ok(out.into_iter().flatten().map(Cow::Owned).collect());
        }
        let mut asked: Vec<usize> = which.to_vec();
        asked.sort_unstable();
        let also: Vec<usize> = (kept.later.iter().enumerate())
            .filter(|&(i, &l)| {
                l && !kept.assets.contains_key(&i) && asked.binary_search(&i).is_err()
            })
            .map(|(i, _)| i)
            .collect();
        let back = self.hollow.read_back_keeping(self.reread, &rest, &also);
        let (back, more) = back.ok_or_else(|| BoundError::ReadBack {
            path: self.reread.path().to_path_buf(),
            assets: rest.len(),
        })?;
        kept.assets.extend(more);
        let mut back = back.into_iter();
        for slot in out.iter_mut().filter(|a| a.is_none()) {
            *slot = back.next();
        }
        let all: Option<Vec<Asset>> = out.into_iter().collect();
        let all = all.ok_or_else(|| BoundError::ReadBack {
            path: self.reread.path().to_path_buf(),
            assets: which.len(),
        })?;
        Ok(all.into_iter().map(Cow::Owned).collect())
    }

    fn twins(&self) -> Option<&[u32]> {
        let t = &self.hollow.twin;
        (t.len() == self.hollow.model.assets.len()).then_some(t.as_slice())
    }

    fn expect(&self, later: Option<&[bool]>) {
        let mut kept = self.kept.lock().unwrap_or_else(PoisonError::into_inner);
        match later {
            Some(later) => {
                kept.later.clear();
                kept.later.extend_from_slice(later);
                // what is no longer expected is given back
                let Kept { later, assets } = &mut *kept;
                assets.retain(|&i, _| later.get(i).copied().unwrap_or(false));
            }
            None => *kept = Kept::default(),
        }
    }
}

/// The twins ([`FullSource::twins`]) of the assets `i` with `of[i]`, as flags of the same
/// length: what a scene of those assets is built of.
pub(super) fn as_twins(src: &dyn FullSource, of: &[bool]) -> Vec<bool> {
    let twins = src.twins();
    let twin = |a: usize| twins.and_then(|t| t.get(a)).map_or(a, |&c| c as usize);
    let mut out = vec![false; of.len()];
    for a in (0..of.len()).filter(|&a| of[a]) {
        if let Some(x) = out.get_mut(twin(a)) {
            *x = true;
        }
    }
    out
}

/// The part of the full scene made of the assets `i` with `include[i]`, in `frame` for about
/// `rays` rays ([`crate::lod::scene::full_scene_of`] with a frame); the whole full scene
/// ([`crate::lod::scene::full_scene`]) with `frame` `None`.
pub(super) fn full_part(
    src: &dyn FullSource,
    include: Option<&[bool]>,
    frame: Option<(Bbox, usize)>,
) -> Result<TraceScene, BoundError> {
    let n = src.asset_count();
    let which: Vec<usize> = match include {
        Some(inc) => (0..n)
            .filter(|&i| inc.get(i).copied().unwrap_or(false))
            .collect(),
        None => (0..n).collect(),
    };
    let assets = src.assets(&which)?;
    let tagged: Vec<(usize, &Asset)> = which.into_iter().zip(assets.iter().map(|a| &**a)).collect();
    Ok(full_scene_of(&tagged, frame))
}

/// The assets of the LoD scene ([`crate::lod::scene::mixed_scene`]) read so far, kept from
/// round to round of the bound (levels only rise).
#[derive(Default)]
pub(super) struct LodAssets<'s> {
    kept: foldhash::HashMap<usize, Cow<'s, Asset>>,
}

impl<'s> LodAssets<'s> {
    /// The LoD scene of `levels`: its assets above level 0 not read yet read from `src`.
    pub(super) fn scene(
        &mut self,
        src: &'s dyn FullSource,
        rough: &[RoughGeometry],
        levels: &[u8],
    ) -> Result<TraceScene, BoundError> {
        let above: Vec<usize> = (0..src.asset_count())
            .filter(|&i| levels.get(i).is_some_and(|&l| l > 0))
            .collect();
        let new: Vec<usize> = (above.iter().copied())
            .filter(|i| !self.kept.contains_key(i))
            .collect();
        let read = src.assets(&new)?;
        self.kept.extend(new.into_iter().zip(read));
        let tagged: Vec<(usize, &Asset)> = (above.iter())
            .filter_map(|i| Some((*i, &**self.kept.get(i)?)))
            .collect();
        Ok(mixed_scene_of(&tagged, rough, levels))
    }
}
