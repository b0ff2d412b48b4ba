//! Sky bundle: Beckers & Beckers' equal-area partition of the hemisphere (paper 4.4).
//!
//! The hemisphere is cut into concentric rings around the zenith; ring `i` is the set of
//! directions with zenith angle in `[theta_min, theta_max]`, split into `cells` equal
//! azimuth sectors. Two measures are supported (see [`SkyVariant`]):
//!
//! * [`SkyVariant::EqualSolidAngle`]: every cell has the solid angle `2*pi/N`. The cap of
//!   zenith angle `theta` has measure `N * (1 - cos theta)` cells.
//! * [`SkyVariant::EqualProjectedArea`]: every cell has the area `pi/N` on the unit disk
//!   (`r = sin theta`, the Nusselt analog), i.e. equal cosine-weighted solid angle. The
//!   cap of zenith angle `theta` holds `N * sin^2 theta` cells.
//!
//! Construction (from the horizon inward, `DESIGN.md`): start with the whole hemisphere,
//! `S_0 = N` cells. A ring has the width `w` of a typical cell (`sqrt(2*pi/N)` radians in
//! `theta` for equal solid angle, `sqrt(pi/N)` in `r = sin theta` for equal projected
//! area). The next inner cap edge is moved inward by `w`, its cell count is
//! `S_i = round(S_{i-1} * (m(edge) / m(previous edge)))` with `m` the variant's cap measure,
//! and the edge is then re-adjusted so that the cap holds exactly `S_i` cells. The ring
//! between two edges holds `S_{i-1} - S_i` cells. Once `S_i` drops below 7 the remaining
//! cap becomes a single polar cell (`S_i = 1`).
//!
//! Azimuth follows the crate convention: measured from local +y ("north") clockwise
//! toward local +x ("east"); the first cell of each ring starts at azimuth 0.
//! Cells are numbered from the zenith outward, ring by ring, by increasing azimuth.
//!
//! # Example
//! ```rust
//! use skylod::solar::{SkyPartition, SkyVariant};
//! let sky = SkyPartition::new(145, SkyVariant::EqualSolidAngle)?;
//! let cells: Vec<usize> = sky.rings().iter().map(|r| r.cells).collect();
//! assert_eq!(cells, vec![1, 7, 12, 18, 22, 26, 29, 30]);
//! let dirs = sky.sample(42);
//! assert_eq!(dirs.len(), 145);
//! assert!(dirs.iter().enumerate().all(|(i, d)| sky.cell_of(*d) == Some(i)));
//! # Ok::<(), skylod::solar::SkyError>(())
//! ```

use glam::DVec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::{FRAC_PI_2, PI, TAU};

/// Largest accepted number of cells (memory guard: the sample vector of this size is 2.4 GB).
pub const MAX_CELLS: usize = 100_000_000;

/// Errors of the sky partition.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum SkyError {
    /// The number of cells was zero.
    #[error("sky partition needs at least one cell")]
    NoCells,
    /// The number of cells exceeded `MAX_CELLS`.
    #[error("sky partition with {0} cells exceeds the maximum of {MAX_CELLS}")]
    TooManyCells(usize),
}

/// The measure in which the cells of a [`SkyPartition`] are equal.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SkyVariant {
    /// Every cell covers the solid angle `2*pi/N` (uniform coverage of the sky vault).
    EqualSolidAngle,
    /// Every cell covers the area `pi/N` of the unit disk under the orthographic
    /// projection `r = sin theta` (equal cosine-weighted solid angle, Nusselt analog).
    EqualProjectedArea,
}

impl SkyVariant {
    /// Normalised cap measure of a cap with zenith angle `theta` (0 at the zenith, 1 for
    /// the hemisphere). Uses the half-angle form for precision near the zenith.
    fn cap_fraction(self, theta: f64) -> f64 {
        match self {
            SkyVariant::EqualSolidAngle => {
                let s = (0.5 * theta).sin();
                2.0 * s * s
            }
            SkyVariant::EqualProjectedArea => {
                let s = theta.sin();
                s * s
            }
        }
    }

