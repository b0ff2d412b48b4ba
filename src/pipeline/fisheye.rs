//! Step 5, pictured: the fisheye picture of each POI.

use super::session::Error;
use super::Framed;
use crate::lod::poi::checks::{self, PoiFlag};
use crate::lod::rough::rough_model;
use crate::lod::scene::{full_scene, selection_scene};
use crate::lod::select::select;
use crate::lod::LodOptions;
use crate::model::runtime::progress::{check, Progress, Stage};
use crate::model::CityModel;
use crate::model::POI_OFFSET;
use crate::solar::fisheye::{classify_cells, CellClass};
use crate::solar::sky::SkyPartition;
use crate::solar::{poi_sky_view, SkyBundles, SkyView};

/// Options of `sky_pictures`.
#[derive(Debug, Clone, Copy)]
pub struct SkyPictureOptions<'o> {
    /// The cells of the picture (one ray through each centre).
    pub partition: &'o SkyPartition,
    /// The bundles of the SVF and sky exposure printed with the picture.
    pub bundles: &'o SkyBundles,
    /// When given, each POI's levels as `skylod lod` selects them for that POI alone.
    pub levels: Option<LodOptions>,
}

/// What a fisheye picture of one POI shows (`sky_pictures`).
#[derive(Debug, Clone)]
#[non_exhaustive]
pub struct SkyPicture {
    /// What each cell of the partition sees (sky, below the surface, or the asset hit).
    pub cells: Vec<CellClass>,
    /// SVF and sky exposure of the POI against the full-detail scene.
    pub view: SkyView,
    /// The POI's trust flags ([`checks::poi_flags`]).
    pub flags: Vec<PoiFlag>,
    /// The level of each asset for this POI, when asked: an opening (window, door) left
    /// out shows its wall's level, since the rough wall's plane closes it in the LoD model.
    pub levels: Option<Vec<u8>>,
}

/// The fisheye pictures of the POIs of `framed`, one at a time, handed to `each` (POI index,
/// picture) as soon as each is made (so a caller writes it before the next is traced): the
/// full-detail scene and, with [`SkyPictureOptions::levels`], the rough model and selection
/// scene built once ([`Stage::Bvh`]), then per POI ([`Stage::Trace`], cancellable before
/// each) its cells, SVF, flags and levels.
///
/// # Errors
/// [`Error::Select`], [`Error::Cancelled`] (as `E`), or what `each` returns.
pub fn sky_pictures<E: From<Error>>(
    framed: &Framed<'_>,
    opts: &SkyPictureOptions<'_>,
    progress: &dyn Progress,
    mut each: impl FnMut(usize, SkyPicture) -> Result<(), E>,
) -> Result<(), E> {
    let model: &CityModel = &framed.model;
    check(progress, Stage::Bvh).map_err(Error::from)?;
    let n = if opts.levels.is_some() { 2 } else { 1 };
    progress.start(Stage::Bvh, n, 0);
    let scene = full_scene(model);
    let around = checks::Surroundings::new(model);
    progress.advance(Stage::Bvh, 1, 0, Some("full scene"));
    let selection = opts.levels.map(|lod| {
        let rough = rough_model(model, &lod.rough);
        let scene = selection_scene(model, &rough);
        progress.advance(Stage::Bvh, 1, 0, Some("selection scene"));
        (lod, rough, scene)
    });
    progress.finish(Stage::Bvh);
    progress.start(Stage::Trace, framed.local_pois.len() as u64, 0);
    let r = framed
        .local_pois
        .iter()
        .enumerate()
        .try_for_each(|(k, poi)| {
            check(progress, Stage::Trace).map_err(Error::from)?;
            let cells = classify_cells(
                opts.partition,
                &scene,
                poi.ray_origin(),
                poi.normal,
                POI_OFFSET,
            );
            let view = poi_sky_view(&scene, poi, opts.bundles);
            let no_sky = (view.sky_exposure == 0.0).then_some(0);
            let flags = checks::poi_flags_around(&scene, model, &around, poi, no_sky);
            let levels = match &selection {
                None => None,
                Some((lod, rough, sel_scene)) => {
                    let sel = select(
                        model,
                        rough,
                        sel_scene,
                        std::slice::from_ref(poi),
                        &lod.select,
                    )
                    .map_err(Error::from)?;
                    Some(shown_levels(model, sel.levels))
                }
            };
            let picture = SkyPicture {
                cells,
                view,
                flags,
                levels,
            };
            each(k, picture)?;
            progress.advance(Stage::Trace, 1, 0, Some(&poi.id));
            Ok(())
        });
    progress.finish(Stage::Trace);
    r
}

