//! A point of interest: a position in the model's CRS, an optional surface normal, and the
//! two things every stage asks of it (where its rays start, how they are seeded). Plain data:
//! reading POIs (CSV, `--poi`) and checking them are [`crate::lod::poi`]'s.

use glam::DVec3;
use serde::Serialize;

/// A point of interest in the model's CRS, with an optional outward surface normal.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Poi {
    /// Identifier (CSV `id`, or `poi-N` for command-line points).
    pub id: String,
    /// Position in model coordinates.
    pub position: DVec3,
    /// Unit outward normal of the surface the point lies on; `None` for a free point
    /// (then the whole upper hemisphere counts and SVF is the horizontal one).
    pub normal: Option<DVec3>,
}

/// Distance (m) a ray origin is moved along the POI's normal, and the `tmin` used, so that
/// rays do not hit the surface the POI lies on.
pub const POI_OFFSET: f64 = 0.01;

impl Poi {
    /// A free point (no normal) `id` at `position` (`[x, y, z]`, the model's CRS).
    ///
    /// ```
    /// let p = skylod::Poi::at("w1", [430000.0, 4581000.0, 12.0]).facing([0.0, -2.0, 0.0]);
    /// assert_eq!(p.normal, Some(glam::DVec3::new(0.0, -1.0, 0.0)));
    /// ```
    pub fn at(id: impl Into<String>, position: [f64; 3]) -> Poi {
        Poi {
            id: id.into(),
            position: DVec3::from_array(position),
            normal: None,
        }
    }

    /// The same point on a surface facing `normal` (normalised; a zero or non-finite normal
    /// is kept as given and refused by [`crate::lod::poi::check_poi`]'s callers, never traced).
    pub fn facing(mut self, normal: [f64; 3]) -> Poi {
        let n = DVec3::from_array(normal);
        self.normal = Some(n.try_normalize().unwrap_or(n));
        self
    }

    /// Where its rays start: moved [`POI_OFFSET`] along its normal when it has one.
    pub fn ray_origin(&self) -> DVec3 {
        match self.normal {
            Some(n) => self.position + n * POI_OFFSET,
            None => self.position,
        }
    }

    /// The seed of this POI's rays: `seed` mixed with the POI's id (FNV-1a, then
    /// SplitMix64), never with its place in a list, so its result is the same whichever
    /// POIs are traced with it (`--shard`). The id (unique in a run) and not the
    /// coordinates: the same point in a translated copy of the scene, or in feet instead of
    /// metres, keeps its rays.
    ///
    /// ```
    /// use glam::DVec3;
    /// use skylod::model::Poi;
    /// let p = Poi { id: "a".into(), position: DVec3::new(1.0, 2.0, 3.0), normal: None };
    /// let q = Poi { id: "b".into(), ..p.clone() };
    /// let moved = Poi { position: DVec3::new(5.0, 0.0, 0.0), ..p.clone() };
    /// assert_eq!(p.ray_seed(1), moved.ray_seed(1));
    /// assert_ne!(p.ray_seed(1), q.ray_seed(1));
    /// assert_ne!(p.ray_seed(1), p.ray_seed(2));
    /// ```
    pub fn ray_seed(&self, seed: u64) -> u64 {
        let mut h: u64 = 0xCBF2_9CE4_8422_2325;
        for &b in self.id.as_bytes() {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x0100_0000_01B3);
        }
        splitmix64(h ^ splitmix64(seed))
    }
}

/// One step of SplitMix64: a bijective mix of all 64 bits.
fn splitmix64(x: u64) -> u64 {
    let mut z = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}
