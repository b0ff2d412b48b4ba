//! Fisheye picture of the sky hemisphere seen from a point (SVG, through the `svg` crate).
//!
//! The world upper hemisphere (z up) is cut into the cells of an equal solid-angle
//! [`SkyPartition`]; each cell is classified by a ray through its centre
//! ([`classify_cells`]) as sky, behind the surface, or hit (with the index of the asset
//! hit). [`fisheye_svg`] draws the cells as annular sectors, coloured by the kind of
//! the asset hit ([`HitClass`]) or, when a per-asset level array is given, by the
//! selection level (0 left out, 1 rough, 2 full detail), with a legend giving each
//! class's share of the hemisphere (cells have equal solid angle, so the share of cells
//! is the share of solid angle). Sun paths ([`sun_paths`]: solstices, equinox, hour
//! lines) are drawn on top when given.
//!
//! The picture is the view **from the point looking up**, north at the top: east is on
//! the left and west on the right, as in a hemispherical photograph. The zenith is the
//! centre and the horizon the outer circle, with altitude circles every 30 degrees.
//! Projections ([`Projection`]): equal-area (Lambert azimuthal, areas on the picture are
//! proportional to solid angle) or stereographic (the usual sun-path chart, angles kept).
//!
//! # Example
//! ```rust
//! use skylod::model::AssetKind;
//! use skylod::solar::{SkyPartition, SkyVariant};
//! use skylod::solar::{CellClass, FisheyeOptions, fisheye_svg};
//! let sky = SkyPartition::new(145, SkyVariant::EqualSolidAngle)?;
//! // The outer ring (30 cells) is blocked by asset 0, a wall.
//! let mut cells = vec![CellClass::Sky; 145];
//! for c in &mut cells[115..] {
//!     *c = CellClass::Hit(0);
//! }
//! let doc = fisheye_svg(&sky, &cells, &[AssetKind::Wall], None, &FisheyeOptions::default());
//! let text = doc.to_string();
//! assert!(text.starts_with("<svg") && text.contains("wall"));
//! # Ok::<(), skylod::solar::SkyError>(())
//! ```

use super::sun::{sun_position, Site};
use super::SolarError;
use crate::model::AssetKind;
use crate::solar::sky::{SkyPartition, SkyVariant};
use crate::solar::trace::TraceScene;
use chrono::{Duration, NaiveDate, TimeZone, Utc};
use glam::DVec3;
use rayon::prelude::*;
use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI, TAU};
use svg::node::element::path::Data;
use svg::node::element::{Circle, Group, Line, Path, Polyline, Rectangle, Text, Title};
use svg::Document;

/// Map projection of the hemisphere onto the disk (zenith at the centre, horizon at the rim).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Projection {
    /// Lambert azimuthal equal-area: `r = sin(theta/2) / sin(pi/4)`. The default.
    #[default]
    EqualArea,
    /// Stereographic: `r = tan(theta/2)`.
    Stereographic,
}

impl Projection {
    /// Radius on the unit disk of zenith angle `theta` (radians, 0..=pi/2).
    pub fn radius(self, theta: f64) -> f64 {
        let t = theta.clamp(0.0, FRAC_PI_2);
        match self {
            Projection::EqualArea => (0.5 * t).sin() / FRAC_PI_4.sin(),
            Projection::Stereographic => (0.5 * t).tan(),
        }
    }

    /// Lower-case name (`equal-area`, `stereographic`).
    pub fn as_str(self) -> &'static str {
        match self {
            Projection::EqualArea => "equal-area",
            Projection::Stereographic => "stereographic",
        }
    }
}

/// What the ray through a cell's centre sees.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CellClass {
    /// Free sky.
    Sky,
    /// Behind the surface the point lies on (`dot(n, d) <= 0`); not traced.
    Behind,
    /// Blocked by the asset with this index (the scene's triangle tag).
    Hit(u32),
}

