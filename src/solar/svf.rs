//! Sky view factor and sky exposure of a point, by casting the sky bundles (paper 3).
//!
//! * **SVF** (cosine-weighted to the surface normal `n`): the
//!   [`SkyVariant::EqualProjectedArea`] bundle is turned into `n`'s frame
//!   ([`Frame::from_normal`]); each of its `N` rays has the weight `1/N` of the
//!   cosine-weighted hemisphere in front of the surface. SVF = fraction of those rays that
//!   point above the horizon (world `z > 0`) and are not blocked. An unobstructed
//!   horizontal point gets 1, an unobstructed vertical surface 0.5.
//! * **Sky exposure** (unweighted): the [`SkyVariant::EqualSolidAngle`] bundle in the
//!   world frame covers the sky hemisphere (`z > 0`); sky exposure = fraction of its rays
//!   that are in front of the surface (`dot(n, d) > 0`) and not blocked, i.e. the
//!   solid-angle fraction of the *whole* sky hemisphere that the surface sees. A horizontal
//!   point sees at most 1, an unobstructed vertical surface 0.5, and in general a tilted
//!   unobstructed surface `1 - tilt/pi`.
//!
//! `normal = None`, or a zero / non-finite normal, means a horizontal surface facing up.
//!
//! # Example
//! ```rust
//! use glam::DVec3;
//! use skylod::solar::{SkyBundles, sky_view};
//! let bundles = SkyBundles::new(2_000, 1)?;
//! // A ground point next to an infinitely long wall of height 10 m, 10 m to the east.
//! let wall = |o: DVec3, d: DVec3| d.x > 0.0 && o.z + (10.0 - o.x) / d.x * d.z < 10.0;
//! let v = sky_view(DVec3::ZERO, None, &bundles, wall);
//! let beta = std::f64::consts::FRAC_PI_4;
//! assert!((v.svf - (1.0 + beta.cos()) / 2.0).abs() < 0.01);
//! # Ok::<(), skylod::solar::SkyError>(())
//! ```

use crate::model::Poi;
use crate::solar::sky::{Frame, SkyError, SkyPartition, SkyVariant};
use glam::DVec3;
use rayon::prelude::*;

/// Constant mixed into the seed of the solid-angle bundle so that the two bundles are
/// jittered independently.
const SOLID_SEED_SALT: u64 = 0x9E37_79B9_7F4A_7C15;

/// The two sky bundles with their local ray directions, prepared once and reused for
/// every point of interest.
#[derive(Debug, Clone)]
pub struct SkyBundles {
    projected: SkyPartition,
    solid: SkyPartition,
    projected_dirs: Vec<DVec3>,
    solid_dirs: Vec<DVec3>,
    seed: u64,
}

/// Default rays per bundle (cells of each Beckers partition), as `skylod svf`.
pub const DEFAULT_SKY_RAYS: usize = 10_000;
/// Default seed of the ray jitter, as `skylod svf`.
pub const DEFAULT_SKY_SEED: u64 = 1;

impl Default for SkyBundles {
    /// [`DEFAULT_SKY_RAYS`] per bundle, seed [`DEFAULT_SKY_SEED`] (what `skylod svf` uses).
    fn default() -> Self {
        match SkyBundles::new(DEFAULT_SKY_RAYS, DEFAULT_SKY_SEED) {
            Ok(b) => b,
            // a constant ray count within 1..=MAX_CELLS (tested)
            Err(_) => unreachable!("the default ray count is valid"),
        }
    }
}

impl SkyBundles {
    /// Both bundles with `n` cells each, jittered from `seed` (the projected-area bundle
    /// with `seed`, the solid-angle bundle with `seed ^ 0x9E3779B97F4A7C15`).
    ///
    /// # Errors
    /// As [`SkyPartition::new`].
    pub fn new(n: usize, seed: u64) -> Result<SkyBundles, SkyError> {
        let projected = SkyPartition::new(n, SkyVariant::EqualProjectedArea)?;
        let solid = SkyPartition::new(n, SkyVariant::EqualSolidAngle)?;
        let projected_dirs = projected.sample(seed);
        let solid_dirs = solid.sample(seed ^ SOLID_SEED_SALT);
        Ok(SkyBundles {
            projected,
            solid,
            projected_dirs,
            solid_dirs,
            seed,
        })
    }

    /// The seed the bundles were made with.
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// The same partitions jittered from another seed (as [`SkyBundles::new`] with it).
    pub fn reseeded(&self, seed: u64) -> SkyBundles {
        SkyBundles {
            projected_dirs: self.projected.sample(seed),
            solid_dirs: self.solid.sample(seed ^ SOLID_SEED_SALT),
            projected: self.projected.clone(),
            solid: self.solid.clone(),
            seed,
        }
    }

    /// The bundles of one POI: jittered from [`Poi::ray_seed`] of this bundle's seed, so a
    /// POI gets the same rays whichever other POIs are traced.
    pub fn for_poi(&self, poi: &Poi) -> SkyBundles {
        self.reseeded(poi.ray_seed(self.seed))
    }

