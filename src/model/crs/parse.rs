//! `srsName` → [`Crs`]: the spellings CityGML files use, and what skylod knows of each code.
//!
//! Spellings: `EPSG:n`, `urn:ogc:def:crs:EPSG::n`, `urn:ogc:def:crs:EPSG:6.12:n`, compound
//! `urn:ogc:def:crs,crs:EPSG::a,crs:EPSG::b` (horizontal `a`, vertical `b`),
//! `http://www.opengis.net/def/crs/EPSG/0/n`, OGC `CRS84`/`CRS84h` (longitude first), and the
//! German AdV names `urn:adv:crs:ETRS89_UTM32*DE_DHHN92_NH` (ETRS89 / UTM zone *n* = EPSG:258nn,
//! `DE_DHDN_3GK<n>` = EPSG:3146(4+n), heights DHHN92 = EPSG:5783, DHHN2016 = EPSG:7837).
//!
//! Kinds: the geographic CRSs of [`GEOGRAPHIC`] (latitude first, as EPSG defines them, with
//! their ellipsoid), projected CRSs in US survey feet or international feet
//! ([`super::feet`]), the projected CRSs in metres of [`PROJECTED_METRES`]; any other code is
//! [`CrsKind::Unknown`] (traced as metres, with a warning). Every table is checked against
//! pyproj's EPSG database by `tests/it/crs_frames.rs`.

use super::feet::{foot_unit, INTERNATIONAL_FOOT, US_SURVEY_FOOT};
use std::fmt;

/// A reference ellipsoid: semi-major axis (m) and inverse flattening.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ellipsoid {
    /// Semi-major axis in metres.
    pub a: f64,
    /// Inverse flattening 1/f.
    pub inv_f: f64,
}

impl Ellipsoid {
    /// The ellipsoid of semi-major axis `a` (metres) and inverse flattening `inv_f`.
    pub const fn new(a: f64, inv_f: f64) -> Ellipsoid {
        Ellipsoid { a, inv_f }
    }

    /// GRS 1980 (ETRS89, JGD2000/2011, NAD83, GDA, CGCS2000 to well below a millimetre).
    pub const GRS80: Ellipsoid = Ellipsoid::new(6_378_137.0, 298.257_222_101);
    /// WGS 84.
    pub const WGS84: Ellipsoid = Ellipsoid::new(6_378_137.0, 298.257_223_563);
    /// Bessel 1841 (DHDN, Tokyo, MGI).
    pub const BESSEL1841: Ellipsoid = Ellipsoid::new(6_377_397.155, 299.152_812_8);
    /// Airy 1830 (OSGB36).
    pub const AIRY1830: Ellipsoid = Ellipsoid::new(6_377_563.396, 299.324_964_6);
    /// International 1924 (ED50).
    pub const INTL1924: Ellipsoid = Ellipsoid::new(6_378_388.0, 297.0);
    /// Clarke 1866 (NAD27).
    pub const CLARKE1866: Ellipsoid = Ellipsoid::new(6_378_206.4, 294.978_698_213_898_2);

    /// Flattening.
    pub fn f(&self) -> f64 {
        1.0 / self.inv_f
    }

    /// First eccentricity squared.
    pub fn e2(&self) -> f64 {
        let f = self.f();
        f * (2.0 - f)
    }
}