/// Colour class of a hit by the kind of asset hit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum HitClass {
    /// `RoofSurface`.
    Roof,
    /// `WallSurface`.
    Wall,
    /// `GroundSurface`.
    Ground,
    /// `BuildingInstallation`.
    Installation,
    /// Window or door.
    Opening,
    /// Anything else (closure, outer ceiling/floor, building body, other objects, or an
    /// asset index without a known kind).
    Other,
}

impl HitClass {
    /// Every class, in legend order.
    pub const ALL: [HitClass; 6] = [
        HitClass::Roof,
        HitClass::Wall,
        HitClass::Ground,
        HitClass::Installation,
        HitClass::Opening,
        HitClass::Other,
    ];

    /// The class of an asset kind.
    pub fn of(kind: AssetKind) -> HitClass {
        match kind {
            AssetKind::Roof => HitClass::Roof,
            AssetKind::Wall => HitClass::Wall,
            AssetKind::Ground => HitClass::Ground,
            AssetKind::Installation => HitClass::Installation,
            AssetKind::Window | AssetKind::Door => HitClass::Opening,
            AssetKind::Closure
            | AssetKind::OuterCeiling
            | AssetKind::OuterFloor
            | AssetKind::Body
            | AssetKind::Other => HitClass::Other,
        }
    }

    /// Legend label.
    pub fn label(self) -> &'static str {
        match self {
            HitClass::Roof => "roof",
            HitClass::Wall => "wall",
            HitClass::Ground => "ground",
            HitClass::Installation => "installation",
            HitClass::Opening => "opening (window, door)",
            HitClass::Other => "other",
        }
    }

    fn colour(self) -> &'static str {
        match self {
            HitClass::Roof => "#c0392b",
            HitClass::Wall => "#e3c9a0",
            HitClass::Ground => "#8d6e63",
            HitClass::Installation => "#27ae60",
            HitClass::Opening => "#6c3483",
            HitClass::Other => "#7f8c8d",
        }
    }
}

const SKY_COLOUR: &str = "#cfe8ff";
const BEHIND_COLOUR: &str = "#4d4d4d";
const LEVEL_COLOURS: [(&str, &str); 3] = [
    ("#f4d03f", "level 0 (left out)"),
    ("#e67e22", "level 1 (rough)"),
    ("#2e4053", "level 2 (full detail)"),
];

/// Kind of a [`SunPath`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SunPathKind {
    /// The sun's path over one day.
    Day,
    /// The sun's position at one hour of local mean solar time over half a year.
    Hour,
}

/// A curve of sun directions (x east, y north, z up; points below the horizon included,
/// the drawing clips them).
#[derive(Debug, Clone, PartialEq)]
pub struct SunPath {
    /// What the curve shows.
    pub kind: SunPathKind,
    /// Label (date of a day path, hour of an hour line).
    pub label: String,
    /// Unit directions in time order.
    pub points: Vec<DVec3>,
}

/// Sun paths of `year` at `site`: the day paths of the June solstice (06-21), the March
/// equinox (03-20) and the December solstice (12-21), sampled every 5 minutes over one
/// local mean solar day, and hour lines for every whole hour of local mean solar time
/// (UTC + longitude/15 h) from 4 to 20 h, sampled every 5 days from 06-21 to 12-21.
///
/// # Errors
/// [`SolarError::Year`] for a year chrono cannot represent, [`SolarError::Spa`] for an
/// invalid site.
pub fn sun_paths(site: &Site, year: i32) -> Result<Vec<SunPath>, SolarError> {
    let day0 = |m: u32, d: u32| {
        NaiveDate::from_ymd_opt(year, m, d)
            .and_then(|nd| nd.and_hms_opt(0, 0, 0))
            .map(|t| Utc.from_utc_datetime(&t))
            .ok_or(SolarError::Year(year))
    };
    // Local mean solar midnight of a date, in UTC.
    let solar_shift = Duration::seconds((site.longitude / 15.0 * 3600.0).round() as i64);
    let mut out = Vec::new();
    for (m, d, label) in [
        (6, 21, "06-21"),
        (3, 20, "03-20 (equinox)"),
        (12, 21, "12-21"),
    ] {
        let start = day0(m, d)? - solar_shift;
        let points = (0..=288)
            .map(|k| sun_position(start + Duration::minutes(5 * k), site).map(|p| p.direction))
            .collect::<Result<Vec<_>, _>>()?;
        out.push(SunPath {
            kind: SunPathKind::Day,
            label: label.to_string(),
            points,
        });
    }
    let june = day0(6, 21)? - solar_shift;
    let december = day0(12, 21)? - solar_shift;
    let days = (december - june).num_days();
    for hour in 4..=20i64 {
        let points = (0..=days / 5)
            .map(|k| {
                let t = june + Duration::days(5 * k) + Duration::hours(hour);
                sun_position(t, site).map(|p| p.direction)
            })
            .collect::<Result<Vec<_>, _>>()?;
        out.push(SunPath {
            kind: SunPathKind::Hour,
            label: format!("{hour}h"),
            points,
        });
    }
    Ok(out)
}