    /// Inverse of [`Self::cap_fraction`] on `[0, 1]`.
    fn cap_theta(self, fraction: f64) -> f64 {
        let f = fraction.clamp(0.0, 1.0);
        match self {
            SkyVariant::EqualSolidAngle => 2.0 * (0.5 * f).sqrt().asin(),
            SkyVariant::EqualProjectedArea => f.sqrt().asin(),
        }
    }
}

/// One ring of the partition: zenith angles `[theta_min, theta_max]` split into `cells`
/// equal azimuth sectors.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ring {
    /// Inner edge (towards the zenith), radians. 0 for the polar cell.
    pub theta_min: f64,
    /// Outer edge (towards the horizon), radians. `pi/2` for the outermost ring.
    pub theta_max: f64,
    /// Number of cells in the ring.
    pub cells: usize,
    /// Index of the ring's first cell.
    pub first: usize,
}

/// Angular bounds of one cell: zenith angle and azimuth (clockwise from local +y), radians.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CellBounds {
    /// Inner zenith angle.
    pub theta_min: f64,
    /// Outer zenith angle.
    pub theta_max: f64,
    /// Start azimuth (inclusive).
    pub phi_min: f64,
    /// End azimuth (exclusive, at most `2*pi`).
    pub phi_max: f64,
}

/// Beckers & Beckers equal-area partition of the upper hemisphere (local +z up).
#[derive(Debug, Clone, PartialEq)]
pub struct SkyPartition {
    variant: SkyVariant,
    n: usize,
    rings: Vec<Ring>,
}

impl SkyPartition {
    /// Builds the partition with `n` cells.
    ///
    /// # Errors
    /// [`SkyError::NoCells`] for `n == 0`, [`SkyError::TooManyCells`] above `MAX_CELLS`.
    pub fn new(n: usize, variant: SkyVariant) -> Result<Self, SkyError> {
        if n == 0 {
            return Err(SkyError::NoCells);
        }
        if n > MAX_CELLS {
            return Err(SkyError::TooManyCells(n));
        }
        let nf = n as f64;
        // Ring width in the construction coordinate: theta (solid angle) or r (projected).
        let width = match variant {
            SkyVariant::EqualSolidAngle => (TAU / nf).sqrt(),
            SkyVariant::EqualProjectedArea => (PI / nf).sqrt(),
        };
        // Cap edges from the horizon inward: (cells in cap, theta of its edge).
        let mut caps: Vec<(usize, f64)> = vec![(n, FRAC_PI_2)];
        let mut s_prev = n;
        let mut theta_prev = FRAC_PI_2;
        while s_prev > 1 {
            let ratio = match variant {
                SkyVariant::EqualSolidAngle => {
                    let t = theta_prev - width;
                    if t <= 0.0 {
                        0.0
                    } else {
                        let a = (0.5 * t).sin() / (0.5 * theta_prev).sin();
                        a * a
                    }
                }
                SkyVariant::EqualProjectedArea => {
                    let r_prev = theta_prev.sin();
                    let r = r_prev - width;
                    if r <= 0.0 {
                        0.0
                    } else {
                        let a = r / r_prev;
                        a * a
                    }
                }
            };
            let rounded = (s_prev as f64 * ratio).round();
            // The ring must hold at least one cell; below 7 the cap is one polar cell.
            let mut s = if rounded.is_finite() && rounded >= 0.0 {
                (rounded as usize).min(s_prev - 1)
            } else {
                1
            };
            if s < 7 {
                s = 1;
            }
            let theta = variant.cap_theta(s as f64 / nf);
            caps.push((s, theta));
            s_prev = s;
            theta_prev = theta;
        }
        // Rings from the zenith outward.
        let mut rings = Vec::with_capacity(caps.len());
        rings.push(Ring {
            theta_min: 0.0,
            theta_max: caps.last().map_or(FRAC_PI_2, |c| c.1),
            cells: 1,
            first: 0,
        });
        let mut first = 1;
        for pair in caps.windows(2).rev() {
            let (outer, inner) = (pair[0], pair[1]);
            let cells = outer.0 - inner.0;
            rings.push(Ring {
                theta_min: inner.1,
                theta_max: outer.1,
                cells,
                first,
            });
            first += cells;
        }
        Ok(SkyPartition { variant, n, rings })
    }