/// Geographic CRSs skylod converts without PROJ: EPSG code, latitude first (EPSG order),
/// ellipsoid. 6697 is the compound JGD2011 + JGD2011 (vertical) height of Japan's PLATEAU.
pub const GEOGRAPHIC: &[(u32, bool, Ellipsoid)] = &[
    (4326, true, Ellipsoid::WGS84),      // WGS 84
    (4979, true, Ellipsoid::WGS84),      // WGS 84 (3D)
    (4148, true, Ellipsoid::WGS84),      // Hartebeesthoek94
    (4258, true, Ellipsoid::GRS80),      // ETRS89
    (4937, true, Ellipsoid::GRS80),      // ETRS89 (3D)
    (4171, true, Ellipsoid::GRS80),      // RGF93
    (6668, true, Ellipsoid::GRS80),      // JGD2011
    (6697, true, Ellipsoid::GRS80),      // JGD2011 + JGD2011 (vertical) height
    (4612, true, Ellipsoid::GRS80),      // JGD2000
    (4019, true, Ellipsoid::GRS80),      // Unknown datum based upon the GRS 1980 ellipsoid
    (4269, true, Ellipsoid::GRS80),      // NAD83
    (4152, true, Ellipsoid::GRS80),      // NAD83(HARN)
    (6318, true, Ellipsoid::GRS80),      // NAD83(2011)
    (6319, true, Ellipsoid::GRS80),      // NAD83(2011) (3D)
    (4617, true, Ellipsoid::GRS80),      // NAD83(CSRS)
    (4283, true, Ellipsoid::GRS80),      // GDA94
    (7844, true, Ellipsoid::GRS80),      // GDA2020
    (7843, true, Ellipsoid::GRS80),      // GDA2020 (3D)
    (4167, true, Ellipsoid::GRS80),      // NZGD2000
    (4959, true, Ellipsoid::GRS80),      // NZGD2000 (3D)
    (4490, true, Ellipsoid::GRS80),      // CGCS2000 (its ellipsoid equals GRS 1980)
    (4301, true, Ellipsoid::BESSEL1841), // Tokyo
    (4314, true, Ellipsoid::BESSEL1841), // DHDN
    (4277, true, Ellipsoid::AIRY1830),   // OSGB36
    (4230, true, Ellipsoid::INTL1924),   // ED50
    (4267, true, Ellipsoid::CLARKE1866), // NAD27
];

/// Inclusive ranges of EPSG codes known to be projected CRSs in metres (easting, northing
/// in the files skylod reads; see [`CrsKind::Projected`]).
pub const PROJECTED_METRES: &[(u32, u32)] = &[
    (2056, 2056),   // CH1903+ / LV95
    (2100, 2100),   // GGRS87 / Greek Grid
    (2154, 2154),   // RGF93 / Lambert-93
    (2169, 2169),   // LUREF / Luxembourg TM
    (2180, 2180),   // ETRF2000-PL / CS92
    (2193, 2193),   // NZTM2000
    (2443, 2461),   // JGD2000 / Japan Plane Rectangular CS I-XIX
    (3006, 3006),   // SWEREF99 TM
    (3035, 3035),   // ETRS89 / LAEA Europe
    (3040, 3050),   // ETRS89 / UTM 28N-37N (N-E), TM38
    (3067, 3067),   // ETRS89 / TM35FIN
    (3068, 3068),   // DHDN / Soldner Berlin
    (3097, 3101),   // JGD2000 / UTM 51N-55N
    (3414, 3414),   // SVY21 / Singapore TM
    (3763, 3763),   // ETRS89 / Portugal TM06
    (3794, 3794),   // Slovenia 1996
    (3812, 3812),   // ETRS89 / Belgian Lambert 2008
    (3826, 3826),   // TWD97 / TM2 zone 121
    (3857, 3857),   // WGS 84 / Pseudo-Mercator
    (3912, 3912),   // MGI 1901 / Slovene National Grid
    (4647, 4647),   // ETRS89 / UTM 32N (zE-N)
    (5186, 5187),   // KGD2002 / Central, East Belt 2010
    (5649, 5650),   // ETRS89 / UTM 31N, 33N (zE-N)
    (6669, 6692),   // JGD2011 / Japan Plane Rectangular CS I-XIX, UTM 51N-55N
    (7846, 7859),   // GDA2020 / MGA zones 46-59
    (21781, 21781), // CH1903 / LV03
    (23028, 23038), // ED50 / UTM 28N-38N
    (25828, 25838), // ETRS89 / UTM 28N-38N
    (26701, 26722), // NAD27 / UTM 1N-22N
    (26901, 26923), // NAD83 / UTM 1N-23N
    (27700, 27700), // OSGB36 / British National Grid
    (28348, 28358), // GDA94 / MGA zones 48-58
    (28992, 28992), // Amersfoort / RD New
    (31254, 31259), // MGI / Austria GK
    (31370, 31370), // BD72 / Belgian Lambert 72
    (31466, 31469), // DHDN / 3-degree Gauss-Kruger zones 2-5
    (32601, 32660), // WGS 84 / UTM 1N-60N
    (32701, 32760), // WGS 84 / UTM 1S-60S
];

