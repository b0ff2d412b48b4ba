//! The Perez all-weather sky (Perez, Seals, Michalsky: "All-weather model for sky luminance
//! distribution — preliminary configuration and validation", Solar Energy 50 (3), 1993, with
//! its erratum) on Reinhart's sky patches: the sky model of Radiance's `gendaymtx`, which
//! daylight-coefficient tools (Radiance, Daysim, Honeybee) use.
//!
//! An hour's diffuse radiance in direction ω, ζ from the zenith and γ from the sun, is
//! `L(ω) = k (1 + a e^(b / cos ζ)) (1 + c e^(d γ) + e cos² γ)`, clamped at 0. The five
//! parameters follow from the sun's zenith angle Z, the sky's clearness
//! `ε = ((DHI + DNI)/DHI + 1.041 Z³) / (1 + 1.041 Z³)` and brightness
//! `Δ = DHI m / (1367 E₀)` (air mass `m` of Kasten 1966, orbit eccentricity `E₀` of Spencer's
//! series) by the published coefficients of ε's bin: `x = x₁ + x₂ Z + Δ (x₃ + x₄ Z)`, with
//! the overcast bin's own forms for c and d. As in `gendaymtx`, Δ is at least 0.2 for
//! 1.065 < ε < 2.8 and the sun is put no higher than 87° for the distribution. The factor
//! `k` makes the sky's horizontal irradiance, summed over the patches, equal the hour's DHI.
//!
//! The patches are Reinhart's subdivision [`SUBDIVISION`] of the 145 Tregenza patches
//! (2 305 patches, about 1.7° × 3°): rows of equal altitude width from the horizon up, each
//! row's patches centred on azimuths `2π j / n` from north towards east, and a zenith cap;
//! the radiance of a patch is the model's value at its centre, as `gendaymtx` takes it. With
//! the sun below the horizon the model is not defined; such an hour's DHI is spread evenly
//! over the sky.

use glam::DVec3;
use std::f64::consts::{FRAC_PI_2, TAU};
use std::sync::OnceLock;

/// Reinhart's subdivision of the Tregenza sky (Radiance's `MF`): 2 305 patches.
pub const SUBDIVISION: usize = 4;

/// Tregenza's patches per row, from the horizon up (without the zenith patch).
const TREGENZA_ROWS: [usize; 7] = [30, 30, 24, 24, 18, 12, 6];

/// The all-weather model's coefficients per clearness bin: a₁..a₄, b₁..b₄, c₁..c₄, d₁..d₄,
/// e₁..e₄ (Perez, Seals, Michalsky 1993, Table 1, as corrected by the erratum).
const COEFFICIENTS: [[f64; 20]; 8] = [
    [
        1.3525, -0.2576, -0.2690, -1.4366, -0.7670, 0.0007, 1.2734, -0.1233, 2.8000, 0.6004,
        1.2375, 1.0000, 1.8734, 0.6297, 0.9738, 0.2809, 0.0356, -0.1246, -0.5718, 0.9938,
    ],
    [
        -1.2219, -0.7730, 1.4148, 1.1016, -0.2054, 0.0367, -3.9128, 0.9156, 6.9750, 0.1774, 6.4477,
        -0.1239, -1.5798, -0.5081, -1.7812, 0.1080, 0.2624, 0.0672, -0.2190, -0.4285,
    ],
    [
        -1.1000, -0.2515, 0.8952, 0.0156, 0.2782, -0.1812, -4.5000, 1.1766, 24.7219, -13.0812,
        -37.7000, 34.8438, -5.0000, 1.5218, 3.9229, -2.6204, -0.0156, 0.1597, 0.4199, -0.5562,
    ],
    [
        -0.5484, -0.6654, -0.2672, 0.7117, 0.7234, -0.6219, -5.6812, 2.6297, 33.3389, -18.3000,
        -62.2500, 52.0781, -3.5000, 0.0016, 1.1477, 0.1062, 0.4659, -0.3296, -0.0876, -0.0329,
    ],
    [
        -0.6000, -0.3566, -2.5000, 2.3250, 0.2937, 0.0496, -5.6812, 1.8415, 21.0000, -4.7656,
        -21.5906, 7.2492, -3.5000, -0.1554, 1.4062, 0.3988, 0.0032, 0.0766, -0.0656, -0.1294,
    ],
    [
        -1.0156, -0.3670, 1.0078, 1.4051, 0.2875, -0.5328, -3.8500, 3.3750, 14.0000, -0.9999,
        -7.1406, 7.5469, -3.4000, -0.1078, -1.0750, 1.5702, -0.0672, 0.4016, 0.3017, -0.4844,
    ],
    [
        -1.0000, 0.0211, 0.5025, -0.5119, -0.3000, 0.1922, 0.7023, -1.6317, 19.0000, -5.0000,
        1.2438, -1.9094, -4.0000, 0.0250, 0.3844, 0.2656, 1.0468, -0.3788, -2.4517, 1.4656,
    ],
    [
        -1.0500, 0.0289, 0.4260, 0.3590, -0.3250, 0.1156, 0.7781, 0.0025, 31.0625, -14.5000,
        -46.1148, 55.3750, -7.2312, 0.4050, 13.3500, 0.6234, 1.5000, -0.6426, 1.8564, 0.5636,
    ],
];

