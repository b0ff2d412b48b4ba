//! A solar cadastre's tables (`irradiance --surfaces`): one row per roof or wall surface
//! ([`surface_rows`], [`write_surface_table`]) and one per sample point
//! ([`write_point_table`]).
//!
//! A surface's row: its name, its building's `gml:id`, `roof` or `wall`, its area (the
//! polygons', holes out), its points, the mean, least and greatest annual global irradiation
//! of its points (kWh/m²; the mean is the plain mean of the points, which sample the surface
//! evenly), with a threshold the area whose points reach it (the surface's area times the
//! share of its points at or above it), and the building's roof total: the sum over its roof
//! surfaces of mean × area (kWh/year); with monthly values, the mean of its points per month
//! of the weather's local time. A surface without points (smaller than the grid) has an
//! empty mean, least and greatest.
//!
//! # Example
//! ```
//! use skylod::export::report::{surface_rows, write_surface_table, TableLayout};
//! use skylod::lod::poi::{CadastreSurface, SurfaceClass};
//! use skylod::solar::irradiance::Irradiance;
//! let roof = CadastreSurface { name: "r".into(), asset: 0, class: SurfaceClass::Roof,
//!     building: Some("B".into()), polygons: vec![0], area_m2: 20.0 };
//! let point = |g: f64| Irradiance { global_kwh_m2: g, direct_kwh_m2: 0.0, diffuse_kwh_m2: 0.0,
//!     reflected_kwh_m2: 0.0, svf: 1.0, sun_hours_possible: 0, sun_hours: 0,
//!     monthly_global_kwh_m2: [g / 12.0; 12] };
//! let at = |id: &str| skylod::model::Poi::at(id, [0.0; 3]);
//! let rows = surface_rows(&[roof], &[at("r:0"), at("r:1")], &[point(1000.0), point(1200.0)],
//!     Some(1100.0), true);
//! assert_eq!((rows[0].mean_kwh_m2, rows[0].area_above_m2), (Some(1100.0), Some(10.0)));
//! assert_eq!(rows[0].building_roof_kwh, Some(22_000.0));
//! assert!((rows[0].monthly_mean_kwh_m2.unwrap()[0] - 1100.0 / 12.0).abs() < 1e-9);
//! let mut csv = Vec::new();
//! let layout = TableLayout { threshold: Some(1100.0), monthly: true, header: true, degrees: false };
//! write_surface_table(&mut csv, &rows, layout).unwrap();
//! assert!(String::from_utf8(csv).unwrap().starts_with("surface_id,building_id,kind,area_m2"));
//! ```

use crate::lod::poi::{surface_of_poi, CadastreSurface, SurfaceClass};
use crate::model::Poi;
use crate::solar::irradiance::Irradiance;
use std::collections::HashMap;
use std::io::Write;

/// One surface of a cadastre (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct SurfaceRow {
    /// The surface's name.
    pub surface_id: String,
    /// Its building's `gml:id`, if any.
    pub building_id: Option<String>,
    /// Roof or wall.
    pub kind: SurfaceClass,
    /// Its area (m²).
    pub area_m2: f64,
    /// Its sample points.
    pub points: usize,
    /// Mean annual global irradiation of its points (kWh/m²).
    pub mean_kwh_m2: Option<f64>,
    /// The least of its points.
    pub min_kwh_m2: Option<f64>,
    /// The greatest of its points.
    pub max_kwh_m2: Option<f64>,
    /// With a threshold: the area whose points reach it (m²).
    pub area_above_m2: Option<f64>,
    /// The building's roofs: Σ mean × area (kWh/year).
    pub building_roof_kwh: Option<f64>,
    /// With monthly values: the mean of its points per month, January first (kWh/m²).
    pub monthly_mean_kwh_m2: Option<[f64; 12]>,
}