    /// The variant (measure) of this partition.
    pub fn variant(&self) -> SkyVariant {
        self.variant
    }

    /// Number of cells `N`.
    pub fn len(&self) -> usize {
        self.n
    }

    /// Always false: a partition has at least one cell.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// The rings from the zenith outward (the first is the polar cell).
    pub fn rings(&self) -> &[Ring] {
        &self.rings
    }

    /// Index of the ring holding cell `cell`, or `None` if out of range.
    pub fn ring_of_cell(&self, cell: usize) -> Option<usize> {
        if cell >= self.n {
            return None;
        }
        // Last ring whose first cell is <= cell.
        Some(self.rings.partition_point(|r| r.first <= cell) - 1)
    }

    /// Angular bounds of cell `cell`, or `None` if out of range.
    pub fn cell_bounds(&self, cell: usize) -> Option<CellBounds> {
        let ring = self.rings.get(self.ring_of_cell(cell)?)?;
        let j = (cell - ring.first) as f64;
        let k = ring.cells as f64;
        Some(CellBounds {
            theta_min: ring.theta_min,
            theta_max: ring.theta_max,
            phi_min: TAU * j / k,
            phi_max: TAU * (j + 1.0) / k,
        })
    }

    /// Solid angle of cell `cell` in steradians (computed from its bounds), or `None`.
    pub fn cell_solid_angle(&self, cell: usize) -> Option<f64> {
        let b = self.cell_bounds(cell)?;
        let cap = |t: f64| {
            let s = (0.5 * t).sin();
            2.0 * s * s
        };
        Some((cap(b.theta_max) - cap(b.theta_min)) * (b.phi_max - b.phi_min))
    }

    /// Projected (cosine-weighted) area of cell `cell` on the unit disk, `r = sin theta`
    /// (computed from its bounds), or `None`. The whole hemisphere has `pi`.
    pub fn cell_projected_area(&self, cell: usize) -> Option<f64> {
        let b = self.cell_bounds(cell)?;
        let cap = |t: f64| {
            let s = t.sin();
            s * s
        };
        Some(0.5 * (cap(b.theta_max) - cap(b.theta_min)) * (b.phi_max - b.phi_min))
    }

    /// Weight of a cell in the variant's measure, normalised so that all cells sum to 1:
    /// exactly `1/N` by construction.
    pub fn cell_weight(&self) -> f64 {
        1.0 / self.n as f64
    }

    /// Typical angular size of a cell in radians: `sqrt(2*pi/N)`, the side of a square
    /// with the mean solid angle of a cell (the same for both variants).
    pub fn angular_size(&self) -> f64 {
        (TAU / self.n as f64).sqrt()
    }

    /// The cell holding the local direction `dir` (need not be normalised), or `None`
    /// below the horizon (`z < 0`) or for a zero / non-finite vector. Directions on the
    /// horizon (`z == 0`) belong to the outermost ring.
    pub fn cell_of(&self, dir: DVec3) -> Option<usize> {
        if !dir.is_finite() || dir.z < 0.0 {
            return None;
        }
        let horizontal = dir.x.hypot(dir.y);
        if horizontal == 0.0 && dir.z == 0.0 {
            return None;
        }
        let theta = horizontal.atan2(dir.z);
        // First ring whose outer edge is >= theta.
        let ri = self
            .rings
            .partition_point(|r| r.theta_max < theta)
            .min(self.rings.len() - 1);
        let ring = self.rings.get(ri)?;
        let mut phi = dir.x.atan2(dir.y);
        if phi < 0.0 {
            phi += TAU;
        }
        let k = ring.cells;
        let j = ((phi / TAU * k as f64).floor() as usize).min(k - 1);
        Some(ring.first + j)
    }