/// Direction through the centre (in solid angle) of cell `cell` of `partition` (local
/// frame = world frame here), or `None` out of range.
pub fn cell_centre(partition: &SkyPartition, cell: usize) -> Option<DVec3> {
    let b = partition.cell_bounds(cell)?;
    let theta = match partition.variant() {
        SkyVariant::EqualSolidAngle => (0.5 * (b.theta_min.cos() + b.theta_max.cos()))
            .clamp(-1.0, 1.0)
            .acos(),
        SkyVariant::EqualProjectedArea => {
            let s2 = 0.5 * (b.theta_min.sin().powi(2) + b.theta_max.sin().powi(2));
            s2.sqrt().clamp(0.0, 1.0).asin()
        }
    };
    let theta = if b.theta_min == 0.0 { 0.0 } else { theta };
    let phi = 0.5 * (b.phi_min + b.phi_max);
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    Some(DVec3::new(st * sp, st * cp, ct))
}

/// Classify every cell of `partition` (world frame, z up) as seen from `origin` on a
/// surface with `normal` (`None`: free point, nothing is behind): the ray through the
/// cell's centre is traced with `scene.first_hit(origin, d, tmin, inf)`. Parallel over
/// cells; the result does not depend on the thread count.
pub fn classify_cells(
    partition: &SkyPartition,
    scene: &TraceScene,
    origin: DVec3,
    normal: Option<DVec3>,
    tmin: f64,
) -> Vec<CellClass> {
    let n = normal.and_then(|n| n.try_normalize());
    (0..partition.len())
        .into_par_iter()
        .map(|c| {
            let Some(d) = cell_centre(partition, c) else {
                return CellClass::Sky;
            };
            if n.is_some_and(|n| n.dot(d) <= 0.0) {
                return CellClass::Behind;
            }
            match scene.first_hit(origin, d, tmin, f64::INFINITY) {
                Some(h) => CellClass::Hit(h.tag),
                None => CellClass::Sky,
            }
        })
        .collect()
}

/// Drawing options of [`fisheye_svg`].
#[derive(Debug, Clone, PartialEq)]
pub struct FisheyeOptions {
    /// Projection of the hemisphere.
    pub projection: Projection,
    /// Title line (e.g. the POI and the input).
    pub title: String,
    /// Extra caption lines under the title (e.g. SVF).
    pub caption: Vec<String>,
    /// Sun paths drawn on top (`sun_paths`); empty for none.
    pub sun_paths: Vec<SunPath>,
    /// Radius of the horizon circle in pixels.
    pub radius: f64,
}

impl Default for FisheyeOptions {
    fn default() -> Self {
        FisheyeOptions {
            projection: Projection::EqualArea,
            title: "sky seen from the point".into(),
            caption: Vec::new(),
            sun_paths: Vec::new(),
            radius: 300.0,
        }
    }
}

/// A colour key of a cell and its legend entry.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
enum Key {
    Sky,
    Behind,
    Kind(HitClass),
    Level(u8),
}