/// The columns and lines of a cadastre table: the threshold's column, the months' columns,
/// the header line (an array job's first part only, so the parts concatenated are the whole
/// table).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TableLayout {
    /// The threshold of `area_above_m2` (kWh/m²), when that column is wanted.
    pub threshold: Option<f64>,
    /// Twelve columns `jan_kwh_m2` … `dec_kwh_m2`.
    pub monthly: bool,
    /// The header line.
    pub header: bool,
    /// The model's CRS is in degrees (latitude and longitude): the point table's positions are
    /// written with 9 decimals in x and y (about 0.1 mm) rather than 3 (1 mm).
    pub degrees: bool,
}

/// The months' column names, January first.
pub const MONTH_COLUMNS: [&str; 12] = [
    "jan_kwh_m2",
    "feb_kwh_m2",
    "mar_kwh_m2",
    "apr_kwh_m2",
    "may_kwh_m2",
    "jun_kwh_m2",
    "jul_kwh_m2",
    "aug_kwh_m2",
    "sep_kwh_m2",
    "oct_kwh_m2",
    "nov_kwh_m2",
    "dec_kwh_m2",
];

/// The rows of `surfaces` from the annual figures `annual[k]` of each point `pois[k]` (named
/// `<surface>:<k>`, as [`crate::lod::poi::surface_pois`] names them); points of other
/// surfaces are left out. With `threshold`, each row's area above it; with `monthly`, its
/// monthly means.
pub fn surface_rows<A: AsRef<Irradiance>>(
    surfaces: &[CadastreSurface],
    pois: &[Poi],
    annual: &[A],
    threshold: Option<f64>,
    monthly: bool,
) -> Vec<SurfaceRow> {
    let index: HashMap<&str, usize> = (surfaces.iter().enumerate())
        .map(|(i, s)| (s.name.as_str(), i))
        .collect();
    let mut values: Vec<Vec<f64>> = vec![Vec::new(); surfaces.len()];
    let mut months: Vec<[f64; 12]> = vec![[0.0; 12]; surfaces.len()];
    for (p, r) in pois.iter().zip(annual) {
        let r = r.as_ref();
        if let Some(&i) = index.get(surface_of_poi(&p.id)) {
            values[i].push(r.global_kwh_m2);
            for (m, v) in months[i].iter_mut().zip(r.monthly_global_kwh_m2) {
                *m += v;
            }
        }
    }
    let mut rows: Vec<SurfaceRow> = (surfaces.iter().zip(&values).zip(&months))
        .map(|((s, v), month_sums)| {
            let n = v.len();
            let mean = (n > 0).then(|| v.iter().sum::<f64>() / n as f64);
            let above = threshold.map(|t| {
                let k = v.iter().filter(|&&g| g >= t).count();
                if n == 0 {
                    0.0
                } else {
                    s.area_m2 * k as f64 / n as f64
                }
            });
            SurfaceRow {
                surface_id: s.name.clone(),
                building_id: s.building.clone(),
                kind: s.class,
                area_m2: s.area_m2,
                points: n,
                mean_kwh_m2: mean,
                min_kwh_m2: v.iter().copied().reduce(f64::min),
                max_kwh_m2: v.iter().copied().reduce(f64::max),
                area_above_m2: above,
                building_roof_kwh: None,
                monthly_mean_kwh_m2: (monthly && n > 0).then(|| month_sums.map(|m| m / n as f64)),
            }
        })
        .collect();
    let mut roofs: HashMap<String, f64> = HashMap::new();
    for r in &rows {
        if let (Some(b), SurfaceClass::Roof, Some(m)) = (&r.building_id, r.kind, r.mean_kwh_m2) {
            *roofs.entry(b.clone()).or_default() += m * r.area_m2;
        }
    }
    for r in &mut rows {
        r.building_roof_kwh = r.building_id.as_ref().and_then(|b| roofs.get(b).copied());
    }
    rows
}

/// A number with `digits` decimals, empty for none.
fn num(v: Option<f64>, digits: usize) -> String {
    v.map_or(String::new(), |v| format!("{v:.digits$}"))
}