    /// One local direction per cell (index = cell), jittered uniformly inside the cell in
    /// the variant's measure (solid angle or projected area), from a ChaCha8 RNG seeded
    /// with `seed`. Samples keep a relative margin of `1e-9` of the cell's extent from its
    /// edges so that rounding never moves one into a neighbour.
    pub fn sample(&self, seed: u64) -> Vec<DVec3> {
        const MARGIN: f64 = 1e-9;
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut out = Vec::with_capacity(self.n);
        for ring in &self.rings {
            let m0 = self.variant.cap_fraction(ring.theta_min);
            let m1 = self.variant.cap_fraction(ring.theta_max);
            let k = ring.cells as f64;
            for j in 0..ring.cells {
                let u: f64 = rng.random::<f64>() * (1.0 - 2.0 * MARGIN) + MARGIN;
                let v: f64 = rng.random::<f64>() * (1.0 - 2.0 * MARGIN) + MARGIN;
                let theta = if ring.first == 0 {
                    // Polar cell: theta from 0, no inner edge to keep away from.
                    self.variant.cap_theta(m1 * u)
                } else {
                    self.variant.cap_theta(m0 + (m1 - m0) * u)
                };
                let phi = TAU * (j as f64 + v) / k;
                let (st, ct) = theta.sin_cos();
                let (sp, cp) = phi.sin_cos();
                out.push(DVec3::new(st * sp, st * cp, ct));
            }
        }
        out
    }
}

/// An orthonormal basis with a given normal as local +z, used to turn the hemisphere
/// around a surface normal.
///
/// The tangent is chosen deterministically: local +x is `normalize(Z x n)` (horizontal),
/// so local +y points "up the surface"; for an (almost) horizontal surface
/// (`|n.z| >= 0.999`) local +x is `normalize(Y x n)`, which for `n = +z` is the identity
/// (local azimuth = world azimuth).
///
/// # Example
/// ```rust
/// use glam::DVec3;
/// use skylod::solar::Frame;
/// let f = Frame::from_normal(DVec3::new(0.0, -1.0, 0.0)); // a south-facing wall
/// assert!((f.to_world(DVec3::Z) - DVec3::new(0.0, -1.0, 0.0)).length() < 1e-12);
/// assert!((f.to_world(DVec3::Y) - DVec3::Z).length() < 1e-12);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    /// Local +x in world coordinates.
    pub x: DVec3,
    /// Local +y in world coordinates.
    pub y: DVec3,
    /// Local +z (the normal) in world coordinates.
    pub z: DVec3,
}

impl Frame {
    /// The world frame (x east, y north, z up).
    pub const IDENTITY: Frame = Frame {
        x: DVec3::X,
        y: DVec3::Y,
        z: DVec3::Z,
    };

    /// Frame with `normal` (normalised here) as local +z. A zero or non-finite normal
    /// gives [`Frame::IDENTITY`].
    pub fn from_normal(normal: DVec3) -> Frame {
        let Some(n) = normal.try_normalize() else {
            return Frame::IDENTITY;
        };
        let helper = if n.z.abs() < 0.999 {
            DVec3::Z
        } else {
            DVec3::Y
        };
        let x = helper.cross(n).normalize();
        let y = n.cross(x);
        Frame { x, y, z: n }
    }

    /// Local direction to world coordinates.
    #[inline]
    pub fn to_world(&self, local: DVec3) -> DVec3 {
        self.x * local.x + self.y * local.y + self.z * local.z
    }

