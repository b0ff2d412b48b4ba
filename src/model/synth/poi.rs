//! Facade points of interest of the synthetic district: window centres on the lower floors
//! of the central block, at its chamfered corners and mid-street, like the paper's corner
//! facade windows. Each POI sits 5 cm in front of the wall plane on the pane's axis (the
//! pane itself is recessed; the rough model closes openings at the wall plane, so a point
//! inside the recess would be inside the rough building) and carries the wall's outward
//! normal. CSV columns: `id,x,y,z,nx,ny,nz` (see `schemas/pois.schema.json`).
//!
//! # Example
//!
//! ```rust
//! use skylod::model::synth::{pois, write_pois_csv, Preset};
//!
//! let p = pois(&Preset::Paper.defaults());
//! assert!(p.len() >= 4 && p.len() <= 8);
//! let mut csv = Vec::new();
//! write_pois_csv(&p, &mut csv).unwrap();
//! let text = String::from_utf8(csv).unwrap();
//! assert!(text.starts_with("id,x,y,z,nx,ny,nz\n"));
//! assert_eq!(text.lines().count(), p.len() + 1);
//! ```

use super::building::{build, BuildingGeom, OpeningKind};
use super::gml::{building_id, opening_id, push_num};
use super::layout::{block_lots, LotEdge};
use super::{SynthError, SynthOptions};
use glam::DVec3;
use std::io::Write;

/// Distance of a POI in front of the wall plane, metres.
pub const POI_OFFSET: f64 = 0.05;

/// A point of interest on a facade.
#[derive(Debug, Clone, PartialEq)]
pub struct SynthPoi {
    /// The gml:id of the window it belongs to.
    pub id: String,
    /// Position (EPSG:25831 metres).
    pub position: DVec3,
    /// Outward unit normal of the facade.
    pub normal: DVec3,
}

impl From<SynthPoi> for crate::model::Poi {
    /// The generic POI of the analysis stages (with its normal).
    fn from(p: SynthPoi) -> Self {
        crate::model::Poi {
            id: p.id,
            position: p.position,
            normal: Some(p.normal),
        }
    }
}

/// POIs of the district: in the central block, the central first-floor street window of
/// every chamfer (corner) building, plus one such window mid-street on the south and east
/// sides (every listed side lot when the preset limits the buildings per block).
pub fn pois(opts: &SynthOptions) -> Vec<SynthPoi> {
    let mut out = Vec::new();
    if opts.lod < 3 || opts.blocks_x == 0 || opts.blocks_y == 0 {
        return out;
    }
    let (bx, by) = (opts.blocks_x / 2, opts.blocks_y / 2);
    let mut lots = Vec::new();
    block_lots(opts.seed, bx, by, &mut lots);
    let limit = opts.preset.buildings_per_block();
    let mut g = BuildingGeom::default();
    for lot in lots.iter().take(limit.unwrap_or(usize::MAX)) {
        let wanted = match lot.edge {
            LotEdge::Chamfer(_) => true,
            LotEdge::Side(side, j, n) => limit.is_some() || (side <= 1 && j == n / 2),
        };
        if !wanted {
            continue;
        }
        build(lot, opts, &mut g);
        let bid = building_id(lot);
        let mid = lot.o0 + (lot.o1 - lot.o0) * 0.5;
        let best = g
            .openings
            .iter()
            .enumerate()
            .filter(|(_, o)| o.street && o.floor == 1 && o.kind == OpeningKind::Window)
            .min_by(|(_, a), (_, b)| {
                let da = (a.centre.truncate() - mid).length();
                let db = (b.centre.truncate() - mid).length();
                da.total_cmp(&db)
            });
        if let Some((k, o)) = best {
            out.push(SynthPoi {
                id: opening_id(&bid, k),
                position: o.centre + o.normal * (o.recess + POI_OFFSET),
                normal: o.normal,
            });
        }
    }
    out
}

/// Write POIs as CSV with header `id,x,y,z,nx,ny,nz` (positions 3 decimals, normals 6).
pub fn write_pois_csv<W: Write>(pois: &[SynthPoi], mut out: W) -> Result<(), SynthError> {
    let mut buf = Vec::with_capacity(64 * (pois.len() + 1));
    buf.extend_from_slice(b"id,x,y,z,nx,ny,nz\n");
    for p in pois {
        buf.extend_from_slice(p.id.as_bytes());
        for v in [p.position.x, p.position.y, p.position.z] {
            buf.push(b',');
            push_num(&mut buf, v);
        }
        for v in [p.normal.x, p.normal.y, p.normal.z] {
            buf.push(b',');
            // 6 decimals, "-0.000000" avoided
            let v = if v.abs() < 5e-7 { 0.0 } else { v };
            buf.extend_from_slice(format!("{v:.6}").as_bytes());
        }
        buf.push(b'\n');
    }
    out.write_all(&buf)?;
    out.flush()?;
    Ok(())
}

/// Where the POIs of a district written to `out` go by default: beside it, named after it
/// (`district.gml` / `district.gml.gz` → `district.pois.csv`).
///
/// ```
/// use skylod::model::synth::pois_path;
/// use std::path::{Path, PathBuf};
/// assert_eq!(pois_path(Path::new("a/d.gml")), PathBuf::from("a/d.pois.csv"));
/// assert_eq!(pois_path(Path::new("d.gml.gz")), PathBuf::from("d.pois.csv"));
/// assert_eq!(pois_path(Path::new("d")), PathBuf::from("d.pois.csv"));
/// ```
pub fn pois_path(out: &std::path::Path) -> std::path::PathBuf {
    let name = out
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let stem = name
        .strip_suffix(".gz")
        .unwrap_or(&name)
        .trim_end_matches(".gml")
        .trim_end_matches(".xml")
        .to_string();
    out.with_file_name(format!("{stem}.pois.csv"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::synth::Preset;

    #[test]
    fn paper_pois_are_corner_and_street_windows_in_front_of_walls() {
        let opts = Preset::Paper.defaults();
        let p = pois(&opts);
        assert_eq!(p.len(), 6);
        for poi in &p {
            assert!((poi.normal.length() - 1.0).abs() < 1e-9);
            assert_eq!(poi.normal.z, 0.0);
            // first floor: between 3.1 and 6.2 m above ground
            let h = poi.position.z - crate::model::synth::layout::GROUND_Z;
            assert!(h > 3.1 && h < 6.2, "{h}");
            assert!(poi.id.contains("_o"));
        }
        // four of them face the diagonal chamfers
        let diagonal = p
            .iter()
            .filter(|q| (q.normal.x.abs() - q.normal.y.abs()).abs() < 1e-9)
            .count();
        assert_eq!(diagonal, 4);
    }

    #[test]
    fn pois_follow_the_seed() {
        let mut o = Preset::Paper.defaults();
        let a = pois(&o);
        o.seed += 1;
        assert_ne!(a, pois(&o));
    }
}