impl Key {
    fn colour(self) -> &'static str {
        match self {
            Key::Sky => SKY_COLOUR,
            Key::Behind => BEHIND_COLOUR,
            Key::Kind(k) => k.colour(),
            Key::Level(l) => LEVEL_COLOURS
                .get(usize::from(l))
                .map_or(HitClass::Other.colour(), |c| c.0),
        }
    }

    fn label(self) -> String {
        match self {
            Key::Sky => "sky".into(),
            Key::Behind => "behind the surface".into(),
            Key::Kind(k) => k.label().into(),
            Key::Level(l) => LEVEL_COLOURS
                .get(usize::from(l))
                .map_or_else(|| format!("level {l}"), |c| c.1.to_string()),
        }
    }
}

fn key_of(c: CellClass, kinds: &[AssetKind], levels: Option<&[u8]>) -> Key {
    match c {
        CellClass::Sky => Key::Sky,
        CellClass::Behind => Key::Behind,
        CellClass::Hit(a) => match levels {
            Some(l) => Key::Level(l.get(a as usize).copied().unwrap_or(0).min(2)),
            None => Key::Kind(
                kinds
                    .get(a as usize)
                    .copied()
                    .map_or(HitClass::Other, HitClass::of),
            ),
        },
    }
}

/// Round to 0.01 px for compact output.
fn px(v: f64) -> f32 {
    ((v * 100.0).round() / 100.0) as f32
}

struct Canvas {
    cx: f64,
    cy: f64,
    r: f64,
    proj: Projection,
}

impl Canvas {
    /// Screen point of zenith angle `theta` and azimuth `phi` (clockwise from north),
    /// seen from below: north up, east left.
    fn at(&self, theta: f64, phi: f64) -> (f64, f64) {
        let rr = self.r * self.proj.radius(theta);
        (self.cx - rr * phi.sin(), self.cy - rr * phi.cos())
    }

    fn of_dir(&self, d: DVec3) -> (f64, f64) {
        let theta = d.x.hypot(d.y).atan2(d.z);
        self.at(theta, d.x.atan2(d.y))
    }

    /// Closed path of the annular sector `theta0..theta1` x `phi0..phi1`.
    fn sector(&self, theta0: f64, theta1: f64, phi0: f64, phi1: f64) -> Data {
        let r1 = self.r * self.proj.radius(theta1);
        let r0 = self.r * self.proj.radius(theta0);
        let span = phi1 - phi0;
        let p = |x: (f64, f64)| (px(x.0), px(x.1));
        if span >= TAU - 1e-12 {
            // Full ring: two circles (even-odd fill leaves the hole).
            let mut d = circle_data(self.cx, self.cy, r1);
            if r0 > 0.0 {
                d = circle_into(d, self.cx, self.cy, r0);
            }
            return d;
        }
        let mut d = Data::new().move_to(p(self.at(theta1, phi0)));
        d = self.arc(d, theta1, phi0, phi1);
        if r0 > 0.0 {
            d = d.line_to(p(self.at(theta0, phi1)));
            d = self.arc(d, theta0, phi1, phi0);
        } else {
            d = d.line_to((px(self.cx), px(self.cy)));
        }
        d.close()
    }

    /// Append the arc of zenith angle `theta` from azimuth `from` to `to`, split into
    /// pieces of at most 60 degrees: an SVG arc whose chord is close to a diameter has an
    /// ill-conditioned centre once its end points are rounded.
    fn arc(&self, mut d: Data, theta: f64, from: f64, to: f64) -> Data {
        let rr = px(self.r * self.proj.radius(theta));
        let pieces = ((to - from).abs() / (PI / 3.0)).ceil().max(1.0) as usize;
        // Azimuth increasing runs counterclockwise on the screen (east is left): sweep 0.
        let sweep = if to > from { 0 } else { 1 };
        for k in 1..=pieces {
            let phi = from + (to - from) * k as f64 / pieces as f64;
            let (x, y) = self.at(theta, phi);
            d = d.elliptical_arc_to((rr, rr, 0, 0, sweep, px(x), px(y)));
        }
        d
    }
}

fn circle_into(d: Data, cx: f64, cy: f64, r: f64) -> Data {
    d.move_to((px(cx), px(cy - r)))
        .elliptical_arc_to((px(r), px(r), 0, 0, 0, px(cx), px(cy + r)))
        .elliptical_arc_to((px(r), px(r), 0, 0, 0, px(cx), px(cy - r)))
        .close()
}

