//! Step 2: the model and the POIs in the local metric frame the tracing works in.

use super::session::Error;
use super::PoiCrsError;
use crate::lod::poi::checks::extent::distance_to_box;
use crate::lod::poi::{check_poi, check_poi_list, checks};
use crate::model::crs::{build_transform, model_crs, Crs, CrsKind, LocalFrame, PointTransform};
use crate::model::Poi;
use crate::model::{Bbox, CityModel};
use glam::DVec3;
use std::borrow::Cow;

/// How the model and the POIs are brought into the tracing frame (`frame`).
#[derive(Debug, Clone, PartialEq)]
pub struct FrameOptions {
    /// CRS of the inputs instead of their `srsName` (written into the model's files, so
    /// reports and the sun's site see it).
    pub source_crs: Option<Crs>,
    /// CRS of the POIs when it is not the model's.
    pub poi_crs: Option<Crs>,
    /// POIs farther than this (m) outside the scene's bounding box are refused.
    pub poi_margin: f64,
}

impl Default for FrameOptions {
    fn default() -> Self {
        FrameOptions {
            source_crs: None,
            poi_crs: None,
            poi_margin: checks::DEFAULT_POI_MARGIN,
        }
    }
}

/// The model and POIs in the local metric frame, with what reports need.
#[derive(Debug)]
#[non_exhaustive]
pub struct Framed<'a> {
    /// The model as read (CRS of the input): what outputs are written from.
    pub source: &'a CityModel,
    /// The model in the local frame: what is traced.
    pub model: Cow<'a, CityModel>,
    /// The model's CRS.
    pub crs: Crs,
    /// The frame.
    pub frame: LocalFrame,
    /// POIs in the model's CRS (for reports); borrowed from a [`crate::pipeline::session::Study`]
    /// (a city's cadastre has millions).
    pub pois: Cow<'a, [Poi]>,
    /// POIs in the local frame (for tracing).
    pub local_pois: Cow<'a, [Poi]>,
    /// What the caller should tell the user (other CRSs named by the inputs, the frame
    /// chosen, its accuracy).
    pub warnings: Vec<String>,
    /// A note on the frame when it is not the identity ("tracing in ...").
    pub note: Option<String>,
    /// The frame's warning (no CRS, an unknown one, ...), structured; its text is the last
    /// of [`Framed::warnings`].
    pub frame_warning: Option<crate::model::crs::FrameWarning>,
}

/// [`frame`] of a model whose box ([`CityModel::bbox`]) is `bbox` when given (the
/// caller has it already: a city's points are not walked again).
///
/// # Errors
/// As [`frame`].
pub(crate) fn frame_in<'a>(
    model: &'a mut CityModel,
    bbox: Option<Bbox>,
    pois: Vec<Poi>,
    opts: &FrameOptions,
) -> Result<Framed<'a>, Error> {
    check_poi_list(&pois)?;
    if let Some(c) = &opts.source_crs {
        for f in &mut model.files {
            f.srs_name = Some(c.name.clone());
        }
    }
    let source: &'a CityModel = model;
    let crs = model_crs(source, opts.source_crs.as_ref());
    let mut warnings = Vec::new();
    let others: Vec<String> = source
        .files
        .iter()
        .filter_map(|f| f.srs_name.as_deref())
        .map(Crs::parse)
        .filter(|c| !c.compatible(&crs))
        .map(|c| c.to_string())
        .collect();
    if !others.is_empty() {
        warnings.push(format!(
            "inputs name other CRSs than {crs} ({}); all are traced as {crs}",
            others.join(", ")
        ));
    }
    // every point of a city: one pass for the frame and the POI check (and none more when
    // the frame is the identity), or none when the caller has the box
    let source_bbox = bbox.unwrap_or_else(|| source.bbox());
    let (frame, warning) = LocalFrame::new(&crs, &source_bbox);
    warnings.extend(warning.as_ref().map(|w| w.to_string()));
    let note = (!frame.is_identity()).then(|| format!("{crs}: tracing in {}", frame.describe()));
    let local = frame.model_to_local(source);
    let local_bbox = match &local {
        Cow::Borrowed(_) => source_bbox,
        Cow::Owned(m) => m.bbox(),
    };
    let pois = match &opts.poi_crs {
        Some(pc) => {
            if !crs.is_known() {
                return Err(PoiCrsError::UnknownModelCrs {
                    from: pc.to_string(),
                    model: crs.to_string(),
                }
                .into());
            }
            let t = build_transform();
            let converted = t.pois(pc, &crs, &pois);
            if let CrsKind::Geographic {
                lat_first: true, ..
            } = pc.kind
            {
                let near = |p: DVec3| {
                    t.position(pc, &crs, p).is_ok_and(|q| {
                        distance_to_box(&local_bbox, frame.to_local(q)) <= opts.poi_margin
                    })
                };
                checks::check_lat_lon_order(&pc.to_string(), &pois, &source_bbox, near)?;
            }
            converted.map_err(|source| PoiCrsError::Convert {
                from: pc.to_string(),
                source,
            })?
        }
        None => pois,
    };
    let local_pois: Vec<Poi> = pois.iter().map(|p| frame.poi_to_local(p)).collect();
    // a conversion can leave a POI without finite coordinates (outside a CRS's domain)
    for (k, p) in local_pois.iter().enumerate() {
        check_poi(p, &format!("POI {} in the tracing frame", k + 1))?;
    }
    checks::check_pois_near_in_frame(
        &local_bbox,
        &local_pois,
        &source_bbox,
        &pois,
        opts.poi_margin,
    )?;
    Ok(Framed {
        source,
        model: local,
        crs,
        frame,
        pois: Cow::Owned(pois),
        local_pois: Cow::Owned(local_pois),
        warnings,
        note,
        frame_warning: warning,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lod::poi::PoiError;
    use crate::model::runtime::progress::Silent;
    use crate::pipeline::read_inputs;
    use crate::pipeline::test_support::*;
    use crate::solar::SkyBundles;
    use glam::DVec3;

    /// Each POI that used to be traced to a clean-looking SVF 1 (a NaN position, a zero
    /// normal) or to two rows under one id is refused by `frame`, so by every path after it.
    #[test]
    fn invalid_pois_are_refused_before_any_tracing() {
        let mut inputs = read_inputs(&[fixture()], &Silent).unwrap();
        let good = grid_pois(&inputs.model, 2);
        let bundles = SkyBundles::new(100, 1).unwrap();
        let mut nan = good.clone();
        nan[1].position.x = f64::NAN;
        let r = frame(&mut inputs.model, nan, &FrameOptions::default());
        assert!(
            matches!(&r, Err(Error::Poi(PoiError::NotFinite { at, .. })) if at == "POI 2"),
            "{r:?}"
        );
        let mut flat = good.clone();
        flat[0].normal = Some(DVec3::ZERO);
        let r = frame(&mut inputs.model, flat, &FrameOptions::default());
        assert!(
            matches!(&r, Err(Error::Poi(PoiError::ZeroNormal { .. }))),
            "{r:?}"
        );
        let mut twice = good.clone();
        twice[1].id = twice[0].id.clone();
        let r = frame(&mut inputs.model, twice, &FrameOptions::default());
        assert!(
            matches!(&r, Err(Error::Poi(PoiError::DuplicateId { .. }))),
            "{r:?}"
        );
        // The same POIs, valid, are traced.
        let framed = frame(&mut inputs.model, good, &FrameOptions::default()).unwrap();
        assert_eq!(svf(&framed, &bundles, &Silent).unwrap().results.len(), 2);
    }
}