    /// World direction to local coordinates.
    #[inline]
    pub fn to_local(&self, world: DVec3) -> DVec3 {
        DVec3::new(world.dot(self.x), world.dot(self.y), world.dot(self.z))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const VARIANTS: [SkyVariant; 2] = [SkyVariant::EqualSolidAngle, SkyVariant::EqualProjectedArea];

    #[test]
    fn n145_matches_beckers() {
        let sky = SkyPartition::new(145, SkyVariant::EqualSolidAngle).unwrap();
        let cells: Vec<usize> = sky.rings().iter().map(|r| r.cells).collect();
        assert_eq!(cells, vec![1, 7, 12, 18, 22, 26, 29, 30]);
        let edges = [6.73, 19.12, 30.45, 42.44, 54.11, 65.99, 78.06, 90.0];
        for (r, e) in sky.rings().iter().zip(edges) {
            let d = r.theta_max.to_degrees();
            // The design quotes two decimals; accept 0.01 deg (half-ulp of the quote + rounding).
            assert!((d - e).abs() <= 0.01, "edge {d} vs {e}");
        }
        for w in sky.rings().windows(2) {
            assert_eq!(w[0].theta_max, w[1].theta_min);
            assert_eq!(w[0].first + w[0].cells, w[1].first);
        }
    }

    #[test]
    fn errors() {
        assert_eq!(
            SkyPartition::new(0, SkyVariant::EqualSolidAngle),
            Err(SkyError::NoCells)
        );
        assert_eq!(
            SkyPartition::new(MAX_CELLS + 1, SkyVariant::EqualProjectedArea),
            Err(SkyError::TooManyCells(MAX_CELLS + 1))
        );
    }

    #[test]
    fn small_n_are_valid() {
        for v in VARIANTS {
            for n in 1..200 {
                let sky = SkyPartition::new(n, v).unwrap();
                let total: usize = sky.rings().iter().map(|r| r.cells).sum();
                assert_eq!(total, n);
                assert_eq!(sky.rings()[0].cells, 1);
                assert_eq!(sky.rings().last().unwrap().theta_max, FRAC_PI_2);
                assert!(sky.rings().iter().all(|r| r.theta_min < r.theta_max));
            }
        }
    }

    #[test]
    fn cells_have_equal_measure() {
        for v in VARIANTS {
            for n in [1, 2, 7, 145, 1000, 10_000, 123_457, 1_000_000] {
                let sky = SkyPartition::new(n, v).unwrap();
                let total: usize = sky.rings().iter().map(|r| r.cells).sum();
                assert_eq!(total, n);
                let expect = match v {
                    SkyVariant::EqualSolidAngle => TAU / n as f64,
                    SkyVariant::EqualProjectedArea => PI / n as f64,
                };
                // Every ring's cells are equal by symmetry; check each ring's first and last.
                for r in sky.rings() {
                    for c in [r.first, r.first + r.cells - 1] {
                        let m = match v {
                            SkyVariant::EqualSolidAngle => sky.cell_solid_angle(c),
                            SkyVariant::EqualProjectedArea => sky.cell_projected_area(c),
                        }
                        .unwrap();
                        let rel = (m - expect).abs() / expect;
                        assert!(rel < 1e-12, "{v:?} n={n} cell {c}: rel {rel:e}");
                    }
                }
            }
        }
    }

    #[test]
    fn rings_are_roughly_square() {
        // Ring width and cell azimuth extent stay within a factor ~2 of each other away
        // from the pole for the solid-angle variant (the point of the construction).
        let sky = SkyPartition::new(10_000, SkyVariant::EqualSolidAngle).unwrap();
        for r in &sky.rings()[2..] {
            let dtheta = r.theta_max - r.theta_min;
            let mid = 0.5 * (r.theta_min + r.theta_max);
            let dphi = TAU / r.cells as f64 * mid.sin();
            let aspect = dtheta / dphi;
            assert!((0.5..2.0).contains(&aspect), "aspect {aspect}");
        }
    }

    #[test]
    fn samples_inside_their_cells_and_deterministic() {
        for v in VARIANTS {
            for n in [1, 3, 145, 10_000, 100_000] {
                let sky = SkyPartition::new(n, v).unwrap();
                let s = sky.sample(7);
                assert_eq!(s.len(), n);
                for (i, d) in s.iter().enumerate() {
                    assert!((d.length() - 1.0).abs() < 1e-12);
                    assert!(d.z > 0.0);
                    assert_eq!(sky.cell_of(*d), Some(i), "{v:?} n={n}");
                    let b = sky.cell_bounds(i).unwrap();
                    let theta = d.x.hypot(d.y).atan2(d.z);
                    assert!(theta >= b.theta_min && theta <= b.theta_max);
                }
                assert_eq!(s, sky.sample(7));
                if n > 1 {
                    assert_ne!(s, sky.sample(8));
                }
            }
        }
    }

    #[test]
    fn samples_are_uniform_in_measure() {
        // Mean of cos(theta) over the hemisphere: 1/2 for uniform solid angle, 2/3 for
        // cosine-weighted (projected-area) sampling.
        let mean = |v| {
            let sky = SkyPartition::new(20_000, v).unwrap();
            let s = sky.sample(1);
            s.iter().map(|d| d.z).sum::<f64>() / s.len() as f64
        };
        assert!((mean(SkyVariant::EqualSolidAngle) - 0.5).abs() < 1e-3);
        assert!((mean(SkyVariant::EqualProjectedArea) - 2.0 / 3.0).abs() < 1e-3);
    }

    #[test]
    fn cell_of_edge_cases() {
        let sky = SkyPartition::new(145, SkyVariant::EqualSolidAngle).unwrap();
        assert_eq!(sky.cell_of(DVec3::Z), Some(0));
        assert_eq!(sky.cell_of(DVec3::new(0.0, 0.0, -1.0)), None);
        assert_eq!(sky.cell_of(DVec3::ZERO), None);
        assert_eq!(sky.cell_of(DVec3::new(f64::NAN, 0.0, 1.0)), None);
        // Due north on the horizon: first cell of the outer ring.
        assert_eq!(sky.cell_of(DVec3::Y), Some(115));
        // Just west of north: last cell.
        assert_eq!(sky.cell_of(DVec3::new(-1e-9, 1.0, 0.0)), Some(144));
        assert_eq!(sky.cell_bounds(145), None);
        assert_eq!(sky.ring_of_cell(0), Some(0));
        assert_eq!(sky.ring_of_cell(144), Some(7));
    }

    #[test]
    fn angular_size() {
        let sky = SkyPartition::new(10_000, SkyVariant::EqualProjectedArea).unwrap();
        assert!((sky.angular_size() - (TAU / 10_000.0).sqrt()).abs() < 1e-15);
        assert!((sky.cell_weight() - 1e-4).abs() < 1e-18);
    }

    #[test]
    fn large_n_is_fast_enough() {
        let t = std::time::Instant::now();
        let sky = SkyPartition::new(1_000_000, SkyVariant::EqualSolidAngle).unwrap();
        let s = sky.sample(3);
        assert_eq!(s.len(), 1_000_000);
        // Generous bound for a debug build on a loaded machine.
        assert!(t.elapsed().as_secs_f64() < 10.0);
    }

    #[test]
    fn frame_is_orthonormal_and_right_handed() {
        for n in [
            DVec3::Z,
            -DVec3::Z,
            DVec3::X,
            DVec3::new(0.3, -0.2, 0.9),
            DVec3::new(0.0, 0.001, 1.0),
            DVec3::new(-1.0, 2.0, -0.5),
        ] {
            let f = Frame::from_normal(n);
            let nn = n.normalize();
            assert!((f.z - nn).length() < 1e-12);
            assert!(f.x.dot(f.y).abs() < 1e-12 && f.x.dot(f.z).abs() < 1e-12);
            assert!((f.x.cross(f.y) - f.z).length() < 1e-12);
            let d = DVec3::new(0.2, -0.5, 0.7).normalize();
            assert!((f.to_local(f.to_world(d)) - d).length() < 1e-12);
        }
        assert_eq!(Frame::from_normal(DVec3::Z), Frame::IDENTITY);
        assert_eq!(Frame::from_normal(DVec3::ZERO), Frame::IDENTITY);
    }
}
