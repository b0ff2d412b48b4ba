//! `--source-crs` and `--poi-crs`, and the local metric frame every tracing command works in
//! ([`skylod::model::crs::LocalFrame`]): the model and the POIs are brought into it after reading,
//! reports and outputs stay in the input's CRS.

use skylod::model::crs::Crs;
use skylod::pipeline::FrameOptions;

/// Parse a CRS flag: any `srsName` spelling that names a CRS ([`Crs::parse_named`]).
pub fn parse_crs(s: &str) -> Result<Crs, String> {
    Crs::parse_named(s)
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

impl CrsArgs {
    /// The frame options of the flags: `--source-crs`, `--poi-crs`, and `margin` (m) for
    /// POIs outside the scene.
    pub fn frame_options(&self, margin: f64) -> FrameOptions {
        FrameOptions {
            source_crs: self.source.source_crs.clone(),
            poi_crs: self.poi_crs.clone(),
            poi_margin: margin,
        }
    }
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