fn circle_data(cx: f64, cy: f64, r: f64) -> Data {
    circle_into(Data::new(), cx, cy, r)
}

/// Draw the fisheye picture of `cells` (one [`CellClass`] per cell of `partition`, in
/// cell order; missing cells are drawn as sky). Hits are coloured by the kind of the
/// asset hit (`kinds[asset]`), or by its selection level when `levels` is given
/// (`levels[asset]`: 0 left out, 1 rough, 2 full detail; missing entries count as 0).
pub fn fisheye_svg(
    partition: &SkyPartition,
    cells: &[CellClass],
    kinds: &[AssetKind],
    levels: Option<&[u8]>,
    opts: &FisheyeOptions,
) -> Document {
    let r = if opts.radius.is_finite() && opts.radius > 10.0 {
        opts.radius
    } else {
        300.0
    };
    let margin = 50.0;
    let top = 60.0 + 18.0 * opts.caption.len() as f64;
    let canvas = Canvas {
        cx: margin + r,
        cy: top + margin * 0.5 + r,
        r,
        proj: opts.projection,
    };
    let width = 2.0 * (margin + r) + 260.0;
    let height = canvas.cy + r + margin;
    let key = |c: usize| {
        key_of(
            cells.get(c).copied().unwrap_or(CellClass::Sky),
            kinds,
            levels,
        )
    };

    // Cells: runs of equal colour within a ring become one sector.
    let mut counts: std::collections::BTreeMap<Key, usize> = Default::default();
    let mut cell_group = Group::new().set("id", "cells").set("fill-rule", "evenodd");
    let mut outline = Group::new()
        .set("id", "silhouette")
        .set("fill", "none")
        .set("stroke", "#111111")
        .set("stroke-width", 1.0);
    for ring in partition.rings() {
        let k = ring.cells;
        let mut j = 0;
        while j < k {
            let kj = key(ring.first + j);
            let mut e = j + 1;
            while e < k && key(ring.first + e) == kj {
                e += 1;
            }
            *counts.entry(kj).or_default() += e - j;
            let (phi0, phi1) = (TAU * j as f64 / k as f64, TAU * e as f64 / k as f64);
            let data = canvas.sector(ring.theta_min, ring.theta_max, phi0, phi1);
            if kj == Key::Level(2) {
                // Silhouette assets (kept in full detail) are outlined.
                outline = outline.add(Path::new().set("d", data.clone()));
            }
            cell_group = cell_group.add(
                Path::new()
                    .set("d", data)
                    .set("fill", kj.colour())
                    .set("stroke", kj.colour())
                    .set("stroke-width", 0.4),
            );
            j = e;
        }
    }

    // Grid: altitude circles, azimuth spokes, horizon, compass.
    let mut grid = Group::new()
        .set("id", "grid")
        .set("fill", "none")
        .set("stroke", "#555555")
        .set("stroke-width", 0.6)
        .set("stroke-dasharray", "3 3");
    for alt in [30.0f64, 60.0] {
        let rr = r * opts.projection.radius((90.0 - alt).to_radians());
        grid = grid
            .add(
                Circle::new()
                    .set("cx", px(canvas.cx))
                    .set("cy", px(canvas.cy))
                    .set("r", px(rr)),
            )
            .add(
                Text::new(format!("{alt:.0}°"))
                    .set("x", px(canvas.cx + 3.0))
                    .set("y", px(canvas.cy - rr - 2.0))
                    .set("font-size", 10)
                    .set("fill", "#333333")
                    .set("stroke", "none"),
            );
    }
    for az in (0..360).step_by(30) {
        let (x, y) = canvas.at(FRAC_PI_2, f64::from(az).to_radians());
        grid = grid.add(
            Line::new()
                .set("x1", px(canvas.cx))
                .set("y1", px(canvas.cy))
                .set("x2", px(x))
                .set("y2", px(y)),
        );
    }
    let mut frame = Group::new().set("id", "horizon").add(
        Circle::new()
            .set("cx", px(canvas.cx))
            .set("cy", px(canvas.cy))
            .set("r", px(r))
            .set("fill", "none")
            .set("stroke", "#000000")
            .set("stroke-width", 1.5),
    );
    for (az, label) in [(0.0, "N"), (90.0, "E"), (180.0, "S"), (270.0, "W")] {
        let (x, y) = canvas.at(FRAC_PI_2, f64::to_radians(az));
        let (dx, dy) = ((x - canvas.cx) / r, (y - canvas.cy) / r);
        frame = frame.add(
            Text::new(label)
                .set("x", px(x + dx * 18.0))
                .set("y", px(y + dy * 18.0 + 6.0))
                .set("text-anchor", "middle")
                .set("font-size", 18)
                .set("font-weight", "bold"),
        );
    }
    for az in (30..360).step_by(30).filter(|a| a % 90 != 0) {
        let (x, y) = canvas.at(FRAC_PI_2, f64::from(az).to_radians());
        let (dx, dy) = ((x - canvas.cx) / r, (y - canvas.cy) / r);
        frame = frame.add(
            Text::new(format!("{az}°"))
                .set("x", px(x + dx * 16.0))
                .set("y", px(y + dy * 16.0 + 4.0))
                .set("text-anchor", "middle")
                .set("font-size", 10)
                .set("fill", "#333333"),
        );
    }

    // Sun paths, clipped at the horizon.
    let mut sun = Group::new().set("id", "sun-paths").set("fill", "none");
    for path in &opts.sun_paths {
        let (stroke, width, dash) = match path.kind {
            SunPathKind::Day => ("#d4ac0d", 2.0, "none"),
            SunPathKind::Hour => ("#b9770e", 0.8, "4 2"),
        };
        let mut runs: Vec<Vec<(f64, f64)>> = Vec::new();
        let mut current: Vec<(f64, f64)> = Vec::new();
        for w in path.points.windows(2) {
            let (a, b) = (w[0], w[1]);
            if a.z >= 0.0 {
                current.push(canvas.of_dir(a));
            }
            if (a.z >= 0.0) != (b.z >= 0.0) {
                // Interpolate the horizon crossing.
                let t = a.z / (a.z - b.z);
                let h = a.lerp(b, t);
                current.push(canvas.of_dir(DVec3::new(h.x, h.y, 0.0)));
                if a.z >= 0.0 {
                    runs.push(std::mem::take(&mut current));
                }
            }
        }
        if let Some(last) = path.points.last().filter(|p| p.z >= 0.0) {
            current.push(canvas.of_dir(*last));
        }
        if !current.is_empty() {
            runs.push(current);
        }
        let mut g = Group::new()
            .set("stroke", stroke)
            .set("stroke-width", width)
            .set("stroke-dasharray", dash)
            .add(Title::new(path.label.clone()));
        for run in runs.iter().filter(|r| r.len() >= 2) {
            let pts: Vec<String> = run
                .iter()
                .map(|(x, y)| format!("{},{}", px(*x), px(*y)))
                .collect();
            g = g.add(Polyline::new().set("points", pts.join(" ")));
        }
        let anchor = match path.kind {
            SunPathKind::Hour => path.points.first().filter(|p| p.z > 0.02),
            SunPathKind::Day => path
                .points
                .iter()
                .filter(|p| p.z > 0.0)
                .max_by(|a, b| a.z.total_cmp(&b.z)),
        };
        // Hour labels above their June end, day labels below their noon point.
        let dy = match path.kind {
            SunPathKind::Hour => -4.0,
            SunPathKind::Day => 14.0,
        };
        if let Some(p) = anchor {
            let (x, y) = canvas.of_dir(*p);
            g = g.add(
                Text::new(path.label.clone())
                    .set("x", px(x))
                    .set("y", px(y + dy))
                    .set("text-anchor", "middle")
                    .set("font-size", 10)
                    .set("fill", "#7e5109")
                    .set("stroke", "#ffffff")
                    .set("stroke-width", 2.5)
                    .set("paint-order", "stroke"),
            );
        }
        sun = sun.add(g);
    }

    // Title, caption, legend.
    let mut head = Group::new().set("id", "title").add(
        Text::new(opts.title.clone())
            .set("x", 20)
            .set("y", 30)
            .set("font-size", 18)
            .set("font-weight", "bold"),
    );
    for (i, line) in opts.caption.iter().enumerate() {
        head = head.add(
            Text::new(line.clone())
                .set("x", 20)
                .set("y", px(52.0 + 18.0 * i as f64))
                .set("font-size", 13),
        );
    }
    let legend_keys: Vec<Key> = {
        let mut v = vec![Key::Sky];
        match levels {
            Some(_) => v.extend((0..3).map(Key::Level)),
            None => v.extend(HitClass::ALL.iter().map(|k| Key::Kind(*k))),
        }
        if counts.contains_key(&Key::Behind) {
            v.push(Key::Behind);
        }
        v
    };
    let total = partition.len().max(1) as f64;
    let lx = 2.0 * (margin + r) + 10.0;
    let mut legend = Group::new().set("id", "legend").add(
        Text::new(format!("{} cells, equal solid angle", partition.len()))
            .set("x", px(lx))
            .set("y", px(top + 10.0))
            .set("font-size", 12)
            .set("fill", "#333333"),
    );
    for (i, k) in legend_keys.iter().enumerate() {
        let y = top + 30.0 + 24.0 * i as f64;
        let share = counts.get(k).copied().unwrap_or(0) as f64 / total * 100.0;
        legend = legend
            .add(
                Rectangle::new()
                    .set("x", px(lx))
                    .set("y", px(y))
                    .set("width", 16)
                    .set("height", 16)
                    .set("fill", k.colour())
                    .set("stroke", "#000000")
                    .set("stroke-width", 0.5),
            )
            .add(
                Text::new(format!("{} {share:.1} %", k.label()))
                    .set("x", px(lx + 24.0))
                    .set("y", px(y + 13.0))
                    .set("font-size", 13),
            );
    }
    let mut y = top + 40.0 + 24.0 * legend_keys.len() as f64;
    if !opts.sun_paths.is_empty() {
        legend = line_key(
            legend,
            lx,
            y,
            ("#d4ac0d", "stroke-width", "2"),
            "sun path (solstices, equinox)",
        );
        y += 22.0;
        legend = line_key(
            legend,
            lx,
            y,
            ("#b9770e", "stroke-dasharray", "4 2"),
            "hour (local mean solar time)",
        );
        y += 22.0;
    }
    legend = legend.add(
        Text::new(format!(
            "{} projection, view from below",
            opts.projection.as_str()
        ))
        .set("x", px(lx))
        .set("y", px(y + 10.0))
        .set("font-size", 11)
        .set("fill", "#333333"),
    );

    Document::new()
        .set("width", px(width))
        .set("height", px(height))
        .set("viewBox", (0, 0, px(width), px(height)))
        .set("font-family", "sans-serif")
        .add(
            Rectangle::new()
                .set("width", "100%")
                .set("height", "100%")
                .set("fill", "#ffffff"),
        )
        .add(head)
        .add(cell_group)
        .add(outline)
        .add(grid)
        .add(sun)
        .add(frame)
        .add(legend)
}

