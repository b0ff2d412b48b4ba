//! `skylod fisheye` from a [`Study`]: each POI's sky picture as an SVG with its title and
//! captions (the POI, its SVF and sky exposure, the inputs, the sun paths' year and site),
//! handed to the caller one at a time ([`Study::fisheye_svgs`]).

use super::weather::SunSite;
use super::Study;
use crate::lod::poi::checks::PoiFlag;
use crate::lod::LodOptions;
use crate::model::crs::{model_site, NoSite};
use crate::model::runtime::progress::Progress;
use crate::model::{AssetKind, Poi};
use crate::pipeline::session::Error;
use crate::pipeline::{sky_pictures, SkyPictureOptions};
use crate::solar::fisheye::SunPath;
use crate::solar::fisheye::{cell_shares, fisheye_svg, sun_paths, FisheyeOptions, Projection};
use crate::solar::sky::{SkyError, SkyPartition, SkyVariant};
use crate::solar::{Site, SkyBundles, SolarError};
use std::path::Path;

/// How the pictures are made: the cells, the bundles of the SVF said in the caption, the
/// projection, the sun paths and, when given, the levels each asset is coloured by.
#[derive(Debug, Clone)]
pub struct Pictures {
    partition: SkyPartition,
    bundles: SkyBundles,
    projection: Projection,
    levels: Option<LodOptions>,
    /// The sun paths' year and site (latitude, longitude), and the paths.
    paths: Option<(i32, (f64, f64), Vec<SunPath>)>,
}

impl Pictures {
    /// Pictures of `rays` cells of the equal solid-angle partition (one ray through each
    /// centre) in `projection`, with the SVF of bundles of at least 10,000 rays (seed 1).
    ///
    /// # Errors
    /// [`SkyError`] for a ray count the partition cannot make.
    pub fn new(rays: usize, projection: Projection) -> Result<Pictures, SkyError> {
        Ok(Pictures {
            partition: SkyPartition::new(rays, SkyVariant::EqualSolidAngle)?,
            bundles: SkyBundles::new(rays.max(10_000), 1)?,
            projection,
            levels: None,
            paths: None,
        })
    }

    /// The same, hit cells coloured by the level `skylod lod` gives each asset for the POI
    /// (`Some`) or by the asset's kind (`None`).
    pub fn with_levels(mut self, levels: Option<LodOptions>) -> Self {
        self.levels = levels;
        self
    }

    /// The same with the sun paths of `year` seen from `site` (latitude, longitude).
    ///
    /// # Errors
    /// [`SolarError`] for a year the sun position does not cover.
    pub fn with_sun_paths(mut self, site: (f64, f64), year: i32) -> Result<Self, SolarError> {
        let paths = sun_paths(&Site::new(site.0, site.1), year)?;
        self.paths = Some((year, site, paths));
        Ok(self)
    }

    /// Cells per picture.
    pub fn cells(&self) -> usize {
        self.partition.len()
    }

    /// The title and caption lines of the picture of `poi` (`decimals` plan decimals:
    /// 8 for degrees, else 2) with SVF `svf` and sky exposure `exposure`.
    fn captions(
        &self,
        poi: &Poi,
        decimals: usize,
        (svf, exposure): (f64, f64),
        inputs: &str,
    ) -> (String, Vec<String>) {
        let dp = if decimals == 8 { 8 } else { 2 };
        let p = poi.position;
        let normal = poi
            .normal
            .map_or(", no normal (horizontal)".to_string(), |n| {
                format!(", normal ({:.2}, {:.2}, {:.2})", n.x, n.y, n.z)
            });
        let mut caption = vec![
            format!("POI ({:.dp$}, {:.dp$}, {:.2}){normal}", p.x, p.y, p.z),
            format!(
                "SVF {svf:.3}, sky exposure {exposure:.3} ({} rays per bundle); input: {inputs}",
                self.bundles.len()
            ),
        ];
        if let Some((year, (lat, lon), _)) = &self.paths {
            caption.push(format!("sun paths {year} at lat {lat}, lon {lon}"));
        }
        (format!("Sky from {}", poi.id), caption)
    }
}

/// One POI's picture ([`Study::fisheye_svgs`]).
#[derive(Debug, Clone)]
#[non_exhaustive]
pub struct PictureSvg {
    /// The SVG document.
    pub svg: String,
    /// The POI's trust flags.
    pub flags: Vec<PoiFlag>,
    /// The share of the cells that see the sky (0..=1).
    pub sky: f64,
    /// The POI's SVF against the full-detail scene.
    pub svf: f64,
}

impl PictureSvg {
    /// What to say of the picture of POI `poi` over `inputs` (their names) written to
    /// `out`, of `cells` cells.
    pub fn line(&self, poi: &str, inputs: &str, out: &Path, cells: usize) -> String {
        let (sky, svf) = (self.sky * 100.0, self.svf);
        let out = out.display();
        format!("{poi}: {inputs} -> {out} ({cells} cells, {sky:.1} % sky, SVF {svf:.3})")
    }
}