    /// The local directions of the projected-area bundle of one POI: those of
    /// [`SkyBundles::for_poi`], without sampling its solid-angle bundle.
    pub fn projected_dirs_for(&self, poi: &Poi) -> Vec<DVec3> {
        self.projected.sample(poi.ray_seed(self.seed))
    }

    /// Number of rays per bundle.
    pub fn len(&self) -> usize {
        self.projected_dirs.len()
    }

    /// Whether the bundles are empty (never: a partition has at least one cell).
    pub fn is_empty(&self) -> bool {
        self.projected_dirs.is_empty()
    }

    /// The equal projected-area partition (SVF).
    pub fn projected(&self) -> &SkyPartition {
        &self.projected
    }

    /// The equal solid-angle partition (sky exposure).
    pub fn solid(&self) -> &SkyPartition {
        &self.solid
    }

    /// Local ray directions of the projected-area bundle (around local +z).
    pub fn projected_dirs(&self) -> &[DVec3] {
        &self.projected_dirs
    }

    /// Ray directions of the solid-angle bundle (world frame, upper hemisphere).
    pub fn solid_dirs(&self) -> &[DVec3] {
        &self.solid_dirs
    }
}

/// Result of [`sky_view`].
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct SkyView {
    /// Sky view factor, cosine-weighted to the normal, in `[0, 1]`.
    pub svf: f64,
    /// Unweighted solid-angle fraction of the sky hemisphere seen, in `[0, 1]`.
    pub sky_exposure: f64,
    /// Number of rays handed to the occlusion predicate (rays below the horizon or behind
    /// the surface are not cast).
    pub rays: usize,
}