/// Vertical CRSs whose heights are in feet: NGVD29 height (ftUS), NAVD88 height (ftUS),
/// NAVD88 height (ft).
const VERTICAL_FEET: &[(u32, f64)] = &[
    (5702, US_SURVEY_FOOT),
    (6360, US_SURVEY_FOOT),
    (8228, INTERNATIONAL_FOOT),
];

/// What kind of coordinates a CRS has, as far as tracing is concerned.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CrsKind {
    /// Projected: `x` easting, `y` northing (what CityGML files in practice hold, also for
    /// CRSs that EPSG defines northing first), in units of `metres_per_unit` metres.
    Projected {
        /// 1 for metres, [`US_SURVEY_FOOT`] or `INTERNATIONAL_FOOT`.
        metres_per_unit: f64,
    },
    /// Geographic: degrees on `ellipsoid`, latitude first when `lat_first` (EPSG order).
    Geographic {
        /// Reference ellipsoid.
        ellipsoid: Ellipsoid,
        /// `x` is the latitude, `y` the longitude (otherwise the reverse, as OGC CRS84).
        lat_first: bool,
    },
    /// Not recognised: traced as if in metres.
    Unknown,
}

/// A coordinate reference system named by an `srsName` (see the module docs).
///
/// Equality compares what the name means (codes, or the normalised name when there is no
/// code), not its spelling: `EPSG:25832` equals `urn:ogc:def:crs:EPSG::25832`.
#[derive(Debug, Clone)]
pub struct Crs {
    /// The name as given (trimmed).
    pub name: String,
    /// EPSG code of the horizontal (or only) component, when known.
    pub epsg: Option<u32>,
    /// EPSG code of the vertical component of a compound CRS.
    pub vertical_epsg: Option<u32>,
    /// Kind of coordinates.
    pub kind: CrsKind,
    /// Metres per unit of the heights (`z`): the vertical CRS's unit when it is a known
    /// feet-based one, otherwise the horizontal unit of a projected CRS without a vertical
    /// component (US models in feet have heights in feet), otherwise 1.
    pub vertical_metres_per_unit: f64,
}

impl PartialEq for Crs {
    fn eq(&self, o: &Crs) -> bool {
        match (self.epsg, o.epsg) {
            (None, None) => normalise(&self.name) == normalise(&o.name),
            (a, b) => a == b && self.vertical_epsg == o.vertical_epsg,
        }
    }
}

impl fmt::Display for Crs {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match (self.epsg, self.vertical_epsg) {
            (Some(h), Some(v)) => write!(f, "EPSG:{h}+{v}"),
            (Some(h), None) => write!(f, "EPSG:{h}"),
            _ if self.name.is_empty() => f.write_str("(no CRS)"),
            _ => f.write_str(&self.name),
        }
    }
}

fn normalise(s: &str) -> String {
    s.trim().to_ascii_uppercase()
}

impl Crs {
    /// Parse a CRS given by a user (a flag): any `srsName` spelling (`EPSG:n`,
    /// `urn:ogc:def:crs:EPSG::n`, `http://www.opengis.net/def/crs/EPSG/0/n`, compound, AdV,
    /// `OGC:CRS84`) that names a CRS; an error message saying so otherwise.
    ///
    /// ```
    /// use skylod::model::crs::Crs;
    /// assert_eq!(Crs::parse_named("EPSG:6697").unwrap().epsg, Some(6697));
    /// assert!(Crs::parse_named("wgs84").is_err());
    /// ```
    pub fn parse_named(s: &str) -> Result<Crs, String> {
        let c = Crs::parse(s);
        if c.epsg.is_none() && c.kind == CrsKind::Unknown {
            return Err(format!(
                "{s:?} names no CRS: give EPSG:n (or urn:ogc:def:crs:EPSG::n, OGC:CRS84, ...)"
            ));
        }
        Ok(c)
    }

    /// Decimals for writing plan coordinates in this CRS: 8 for degrees (~1 mm), 3
    /// otherwise.
    pub fn plan_decimals(&self) -> usize {
        if matches!(self.kind, CrsKind::Geographic { .. }) {
            8
        } else {
            3
        }
    }