/// The surface table as CSV: `surface_id, building_id, kind, area_m2, points, mean_kwh_m2,
/// min_kwh_m2, max_kwh_m2`, then as `layout` asks `area_above_m2` and the months, then
/// `building_roof_kwh`.
///
/// # Errors
/// The writer's.
pub fn write_surface_table(
    out: impl Write,
    rows: &[SurfaceRow],
    layout: TableLayout,
) -> csv::Result<()> {
    let mut w = csv::Writer::from_writer(out);
    let mut head = vec![
        "surface_id",
        "building_id",
        "kind",
        "area_m2",
        "points",
        "mean_kwh_m2",
        "min_kwh_m2",
        "max_kwh_m2",
    ];
    if layout.threshold.is_some() {
        head.push("area_above_m2");
    }
    if layout.monthly {
        head.extend(MONTH_COLUMNS);
    }
    head.push("building_roof_kwh");
    if layout.header {
        w.write_record(&head)?;
    }
    for r in rows {
        let mut rec = vec![
            r.surface_id.clone(),
            r.building_id.clone().unwrap_or_default(),
            r.kind.as_str().to_string(),
            format!("{:.3}", r.area_m2),
            r.points.to_string(),
            num(r.mean_kwh_m2, 3),
            num(r.min_kwh_m2, 3),
            num(r.max_kwh_m2, 3),
        ];
        if layout.threshold.is_some() {
            rec.push(num(r.area_above_m2, 3));
        }
        if layout.monthly {
            for m in 0..12 {
                rec.push(num(r.monthly_mean_kwh_m2.map(|v| v[m]), 3));
            }
        }
        rec.push(num(r.building_roof_kwh, 1));
        w.write_record(&rec)?;
    }
    w.flush()?;
    Ok(())
}

/// Every sample point as CSV: `surface_id, x, y, z, nx, ny, nz, global_kwh_m2,
/// direct_kwh_m2, diffuse_kwh_m2, reflected_kwh_m2`, the point in the model's CRS (`pois`,
/// named by [`crate::lod::poi::surface_pois`]) with its annual values `annual` in order, and
/// the months when `layout` asks for them.
///
/// # Errors
/// The writer's.
pub fn write_point_table(
    out: impl Write,
    pois: &[Poi],
    annual: &[impl AsRef<Irradiance>],
    layout: TableLayout,
) -> csv::Result<()> {
    let mut w = csv::Writer::from_writer(out);
    let mut head = vec![
        "surface_id",
        "x",
        "y",
        "z",
        "nx",
        "ny",
        "nz",
        "global_kwh_m2",
        "direct_kwh_m2",
        "diffuse_kwh_m2",
        "reflected_kwh_m2",
    ];
    if layout.monthly {
        head.extend(MONTH_COLUMNS);
    }
    if layout.header {
        w.write_record(head)?;
    }
    let xy = if layout.degrees { 9 } else { 3 };
    for (p, r) in pois.iter().zip(annual) {
        let r = r.as_ref();
        let n = p.normal.unwrap_or(glam::DVec3::Z);
        let mut rec = vec![
            surface_of_poi(&p.id).to_string(),
            format!("{:.*}", xy, p.position.x),
            format!("{:.*}", xy, p.position.y),
            format!("{:.3}", p.position.z),
            format!("{:.4}", n.x),
            format!("{:.4}", n.y),
            format!("{:.4}", n.z),
            format!("{:.3}", r.global_kwh_m2),
            format!("{:.3}", r.direct_kwh_m2),
            format!("{:.3}", r.diffuse_kwh_m2),
            format!("{:.3}", r.reflected_kwh_m2),
        ];
        if layout.monthly {
            rec.extend(r.monthly_global_kwh_m2.iter().map(|m| format!("{m:.3}")));
        }
        w.write_record(rec)?;
    }
    w.flush()?;
    Ok(())
}