/// Lower edges of the clearness bins 1..7 (bin 0 from 1 to 1.065).
const CLEARNESS_EDGES: [f64; 7] = [1.065, 1.23, 1.5, 1.95, 2.8, 4.5, 6.2];

/// Reinhart's sky patches (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct Patches {
    /// Altitude width of a row (radians).
    alpha: f64,
    /// Per row: the index of its first patch and its number of patches.
    rows: Vec<(usize, usize)>,
    /// Centre direction of each patch (x east, y north, z up).
    centres: Vec<DVec3>,
    /// Solid angle of each patch (sr).
    solid_angles: Vec<f64>,
}

impl Patches {
    /// The patches of [`SUBDIVISION`], built once.
    pub fn reinhart() -> &'static Patches {
        static PATCHES: OnceLock<Patches> = OnceLock::new();
        PATCHES.get_or_init(|| Patches::new(SUBDIVISION))
    }

    fn new(mf: usize) -> Patches {
        let mf = mf.max(1);
        let alpha = FRAC_PI_2 / ((7 * mf) as f64 + 0.5);
        let (mut rows, mut centres, mut solid_angles) = (Vec::new(), Vec::new(), Vec::new());
        for i in 0..7 * mf {
            let n = TREGENZA_ROWS[i / mf] * mf;
            rows.push((centres.len(), n));
            let alt = alpha * (i as f64 + 0.5);
            let omega =
                TAU * ((alpha * (i + 1) as f64).sin() - (alpha * i as f64).sin()) / n as f64;
            for j in 0..n {
                let az = TAU * j as f64 / n as f64;
                centres.push(DVec3::new(
                    alt.cos() * az.sin(),
                    alt.cos() * az.cos(),
                    alt.sin(),
                ));
                solid_angles.push(omega);
            }
        }
        centres.push(DVec3::Z);
        solid_angles.push(TAU * (1.0 - (alpha / 2.0).cos()));
        Patches {
            alpha,
            rows,
            centres,
            solid_angles,
        }
    }

    /// Number of patches.
    pub fn len(&self) -> usize {
        self.centres.len()
    }

    /// Whether there are none (never).
    pub fn is_empty(&self) -> bool {
        self.centres.is_empty()
    }

    /// The centre direction of each patch.
    pub fn centres(&self) -> &[DVec3] {
        &self.centres
    }

    /// The solid angle of each patch (sr); they sum to 2π.
    pub fn solid_angles(&self) -> &[f64] {
        &self.solid_angles
    }

    /// The patch holding unit direction `d`; `None` below the horizon (`d.z <= 0`).
    pub fn patch_of(&self, d: DVec3) -> Option<usize> {
        if d.z <= 0.0 || !d.is_finite() {
            return None;
        }
        let alt = d.z.min(1.0).asin();
        let row = (alt / self.alpha) as usize;
        let Some(&(first, n)) = self.rows.get(row) else {
            return Some(self.centres.len() - 1);
        };
        let az = d.x.atan2(d.y).rem_euclid(TAU);
        let width = TAU / n as f64;
        Some(first + ((az / width + 0.5) as usize) % n)
    }
}