    /// Parse an `srsName` (never fails: an unrecognised name is [`CrsKind::Unknown`]).
    ///
    /// ```
    /// use skylod::model::crs::{Crs, CrsKind};
    /// let c = Crs::parse("http://www.opengis.net/def/crs/EPSG/0/6697");
    /// assert!(matches!(c.kind, CrsKind::Geographic { lat_first: true, .. }));
    /// assert_eq!(c, Crs::parse("EPSG:6697"));
    /// let ny = Crs::parse("urn:ogc:def:crs:EPSG::2263");
    /// assert!(matches!(ny.kind, CrsKind::Projected { metres_per_unit } if (metres_per_unit - 0.3048006).abs() < 1e-6));
    /// ```
    pub fn parse(srs_name: &str) -> Crs {
        let name = srs_name.trim().to_string();
        let upper = normalise(&name);
        if upper.contains("CRS84") {
            return Crs {
                name,
                epsg: None,
                vertical_epsg: None,
                kind: CrsKind::Geographic {
                    ellipsoid: Ellipsoid::WGS84,
                    lat_first: false,
                },
                vertical_metres_per_unit: 1.0,
            };
        }
        let (h, v) = if upper.starts_with("URN:ADV:CRS:") {
            adv_codes(&upper)
        } else {
            let codes = epsg_codes(&upper);
            (codes.first().copied(), codes.get(1).copied())
        };
        Crs::from_codes(name, h, v)
    }

    /// The CRS `EPSG:code` (horizontal or 3D), as `--source-crs EPSG:n` gives it.
    pub fn epsg(code: u32) -> Crs {
        Crs::from_codes(format!("EPSG:{code}"), Some(code), None)
    }

    fn from_codes(name: String, h: Option<u32>, v: Option<u32>) -> Crs {
        let kind = h.map_or(CrsKind::Unknown, kind_of);
        let vfeet = v.and_then(|v| VERTICAL_FEET.iter().find(|(c, _)| *c == v).map(|x| x.1));
        let vertical_metres_per_unit = match (vfeet, kind, v) {
            (Some(u), _, _) => u,
            (None, CrsKind::Projected { metres_per_unit }, None) => metres_per_unit,
            _ => 1.0,
        };
        Crs {
            name,
            epsg: h,
            vertical_epsg: v,
            kind,
            vertical_metres_per_unit,
        }
    }

    /// Whether the CRS is recognised.
    pub fn is_known(&self) -> bool {
        self.kind != CrsKind::Unknown
    }

    /// Same horizontal CRS, and the same vertical CRS where both name one (`EPSG:25832`
    /// is compatible with `EPSG:25832` + `EPSG:5783`, not with `EPSG:25833`).
    pub fn compatible(&self, o: &Crs) -> bool {
        match (self.epsg, o.epsg) {
            (None, None) => normalise(&self.name) == normalise(&o.name),
            (a, b) => {
                a == b
                    && (self.vertical_epsg.is_none()
                        || o.vertical_epsg.is_none()
                        || self.vertical_epsg == o.vertical_epsg)
            }
        }
    }
}

/// The key two names are compared by: the EPSG code of the horizontal CRS when the name
/// carries one ([`Crs::parse`]: an AdV `ETRS89_UTMzz` name is EPSG:258zz), otherwise the
/// trimmed name.
pub fn srs_key(name: &str) -> String {
    match Crs::parse(name).epsg {
        Some(code) => format!("EPSG:{code}"),
        None => name.trim().to_string(),
    }
}

/// Whether two `srsName`s denote the same horizontal CRS (a vertical datum stated in one
/// name and not in the other does not make them differ: merging tiles asks only this;
/// [`Crs::compatible`] also compares vertical CRSs where both name one).
///
/// ```
/// use skylod::model::crs::same_crs;
/// assert!(same_crs("EPSG:25832", "urn:ogc:def:crs:EPSG::25832"));
/// assert!(same_crs("urn:adv:crs:ETRS89_UTM32*DE_DHHN92_NH", "urn:ogc:def:crs,crs:EPSG::25832,crs:EPSG::5783"));
/// assert!(!same_crs("EPSG:25832", "EPSG:25833"));
/// ```
pub fn same_crs(a: &str, b: &str) -> bool {
    srs_key(a) == srs_key(b)
}

