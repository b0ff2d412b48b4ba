//! Rings and polygons: rings closed, deduplicated and checked, polygons oriented and pushed
//! into the geometry arena.

use super::state::{Frame, Parser, Part};
use crate::model::Polygon;
use compact_str::CompactString;
use glam::DVec3;

impl Parser<'_> {
    pub(super) fn finish_ring(&mut self, exterior: bool, _frame: &Frame) {
        // the points are parsed into a reused buffer; the polygon gets an exact-size copy
        let mut ring = std::mem::take(&mut self.ring);
        let closed = ring.len() >= 2 && ring.first() == ring.last();
        if closed {
            ring.pop();
        } else if ring.len() >= 3 {
            self.warn("ring is not closed (first point differs from last): closed implicitly");
        }
        // drop consecutive duplicates
        ring.dedup();
        while ring.len() > 1 && ring.first() == ring.last() {
            ring.pop();
        }
        let valid = ring.len() >= 3;
        if valid && zero_area(&ring) {
            self.warn(format!(
                "{} ring has zero area (collinear points or a ring folding back on itself)",
                if exterior { "exterior" } else { "interior" }
            ));
        }
        if !valid {
            self.warn(format!(
                "ring with {} distinct point(s), at least 3 needed: {}",
                ring.len(),
                if exterior {
                    "polygon dropped"
                } else {
                    "hole dropped"
                }
            ));
        }
        if let Some(p) = self.poly.as_mut() {
            if exterior {
                if valid {
                    p.exterior = Some(ring.as_slice().to_vec());
                } else {
                    p.invalid = true;
                }
            } else if valid {
                p.interiors.push(ring.as_slice().to_vec());
            }
        }
        ring.clear();
        self.ring = ring;
    }

    /// Push the polygon being built; false when it was dropped.
    pub(super) fn finish_polygon(&mut self, id: Option<CompactString>) -> bool {
        let Some(p) = self.poly.take() else {
            return false;
        };
        if p.invalid {
            return false;
        }
        let Some(mut exterior) = p.exterior else {
            self.warn("polygon without exterior ring dropped");
            return false;
        };
        let mut interiors = p.interiors;
        if self.flips % 2 == 1 {
            exterior.reverse();
            interiors.iter_mut().for_each(|r| r.reverse());
        }
        let idx = self.polys.len() as u32;
        self.polys.push(if interiors.is_empty() {
            // the exterior was copied at its exact size: moved, not copied again
            Polygon::new(exterior).with_id(id)
        } else {
            Polygon::from_rings(id, &exterior, &interiors)
        });
        self.parts.push(Part::Poly(idx));
        true
    }
}

/// True when a ring (at least 3 distinct points) encloses no area: its Newell normal,
/// computed relative to the first point so that large offsets cancel, is negligible against
/// the ring's extent.
pub(super) fn zero_area(ring: &[DVec3]) -> bool {
    let Some(&o) = ring.first() else {
        return true;
    };
    let mut n = DVec3::ZERO;
    let mut extent2 = 0.0f64;
    let mut prev = DVec3::ZERO;
    for q in &ring[1..] {
        let d = *q - o;
        n += prev.cross(d);
        extent2 = extent2.max(d.length_squared());
        prev = d;
    }
    n.length() <= 1e-12 * extent2
}