/// `levels` with each opening left out at its wall's level (see [`SkyPicture::levels`]).
fn shown_levels(model: &CityModel, mut levels: Vec<u8>) -> Vec<u8> {
    for (i, a) in model.assets.iter().enumerate() {
        if a.kind.is_opening() && levels.get(i) == Some(&0) {
            if let Some(p) = a.parent.and_then(|p| levels.get(p).copied()) {
                levels[i] = p;
            }
        }
    }
    levels
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::runtime::progress::Cancelled;
    use crate::model::runtime::progress::Silent;
    use crate::pipeline::test_support::*;

    #[test]
    fn sky_pictures_come_one_per_poi_and_stop_when_cancelled() {
        let mut inputs = fixture_inputs();
        let framed = framed_with(&mut inputs, 5);
        let partition =
            SkyPartition::new(300, crate::solar::sky::SkyVariant::EqualSolidAngle).unwrap();
        let bundles = SkyBundles::new(400, 1).unwrap();
        let lod = LodOptions {
            select: crate::lod::select::SelectOptions {
                rays: 500,
                ..Default::default()
            },
            ..Default::default()
        };
        let opts = SkyPictureOptions {
            partition: &partition,
            bundles: &bundles,
            levels: Some(lod),
        };
        let tally = Tally::default();
        let mut got = Vec::new();
        sky_pictures(&framed, &opts, &tally, |k, p| -> Result<(), Error> {
            got.push((k, p));
            Ok(())
        })
        .unwrap();
        assert_eq!(got.iter().map(|g| g.0).collect::<Vec<_>>(), [0, 1, 2, 3, 4]);
        assert_eq!(tally.sum(Stage::Trace, "start").0, 5);
        assert_eq!(tally.sum(Stage::Trace, "advance").0, 5);
        assert_eq!(tally.sum(Stage::Bvh, "advance").0, 2);
        let scene = full_scene(&framed.model);
        for (k, pic) in &got {
            let poi = &framed.local_pois[*k];
            assert_eq!(pic.cells.len(), partition.len());
            assert_eq!(pic.view, poi_sky_view(&scene, poi, &bundles));
            // The levels `lod` selects for this POI alone, openings shown at their wall's.
            let alone =
                crate::lod::lod(&*framed.model, std::slice::from_ref(poi), &lod, &Silent).unwrap();
            let want = shown_levels(&framed.model, alone.selection.levels);
            assert_eq!(pic.levels.as_deref(), Some(&want[..]));
        }

        // Cancelled after the first picture: `each` saw one, the trace stage is named.
        let stop = Stopper::new(Stage::Trace, 1);
        let mut seen = 0;
        let r = sky_pictures(&framed, &opts, &stop, |_, _| -> Result<(), Error> {
            seen += 1;
            Ok(())
        });
        assert_cancelled(&r, Stage::Trace);
        assert_eq!(seen, 1);
        // An error of `each` stops the work and is returned as is.
        let mut calls = 0;
        let r = sky_pictures(&framed, &opts, &Silent, |_, _| {
            calls += 1;
            Err::<(), _>(Error::Cancelled(Cancelled {
                stage: Stage::Write,
            }))
        });
        assert_cancelled(&r, Stage::Write);
        assert_eq!(calls, 1);
    }
}
