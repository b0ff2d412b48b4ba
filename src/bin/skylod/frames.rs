//! `--source-crs` and `--poi-crs`, and the local metric frame every tracing command works in
//! ([`skylod::crs::LocalFrame`]): the model and the POIs are brought into it after reading,
//! reports and outputs stay in the input's CRS.

use anyhow::{bail, Context};
use skylod::crs::{build_transform, model_crs, Crs, CrsKind, LocalFrame, PointTransform};
use skylod::model::CityModel;
use skylod::poi::Poi;
use std::borrow::Cow;

/// Parse a CRS flag: any `srsName` spelling (`EPSG:n`, `urn:ogc:def:crs:EPSG::n`,
/// `http://www.opengis.net/def/crs/EPSG/0/n`, compound, AdV, `OGC:CRS84`) that names a code.
pub fn parse_crs(s: &str) -> Result<Crs, String> {
    let c = Crs::parse(s);
    if c.epsg.is_none() && c.kind == CrsKind::Unknown {
        return Err(format!(
            "{s:?} names no CRS: give EPSG:n (or urn:ogc:def:crs:EPSG::n, OGC:CRS84, ...)"
        ));
    }
    Ok(c)
}

/// Decimals for printing plan coordinates of `crs`: 8 for degrees (~1 mm), 3 otherwise.
pub fn decimals(crs: &Crs) -> usize {
    if matches!(crs.kind, CrsKind::Geographic { .. }) {
        8
    } else {
        3
    }
}

/// `--source-crs`, for every command that reads.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct SourceCrsArgs {
    /// CRS of the inputs, instead of their srsName: EPSG:n or any srsName form. Geographic
    /// CRSs (EPSG:4326, 6697, ...) are traced in a local east-north-up frame in metres,
    /// feet CRSs (EPSG:2263, ...) scaled to metres; outputs keep the input's coordinates.
    #[arg(long, value_name = "CRS", value_parser = parse_crs)]
    pub source_crs: Option<Crs>,
}

impl SourceCrsArgs {
    /// Replace the `srsName` of every file by `--source-crs`, so that everything that looks
    /// at the model's CRS (frame, site of the sun, stats, report) sees the override.
    pub fn apply(&self, model: &mut CityModel) {
        if let Some(c) = &self.source_crs {
            for f in &mut model.files {
                f.srs_name = Some(c.name.clone());
            }
        }
    }
}

/// `--source-crs` and `--poi-crs`, for the commands that take POIs.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct CrsArgs {
    #[command(flatten)]
    pub source: SourceCrsArgs,
    /// CRS of --poi and --pois when it is not the model's: EPSG:4326 (WGS 84), or any
    /// geographic CRS on GRS 1980/WGS 84, or a UTM CRS (EPSG:326xx, 258xx, ...); any EPSG CRS
    /// PROJ knows, to a model in any, in a build with the `proj` feature. Axis order
    /// as EPSG defines it: EPSG:4326 is LAT,LON,HEIGHT (as pyproj without always_xy), the
    /// normal NX,NY,NZ is along the same axes (north, east, up); OGC:CRS84 is LON,LAT. The
    /// height is in the model's vertical datum (passed through); no datum shift between
    /// WGS 84, ETRS89, JGD2011, NAD83 (EPSG's null transformation, as PROJ's default).
    #[arg(long, value_name = "CRS", value_parser = parse_crs)]
    pub poi_crs: Option<Crs>,
}

/// The model and POIs in the local metric frame, with what reports need.
pub struct Framed<'a> {
    /// The model as read (CRS of the input): what outputs are written from.
    pub source: &'a CityModel,
    /// The model in the local frame: what is traced.
    pub model: Cow<'a, CityModel>,
    /// The model's CRS.
    pub crs: Crs,
    /// The frame.
    pub frame: LocalFrame,
    /// POIs in the model's CRS (for reports).
    pub pois: Vec<Poi>,
    /// POIs in the local frame (for tracing).
    pub local_pois: Vec<Poi>,
}

/// Apply `--source-crs`, choose the frame (warnings on stderr, prefixed by `cmd`), convert
/// the POIs from `--poi-crs` to the model's CRS and everything into the frame.
pub fn frame<'a>(
    model: &'a mut CityModel,
    args: &CrsArgs,
    pois: Vec<Poi>,
    cmd: &str,
) -> anyhow::Result<Framed<'a>> {
    args.source.apply(model);
    let source: &'a CityModel = model;
    let crs = model_crs(source, args.source.source_crs.as_ref());
    let others: Vec<String> = source
        .files
        .iter()
        .filter_map(|f| f.srs_name.as_deref())
        .map(Crs::parse)
        .filter(|c| !c.compatible(&crs))
        .map(|c| c.to_string())
        .collect();
    if !others.is_empty() {
        eprintln!(
            "{cmd}: warning: inputs name other CRSs than {crs} ({}); all are traced as {crs}",
            others.join(", ")
        );
    }
    let (frame, warning) = LocalFrame::new(&crs, &source.bbox());
    if let Some(w) = warning {
        eprintln!("{cmd}: warning: {w}");
    }
    if !frame.is_identity() {
        eprintln!("{cmd}: {crs}: tracing in {}", frame.describe());
    }
    let pois = match &args.poi_crs {
        Some(pc) => {
            if !crs.is_known() {
                bail!("--poi-crs {pc}: the model's CRS ({crs}) is not known, so POIs cannot be converted to it (give --source-crs)");
            }
            build_transform()
                .pois(pc, &crs, &pois)
                .with_context(|| format!("--poi-crs {pc}"))?
        }
        None => pois,
    };
    let local_pois = pois.iter().map(|p| frame.poi_to_local(p)).collect();
    let model = frame.model_to_local(source);
    Ok(Framed {
        source,
        model,
        crs,
        frame,
        pois,
        local_pois,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crs_flags() {
        assert_eq!(parse_crs("EPSG:6697").unwrap().epsg, Some(6697));
        assert_eq!(
            parse_crs("urn:ogc:def:crs:EPSG::2263").unwrap().epsg,
            Some(2263)
        );
        assert!(parse_crs("OGC:CRS84").is_ok());
        assert!(parse_crs("wgs84").is_err());
        assert!(parse_crs("").is_err());
    }
}