/// SVF and sky exposure at `poi` for a surface with `normal` (see the module docs).
/// `blocked(origin, dir)` returns true when the ray from `origin` along the unit `dir`
/// hits the scene.
pub fn sky_view(
    poi: DVec3,
    normal: Option<DVec3>,
    bundles: &SkyBundles,
    blocked: impl Fn(DVec3, DVec3) -> bool + Sync,
) -> SkyView {
    let n = normal.and_then(|n| n.try_normalize()).unwrap_or(DVec3::Z);
    let frame = Frame::from_normal(n);
    // (rays cast, rays reaching the sky) over one bundle, in parallel chunks; counts are
    // sums, so the result does not depend on the thread count.
    let count = |dirs: &[DVec3], world: &(dyn Fn(DVec3) -> Option<DVec3> + Sync)| {
        dirs.par_iter()
            .with_min_len(1024)
            .filter_map(|&d| world(d))
            .map(|d| (1usize, usize::from(!blocked(poi, d))))
            .reduce(|| (0, 0), |a, b| (a.0 + b.0, a.1 + b.1))
    };
    let (rays_svf, sky) = count(&bundles.projected_dirs, &|local| {
        let d = frame.to_world(local);
        (d.z > 0.0).then_some(d)
    });
    let (rays_exp, exposed) = count(&bundles.solid_dirs, &|d| (n.dot(d) > 0.0).then_some(d));
    let rays = rays_svf + rays_exp;
    let total = bundles.len().max(1) as f64;
    SkyView {
        svf: sky as f64 / total,
        sky_exposure: exposed as f64 / total,
        rays,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{FRAC_PI_2, PI};

    #[test]
    fn a_poi_s_projected_dirs_are_those_of_its_bundles() {
        let b = SkyBundles::new(500, 3).unwrap();
        for id in ["a", "B4_2_1_o6", ""] {
            let poi = Poi {
                id: id.into(),
                position: DVec3::new(1.0, 2.0, 3.0),
                normal: None,
            };
            let dirs = b.projected_dirs_for(&poi);
            assert_eq!(dirs, b.for_poi(&poi).projected_dirs());
            assert_ne!(dirs, b.projected_dirs());
        }
    }

    #[test]
    fn default_bundles_are_the_cli_s() {
        let d = SkyBundles::default();
        let n = SkyBundles::new(10_000, 1).unwrap();
        assert_eq!(d.seed(), 1);
        assert_eq!(d.projected_dirs, n.projected_dirs);
        assert_eq!(d.solid_dirs, n.solid_dirs);
    }

    /// Infinite (along y) vertical wall in the plane x = `x`, from z = 0 up to `h`.
    /// Blocks a ray that reaches the plane (strictly ahead) below the wall top.
    fn wall_hit(o: DVec3, d: DVec3, x: f64, h: f64) -> bool {
        if d.x == 0.0 {
            return false;
        }
        let t = (x - o.x) / d.x;
        t > 1e-9 && {
            let z = o.z + t * d.z;
            (0.0..h).contains(&z)
        }
    }

    fn bundles() -> SkyBundles {
        SkyBundles::new(10_000, 12345).unwrap()
    }

    const TOL: f64 = 0.005;

    #[test]
    fn unobstructed() {
        let b = bundles();
        let free = |_: DVec3, _: DVec3| false;
        let h = sky_view(DVec3::ZERO, None, &b, free);
        assert_eq!(h.svf, 1.0);
        assert_eq!(h.sky_exposure, 1.0);
        assert_eq!(h.rays, 20_000);
        for n in [DVec3::X, DVec3::new(0.3, -1.0, 0.0), DVec3::NEG_Y] {
            let v = sky_view(DVec3::ZERO, Some(n), &b, free);
            assert!((v.svf - 0.5).abs() < TOL, "{n} {v:?}");
            assert!((v.sky_exposure - 0.5).abs() < TOL, "{n} {v:?}");
        }
        // Tilted 60 degrees: SVF (1 + cos t)/2, exposure 1 - t/pi.
        let t = 60f64.to_radians();
        let n = DVec3::new(t.sin(), 0.0, t.cos());
        let v = sky_view(DVec3::ZERO, Some(n), &b, free);
        assert!((v.svf - (1.0 + t.cos()) / 2.0).abs() < TOL, "{v:?}");
        assert!((v.sky_exposure - (1.0 - t / PI)).abs() < TOL, "{v:?}");
        // Facing down: sees nothing.
        let down = sky_view(DVec3::ZERO, Some(DVec3::NEG_Z), &b, free);
        assert_eq!((down.svf, down.sky_exposure), (0.0, 0.0));
        // Zero normal is treated as horizontal.
        assert_eq!(sky_view(DVec3::ZERO, Some(DVec3::ZERO), &b, free), h);
    }

    #[test]
    fn canyon_floor_centre() {
        let b = bundles();
        let w = 10.0;
        for hw in [0.5, 1.0, 2.0] {
            let h = hw * w;
            let canyon =
                |o: DVec3, d: DVec3| wall_hit(o, d, -w / 2.0, h) || wall_hit(o, d, w / 2.0, h);
            let v = sky_view(DVec3::ZERO, None, &b, canyon);
            let beta = (2.0 * h / w).atan();
            assert!((v.svf - beta.cos()).abs() < TOL, "H/W {hw}: {v:?}");
            let exp = 1.0 - 2.0 * beta / PI;
            assert!((v.sky_exposure - exp).abs() < TOL, "H/W {hw}: {v:?}");
        }
    }

    #[test]
    fn single_wall_at_distance() {
        let b = bundles();
        for (h, dist) in [(10.0, 10.0), (30.0, 10.0), (5.0, 20.0)] {
            let wall = |o: DVec3, d: DVec3| wall_hit(o, d, dist, h);
            let poi = DVec3::new(0.0, 3.0, 0.0);
            let v = sky_view(poi, Some(DVec3::Z), &b, wall);
            let beta = f64::atan(h / dist);
            assert!((v.svf - (1.0 + beta.cos()) / 2.0).abs() < TOL, "{v:?}");
            // Exposure: half hemisphere free + wedge of dihedral pi/2 - beta.
            let exp = 0.5 + (FRAC_PI_2 - beta) / PI;
            assert!((v.sky_exposure - exp).abs() < TOL, "{v:?}");
        }
    }

    #[test]
    fn canyon_wall_base_facing_across() {
        let b = bundles();
        let (w, h) = (12.0, 12.0);
        let canyon = |o: DVec3, d: DVec3| wall_hit(o, d, -w / 2.0, h) || wall_hit(o, d, w / 2.0, h);
        let poi = DVec3::new(-w / 2.0, 0.0, 0.0);
        let v = sky_view(poi, Some(DVec3::X), &b, canyon);
        let expect = (1.0 - h / (h * h + w * w).sqrt()) / 2.0;
        assert!((v.svf - expect).abs() < TOL, "{v:?} vs {expect}");
        // Exposure: wedge between the vertical wall plane and the line to the top of the
        // opposite wall, dihedral pi/2 - atan(H/W), over the hemisphere's 2*pi.
        let exp = (FRAC_PI_2 - (h / w).atan()) / PI;
        assert!((v.sky_exposure - exp).abs() < TOL, "{v:?} vs {exp}");
    }

    #[test]
    fn reusable_and_deterministic() {
        let a = SkyBundles::new(500, 9).unwrap();
        let b = SkyBundles::new(500, 9).unwrap();
        assert_eq!(a.projected_dirs(), b.projected_dirs());
        assert_eq!(a.solid_dirs(), b.solid_dirs());
        assert_ne!(a.projected_dirs(), a.solid_dirs());
        let wall = |o: DVec3, d: DVec3| wall_hit(o, d, 4.0, 7.0);
        let p = DVec3::new(1.0, 2.0, 0.5);
        assert_eq!(sky_view(p, None, &a, wall), sky_view(p, None, &b, wall));
        assert!(SkyBundles::new(0, 1).is_err());
    }
}