impl Study {
    /// The site of the sun paths: `given`, else the centre of the model in its CRS as
    /// framed (named as it prints).
    ///
    /// # Errors
    /// [`NoSite`] when none is given and the model gives none.
    pub fn sun_paths_site(&self, given: Option<(f64, f64)>) -> Result<SunSite, NoSite> {
        if let Some((a, o)) = given {
            return Ok(SunSite::Given(a, o));
        }
        let s = model_site(self.source(), self.crs())?;
        Ok(SunSite::Model(s.lat, s.lon, self.crs().to_string()))
    }

    /// The sky picture of every POI (in order, `sky_pictures`) as SVG with its captions,
    /// handed to `each` (POI index, picture) as soon as it is made.
    ///
    /// # Errors
    /// [`Error::Select`], [`Error::Cancelled`] (as `E`), or what `each`
    /// returns.
    pub fn fisheye_svgs<E: From<Error>>(
        &self,
        pictures: &Pictures,
        progress: &dyn Progress,
        mut each: impl FnMut(usize, PictureSvg) -> Result<(), E>,
    ) -> Result<(), E> {
        let framed = self.framed();
        let kinds: Vec<AssetKind> = framed.model.assets.iter().map(|a| a.kind).collect();
        let opts = SkyPictureOptions {
            partition: &pictures.partition,
            bundles: &pictures.bundles,
            levels: pictures.levels,
        };
        let inputs = self.input_names().join(", ");
        let decimals = self.crs().plan_decimals();
        sky_pictures(&framed, &opts, progress, |k, pic| {
            let view = (pic.view.svf, pic.view.sky_exposure);
            let (title, caption) = pictures.captions(&self.pois()[k], decimals, view, &inputs);
            let paths = pictures.paths.as_ref().map(|p| p.2.clone());
            let fopts = FisheyeOptions {
                projection: pictures.projection,
                title,
                caption,
                sun_paths: paths.unwrap_or_default(),
                ..FisheyeOptions::default()
            };
            let levels = pic.levels.as_deref();
            let svg = fisheye_svg(&pictures.partition, &pic.cells, &kinds, levels, &fopts);
            let shares = cell_shares(&pic.cells, &kinds, levels);
            let sky = shares
                .into_iter()
                .find(|s| s.0 == "sky")
                .map_or(0.0, |s| s.1);
            let svg = svg.to_string();
            each(
                k,
                PictureSvg {
                    svg,
                    flags: pic.flags,
                    sky,
                    svf: pic.view.svf,
                },
            )
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::runtime::progress::Silent;
    use crate::pipeline::session::{Scene, SceneOptions};
    use crate::pipeline::test_support::{fixture, grid_pois};

    #[test]
    fn each_poi_s_picture_is_captioned_with_its_figures() {
        let scene = Scene::load(&[fixture()], &SceneOptions::default(), &Silent).unwrap();
        let mut pois = grid_pois(scene.model(), 2);
        pois[0].normal = Some(glam::DVec3::Z);
        pois[1].normal = None;
        let study = scene.frame(pois).unwrap();
        let site = study.sun_paths_site(None).unwrap();
        assert!(
            matches!(&site, SunSite::Model(_, _, n) if n == "EPSG:25831"),
            "{site:?}"
        );
        assert_eq!(
            study.sun_paths_site(Some((1.0, 2.0))).unwrap(),
            SunSite::Given(1.0, 2.0)
        );
        let pics = Pictures::new(300, Projection::EqualArea).unwrap();
        assert_eq!(pics.cells(), 300);
        let pics = pics.with_sun_paths((41.5, 2.25), 2024).unwrap();
        let mut got = Vec::new();
        study
            .fisheye_svgs(&pics, &Silent, |k, p| -> Result<(), Error> {
                got.push((k, p));
                Ok(())
            })
            .unwrap();
        assert_eq!(got.len(), 2);
        let inputs = fixture().display().to_string();
        for (k, p) in &got {
            let poi = &study.pois()[*k];
            assert!(
                p.svg.starts_with("<svg") || p.svg.contains("<svg"),
                "{}",
                &p.svg[..80]
            );
            assert!(p.svg.contains(&format!("Sky from {}", poi.id)));
            assert!(p.svg.contains(&format!("SVF {:.3}, sky exposure", p.svf)));
            assert!(p.svg.contains("(10000 rays per bundle); input: "));
            assert!(p.svg.contains(&inputs));
            assert!(p.svg.contains("sun paths 2024 at lat 41.5, lon 2.25"));
            assert!((0.0..=1.0).contains(&p.sky), "{}", p.sky);
            let at = format!(
                "POI ({:.2}, {:.2}, {:.2})",
                poi.position.x, poi.position.y, poi.position.z
            );
            assert!(p.svg.contains(&at), "{at}");
        }
        assert!(got[1].1.svg.contains("no normal (horizontal)"));
        assert!(got[0].1.svg.contains(", normal (0.00, 0.00, 1.00)"));
        // Without sun paths, no line on them.
        let plain = Pictures::new(300, Projection::Stereographic).unwrap();
        study
            .fisheye_svgs(&plain, &Silent, |_, p| -> Result<(), Error> {
                assert!(!p.svg.contains("sun paths"));
                Ok(())
            })
            .unwrap();
    }
}