/// Kind of the EPSG code `code`.
pub fn kind_of(code: u32) -> CrsKind {
    if let Some((_, lat_first, ellipsoid)) = GEOGRAPHIC.iter().find(|g| g.0 == code) {
        return CrsKind::Geographic {
            ellipsoid: *ellipsoid,
            lat_first: *lat_first,
        };
    }
    if let Some(u) = foot_unit(code) {
        return CrsKind::Projected { metres_per_unit: u };
    }
    if PROJECTED_METRES
        .iter()
        .any(|(a, b)| (*a..=*b).contains(&code))
    {
        return CrsKind::Projected {
            metres_per_unit: 1.0,
        };
    }
    // Any other projected CRS in metres with a proj4 definition in `crs-definitions`
    // (27572, 3942-3950, 2056, ...): converted by `proj4rs` in the default build.
    let projected = u16::try_from(code)
        .ok()
        .and_then(super::convert::proj4_definition)
        .is_some_and(|d| {
            ![
                "+proj=longlat",
                "+proj=latlong",
                "+proj=lonlat",
                "+proj=geocent",
            ]
            .iter()
            .any(|p| d.contains(p))
        });
    if projected {
        return CrsKind::Projected {
            metres_per_unit: 1.0,
        };
    }
    CrsKind::Unknown
}

/// Horizontal and vertical EPSG codes of an AdV name (upper case).
fn adv_codes(upper: &str) -> (Option<u32>, Option<u32>) {
    let rest = &upper["URN:ADV:CRS:".len()..];
    let mut parts = rest.split('*');
    let h = parts.next().unwrap_or("");
    let v = parts.next().unwrap_or("");
    let zone = |prefix: &str| -> Option<u32> {
        let digits: String = h
            .strip_prefix(prefix)?
            .chars()
            .take_while(char::is_ascii_digit)
            .collect();
        digits.parse().ok()
    };
    let hc = if let Some(z) = zone("ETRS89_UTM") {
        (28..=38).contains(&z).then_some(25800 + z)
    } else if let Some(z) = zone("DE_DHDN_3GK") {
        (2..=5).contains(&z).then_some(31464 + z)
    } else if h.starts_with("ETRS89_LAT-LON") {
        Some(4258)
    } else {
        None
    };
    let vc = if v.starts_with("DE_DHHN2016") {
        Some(7837)
    } else if v.starts_with("DE_DHHN92") {
        Some(5783)
    } else {
        None
    };
    (hc, vc)
}

/// The code after each `EPSG` authority in the name: the last number of the run of digits
/// and separators that follows it (`EPSG::25832`, `EPSG/0/25832`, `EPSG:6.12:31466`).
pub(crate) fn epsg_codes(upper: &str) -> Vec<u32> {
    let mut codes = Vec::new();
    for rest in upper.split("EPSG").skip(1) {
        // The run of digits and separators after the authority; its last number is the
        // code (`::25832`, `/0/25832`, `:6.12:31466`); `EPSG:a+b` (a compound CRS as PROJ
        // and the command line write it) gives two.
        let run: &str = rest
            .split(|c: char| !(c.is_ascii_digit() || matches!(c, ':' | '/' | '.' | '+')))
            .next()
            .unwrap_or("");
        for part in run.split('+') {
            if let Some(code) = part
                .rsplit(|c: char| !c.is_ascii_digit())
                .find(|d| !d.is_empty())
                .and_then(|d| d.parse::<u32>().ok())
            {
                codes.push(code);
            }
        }
    }
    codes
}

#[cfg(test)]
mod tests {
    use super::*;