/// The sky of one hour: its parameters and the factor that makes its horizontal irradiance
/// the hour's DHI (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HourSky {
    /// a, b, c, d, e; `None` for an even sky (the sun below the horizon).
    params: Option<[f64; 5]>,
    /// Unit direction to the sun, lifted to at most 87° of altitude.
    sun: DVec3,
    /// Radiance (the weather's unit per steradian) = `scale` × relative luminance.
    scale: f64,
}

impl HourSky {
    /// The sky of an hour with diffuse horizontal `dhi` and direct normal `dni` (W/m² or
    /// Wh/m²), the sun in unit direction `sun` (x east, y north, z up), on day of year `doy`.
    /// `None` when there is no diffuse light.
    pub fn new(sun: DVec3, dni: f64, dhi: f64, doy: u32) -> Option<HourSky> {
        HourSky::adding(sun, dni, dhi, doy, &mut [])
    }

    /// [`HourSky::new`], the radiance of each patch of [`Patches::reinhart`] added to `sums`
    /// (when it holds one value per patch).
    pub fn adding(sun: DVec3, dni: f64, dhi: f64, doy: u32, sums: &mut [f64]) -> Option<HourSky> {
        if dhi.is_nan() || dhi <= 1e-4 || !sun.is_finite() {
            return None;
        }
        let patches = Patches::reinhart();
        let max_alt = 87f64.to_radians();
        let (sun, params) = if sun.z <= 0.0 {
            (sun, None)
        } else {
            let sun = if sun.z.asin() > max_alt {
                let h = DVec3::new(sun.x, sun.y, 0.0)
                    .try_normalize()
                    .unwrap_or(DVec3::Y);
                h * max_alt.cos() + DVec3::Z * max_alt.sin()
            } else {
                sun
            };
            let z = sun.z.clamp(-1.0, 1.0).acos();
            (sun, Some(parameters(z, dni.max(0.0), dhi, doy)))
        };
        let mut sky = HourSky {
            params,
            sun,
            scale: 1.0,
        };
        let relative = |sky: &HourSky| -> (Vec<f64>, f64) {
            let rel: Vec<f64> = patches.centres.iter().map(|c| sky.relative(*c)).collect();
            let e = (rel.iter().zip(&patches.centres).zip(&patches.solid_angles))
                .map(|((l, c), w)| l * c.z * w)
                .sum();
            (rel, e)
        };
        let (mut rel, mut e) = relative(&sky);
        if !(e > 0.0 && e.is_finite()) {
            sky.params = None;
            (rel, e) = relative(&sky);
        }
        sky.scale = dhi / e;
        if sums.len() == rel.len() {
            for (s, l) in sums.iter_mut().zip(rel) {
                *s += sky.scale * l;
            }
        }
        Some(sky)
    }

    /// The model's relative luminance in unit direction `d` (above the horizon).
    fn relative(&self, d: DVec3) -> f64 {
        let Some([a, b, c, dd, e]) = self.params else {
            return 1.0;
        };
        let cos_zeta = d.z.max(1e-6);
        let cos_gamma = d.dot(self.sun).clamp(-1.0, 1.0);
        let gamma = cos_gamma.acos();
        let v = (1.0 + a * (b / cos_zeta).exp())
            * (1.0 + c * (dd * gamma).exp() + e * cos_gamma * cos_gamma);
        v.max(0.0)
    }

    /// The radiance of patch `p` of [`Patches::reinhart`].
    pub fn patch(&self, p: usize) -> f64 {
        Patches::reinhart()
            .centres()
            .get(p)
            .map_or(0.0, |c| self.scale * self.relative(*c))
    }
}