/// Share of cells of each legend entry: `(label, fraction)` for sky, each hit class or
/// level present, and "behind the surface" (for reports and tests).
pub fn cell_shares(
    cells: &[CellClass],
    kinds: &[AssetKind],
    levels: Option<&[u8]>,
) -> Vec<(String, f64)> {
    let mut counts: std::collections::BTreeMap<Key, usize> = Default::default();
    for c in cells {
        *counts.entry(key_of(*c, kinds, levels)).or_default() += 1;
    }
    let total = cells.len().max(1) as f64;
    counts
        .into_iter()
        .map(|(k, n)| (k.label(), n as f64 / total))
        .collect()
}

/// A legend key: a 16 px line in `stroke` (with one more style attribute) and its label.
fn line_key(
    legend: Group,
    lx: f64,
    y: f64,
    (stroke, attr, value): (&str, &str, &str),
    label: &str,
) -> Group {
    legend
        .add(
            Line::new()
                .set("x1", px(lx))
                .set("y1", px(y))
                .set("x2", px(lx + 16.0))
                .set("y2", px(y))
                .set("stroke", stroke)
                .set(attr, value),
        )
        .add(
            Text::new(label)
                .set("x", px(lx + 24.0))
                .set("y", px(y + 4.0))
                .set("font-size", 13),
        )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn projections_map_horizon_to_rim() {
        for p in [Projection::EqualArea, Projection::Stereographic] {
            assert_eq!(p.radius(0.0), 0.0);
            assert!((p.radius(FRAC_PI_2) - 1.0).abs() < 1e-12);
        }
        // Equal-area: the disk area inside theta is proportional to the cap's solid angle.
        let t = 1.0f64;
        let r = Projection::EqualArea.radius(t);
        assert!((r * r - (1.0 - t.cos())).abs() < 1e-12);
    }

    #[test]
    fn cell_centres_are_inside_their_cells() {
        for v in [SkyVariant::EqualSolidAngle, SkyVariant::EqualProjectedArea] {
            let sky = SkyPartition::new(500, v).unwrap();
            for c in 0..500 {
                assert_eq!(sky.cell_of(cell_centre(&sky, c).unwrap()), Some(c));
            }
            assert!(cell_centre(&sky, 500).is_none());
        }
    }

    #[test]
    fn levels_colour_map() {
        let sky = SkyPartition::new(145, SkyVariant::EqualSolidAngle).unwrap();
        // Assets 0, 1, 2 at levels 0, 1, 2; asset 3 has no level (counts as 0).
        let levels = [0u8, 1, 2];
        let kinds = [AssetKind::Roof; 4];
        let mut cells = vec![CellClass::Sky; 145];
        for (c, cell) in cells.iter_mut().enumerate().skip(85) {
            *cell = CellClass::Hit((c % 4) as u32);
        }
        let doc = fisheye_svg(
            &sky,
            &cells,
            &kinds,
            Some(&levels),
            &FisheyeOptions::default(),
        )
        .to_string();
        for (colour, label) in LEVEL_COLOURS {
            assert!(doc.contains(colour), "{colour}");
            assert!(doc.contains(label), "{label}");
        }
        assert!(!doc.contains(HitClass::Roof.colour()));
        let shares = cell_shares(&cells, &kinds, Some(&levels));
        let get = |l: &str| shares.iter().find(|s| s.0 == l).map_or(0.0, |s| s.1);
        assert!((get("sky") - 85.0 / 145.0).abs() < 1e-12);
        // Cells 85..145: c % 4 == 0 or 3 -> level 0.
        let l0 = (85..145).filter(|c| c % 4 == 0 || c % 4 == 3).count() as f64;
        assert!((get("level 0 (left out)") - l0 / 145.0).abs() < 1e-12);
        let l2 = (85..145).filter(|c| c % 4 == 2).count() as f64;
        assert!((get("level 2 (full detail)") - l2 / 145.0).abs() < 1e-12);
        // By kind: all roof.
        let shares = cell_shares(&cells, &kinds, None);
        assert!((shares.iter().find(|s| s.0 == "roof").unwrap().1 - 60.0 / 145.0).abs() < 1e-12);
    }

    #[test]
    fn sun_paths_barcelona() {
        let site = Site::new(41.39, 2.17);
        let paths = sun_paths(&site, 2025).unwrap();
        assert_eq!(paths.len(), 3 + 17);
        // June solstice noon altitude ~ 90 - 41.39 + 23.44 = 72 degrees.
        let top = paths[0].points.iter().map(|p| p.z).fold(f64::MIN, f64::max);
        assert!(
            (top.asin().to_degrees() - 72.05).abs() < 0.3,
            "{}",
            top.asin().to_degrees()
        );
        // The 12 h line points south.
        let noon = paths.iter().find(|p| p.label == "12h").unwrap();
        assert!(noon.points.iter().all(|p| p.y < 0.0 && p.x.abs() < 0.1));
    }
}