    fn geo(lat_first: bool) -> &'static str {
        if lat_first {
            "geo-latlon"
        } else {
            "geo-lonlat"
        }
    }

    fn describe(c: &Crs) -> String {
        let k = match c.kind {
            CrsKind::Projected {
                metres_per_unit: 1.0,
            } => "m".to_string(),
            CrsKind::Projected { metres_per_unit } if metres_per_unit == US_SURVEY_FOOT => {
                "ftUS".to_string()
            }
            CrsKind::Projected { .. } => "ft".to_string(),
            CrsKind::Geographic { lat_first, .. } => geo(lat_first).to_string(),
            CrsKind::Unknown => "unknown".to_string(),
        };
        format!("{k} {:?} {:?}", c.epsg, c.vertical_epsg)
    }

    /// One line per spelling: what it must parse to.
    #[test]
    fn spellings() {
        for (name, want) in [
            ("EPSG:25831", "m Some(25831) None"),
            ("epsg:25831", "m Some(25831) None"),
            ("urn:ogc:def:crs:EPSG::25832", "m Some(25832) None"),
            ("urn:ogc:def:crs:EPSG:6.12:31466", "m Some(31466) None"),
            (
                "urn:ogc:def:crs,crs:EPSG::25832,crs:EPSG::5783",
                "m Some(25832) Some(5783)",
            ),
            (
                "urn:ogc:def:crs,crs:EPSG:6.12:3068,crs:EPSG:6.12:5783",
                "m Some(3068) Some(5783)",
            ),
            (
                "http://www.opengis.net/def/crs/EPSG/0/6697",
                "geo-latlon Some(6697) None",
            ),
            (
                "https://www.opengis.net/def/crs/EPSG/0/4326",
                "geo-latlon Some(4326) None",
            ),
            ("urn:ogc:def:crs:EPSG::4979", "geo-latlon Some(4979) None"),
            ("EPSG:6668", "geo-latlon Some(6668) None"),
            ("EPSG:4258", "geo-latlon Some(4258) None"),
            ("urn:ogc:def:crs:OGC:1.3:CRS84", "geo-lonlat None None"),
            (
                "http://www.opengis.net/def/crs/OGC/0/CRS84h",
                "geo-lonlat None None",
            ),
            ("EPSG:2263", "ftUS Some(2263) None"),
            (
                "urn:ogc:def:crs,crs:EPSG::2263,crs:EPSG::6360",
                "ftUS Some(2263) Some(6360)",
            ),
            ("EPSG:2223", "ft Some(2223) None"),
            (
                "urn:adv:crs:ETRS89_UTM32*DE_DHHN92_NH",
                "m Some(25832) Some(5783)",
            ),
            (
                "urn:adv:crs:ETRS89_UTM33*DE_DHHN2016_NH",
                "m Some(25833) Some(7837)",
            ),
            (
                "urn:adv:crs:DE_DHDN_3GK4*DE_DHHN92_NH",
                "m Some(31468) Some(5783)",
            ),
            ("urn:adv:crs:ETRS89_UTM99", "unknown None None"),
            ("EPSG:99999", "unknown Some(99999) None"),
            ("#local-CRS-1", "unknown None None"),
            ("", "unknown None None"),
        ] {
            assert_eq!(describe(&Crs::parse(name)), want, "{name}");
        }
    }

    #[test]
    fn heights_follow_the_vertical_crs() {
        assert_eq!(
            Crs::parse("EPSG:2263").vertical_metres_per_unit,
            US_SURVEY_FOOT
        );
        assert_eq!(
            Crs::parse("urn:ogc:def:crs,crs:EPSG::2263,crs:EPSG::5703").vertical_metres_per_unit,
            1.0
        );
        assert_eq!(
            Crs::parse("urn:ogc:def:crs,crs:EPSG::2222,crs:EPSG::6360").vertical_metres_per_unit,
            US_SURVEY_FOOT
        );
        assert_eq!(Crs::parse("EPSG:6697").vertical_metres_per_unit, 1.0);
    }

    #[test]
    fn equality_is_by_meaning() {
        assert_eq!(
            Crs::parse("EPSG:25832"),
            Crs::parse("urn:ogc:def:crs:EPSG::25832")
        );
        assert_eq!(
            Crs::parse("urn:adv:crs:ETRS89_UTM32*DE_DHHN92_NH"),
            Crs::parse("urn:ogc:def:crs,crs:EPSG::25832,crs:EPSG::5783")
        );
        assert_ne!(Crs::parse("EPSG:25832"), Crs::parse("EPSG:25833"));
        assert_ne!(
            Crs::parse("EPSG:25832"),
            Crs::parse("urn:ogc:def:crs,crs:EPSG::25832,crs:EPSG::5783")
        );
        assert!(Crs::parse("EPSG:25832").compatible(&Crs::parse(
            "urn:ogc:def:crs,crs:EPSG::25832,crs:EPSG::5783"
        )));
        assert!(!Crs::parse("EPSG:25832").compatible(&Crs::parse("EPSG:6697")));
        assert_eq!(Crs::parse("#a"), Crs::parse(" #A "));
        assert_eq!(Crs::epsg(6697), Crs::parse("EPSG:6697"));
        assert_eq!(Crs::parse("EPSG:6697").to_string(), "EPSG:6697");
    }
}