/// a, b, c, d, e of the model for the sun at zenith angle `z` (radians).
fn parameters(z: f64, dni: f64, dhi: f64, doy: u32) -> [f64; 5] {
    let airmass = 1.0 / (z.cos() + 0.15 * (93.885 - z.to_degrees()).max(1e-3).powf(-1.253));
    let day = TAU * (f64::from(doy) - 1.0) / 365.0;
    let eccentricity = 1.00011
        + 0.034221 * day.cos()
        + 0.00128 * day.sin()
        + 0.000719 * (2.0 * day).cos()
        + 0.000077 * (2.0 * day).sin();
    let mut delta = dhi * airmass / (1367.0 * eccentricity);
    let kz3 = 1.041 * z.powi(3);
    let epsilon = ((dhi + dni) / dhi + kz3) / (1.0 + kz3);
    let bin = CLEARNESS_EDGES.iter().filter(|&&e| epsilon >= e).count();
    if epsilon > 1.065 && epsilon < 2.8 {
        delta = delta.max(0.2);
    }
    let x = &COEFFICIENTS[bin];
    let term = |i: usize| x[4 * i] + x[4 * i + 1] * z + delta * (x[4 * i + 2] + x[4 * i + 3] * z);
    let mut p = [term(0), term(1), term(2), term(3), term(4)];
    if bin == 0 {
        p[2] = (delta * (x[8] + x[9] * z)).powf(x[10]).exp() - x[11];
        p[3] = -(delta * (x[12] + x[13] * z)).exp() + x[14] + delta * x[15];
    }
    p
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn patches_cover_the_sky_once() {
        let p = Patches::reinhart();
        assert_eq!(p.len(), 2305);
        let total: f64 = p.solid_angles().iter().sum();
        assert!((total - TAU).abs() < 1e-9, "{total}");
        for (i, c) in p.centres().iter().enumerate() {
            assert_eq!(p.patch_of(*c), Some(i));
        }
        assert_eq!(p.patch_of(DVec3::new(0.0, 1.0, -0.1)), None);
        // Radiance's first patch: on the horizon row, centred on north
        assert_eq!(p.patch_of(DVec3::new(0.01, 1.0, 0.01).normalize()), Some(0));
        assert_eq!(
            p.patch_of(DVec3::new(-0.01, 1.0, 0.01).normalize()),
            Some(0)
        );
    }

    #[test]
    fn the_sky_gives_its_dhi_on_the_horizontal() {
        let p = Patches::reinhart();
        for (sun, dni, dhi) in [
            (DVec3::new(0.3, -0.5, 0.8), 800.0, 120.0),
            (DVec3::new(-0.8, 0.1, 0.2), 50.0, 300.0),
            (DVec3::new(0.0, -0.2, 0.98), 0.0, 200.0),
            (DVec3::new(0.5, 0.5, -0.1), 0.0, 10.0),
        ] {
            let mut l = vec![0.0; p.len()];
            let sky = HourSky::adding(sun.normalize(), dni, dhi, 180, &mut l).unwrap();
            let e: f64 = (l.iter().zip(p.centres()).zip(p.solid_angles()))
                .map(|((l, c), w)| l * c.z * w)
                .sum();
            assert!((e / dhi - 1.0).abs() < 1e-9, "{e} vs {dhi}");
            assert!((sky.patch(7) - l[7]).abs() < 1e-12);
        }
        assert!(HourSky::new(DVec3::Z, 500.0, 0.0, 1).is_none());
    }

    #[test]
    fn a_clear_sky_is_brightest_around_the_sun() {
        let sun = DVec3::new(0.0, -0.6, 0.8);
        let sky = HourSky::new(sun, 850.0, 90.0, 172).unwrap();
        let p = Patches::reinhart();
        let at = |d: DVec3| sky.patch(p.patch_of(d.normalize()).unwrap());
        let near = at(sun + DVec3::new(0.02, 0.0, 0.0));
        let opposite = at(DVec3::new(0.0, 0.6, 0.8));
        assert!(near > 5.0 * opposite, "{near} vs {opposite}");
    }
}
