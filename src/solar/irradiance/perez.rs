//! The Perez 1990 anisotropic sky (Perez, Ineichen, Seals, Michalsky, Stewart: "Modeling
//! daylight availability and irradiance components from direct and global irradiance",
//! Solar Energy 44 (5), 1990), with its "all sites composite" coefficients: the diffuse
//! irradiance on a plane of tilt β is
//!
//! `DHI × [(1 − F1) (1 + cos β)/2 + F1 a/b + F2 sin β]`
//!
//! (isotropic background, circumsolar disc, horizon band), `a = max(0, cos θ)` of the sun's
//! incidence, `b = max(cos 85°, cos Z)`. F1 and F2 depend on the sky's clearness ε and
//! brightness Δ, binned as pvlib's `irradiance.perez` does; the same relative air mass
//! (Kasten & Young 1989) and extraterrestrial irradiance (Spencer 1971) as pvlib's defaults.
//!
//! # Example
//! ```
//! use skylod::solar::irradiance::{brightening, extraterrestrial, relative_airmass};
//! let z: f64 = 40.0;
//! let (f1, f2) = brightening(120.0, 650.0, z, relative_airmass(z).unwrap(), extraterrestrial(172));
//! // pvlib 0.16, irradiance.perez(90, 180, 120, 650, dni_extra, 40, 180, airmass,
//! // return_components=True): poa_isotropic 22.80608839 = 60 (1 - F1), poa_horizon
//! // 26.63949326 = 120 F2
//! assert!((f1 - (1.0 - 22.80608839 / 60.0)).abs() < 1e-7, "{f1}");
//! assert!((f2 - 26.63949326 / 120.0).abs() < 1e-7, "{f2}");
//! ```

/// The ε bins' lower edges (bin 0 from 1 to 1.065, …, bin 7 above 6.2).
const EPSILON_EDGES: [f64; 7] = [1.065, 1.23, 1.5, 1.95, 2.8, 4.5, 6.2];

/// F1 = f11 + f12 Δ + f13 Z per ε bin ("allsitescomposite1990").
const F1: [[f64; 3]; 8] = [
    [-0.008, 0.588, -0.062],
    [0.130, 0.683, -0.151],
    [0.330, 0.487, -0.221],
    [0.568, 0.187, -0.295],
    [0.873, -0.392, -0.362],
    [1.132, -1.237, -0.412],
    [1.060, -1.600, -0.359],
    [0.678, -0.327, -0.250],
];

/// F2 = f21 + f22 Δ + f23 Z per ε bin ("allsitescomposite1990").
const F2: [[f64; 3]; 8] = [
    [-0.060, 0.072, -0.022],
    [-0.019, 0.066, -0.029],
    [0.055, -0.064, -0.026],
    [0.109, -0.152, -0.014],
    [0.226, -0.462, 0.001],
    [0.288, -0.823, 0.056],
    [0.264, -1.127, 0.131],
    [0.156, -1.377, 0.251],
];

/// The circumsolar (F1 ≥ 0) and horizon (F2) brightening coefficients of an hour with
/// diffuse `dhi` and direct normal `dni` (any irradiance unit), the sun at zenith angle
/// `zenith_deg`, relative air mass `airmass` and extraterrestrial normal irradiance
/// `dni_extra` (W/m²). `(0, 0)` (an isotropic sky) when `dhi` is not positive.
pub fn brightening(
    dhi: f64,
    dni: f64,
    zenith_deg: f64,
    airmass: f64,
    dni_extra: f64,
) -> (f64, f64) {
    if dhi <= 0.0 || !airmass.is_finite() || dni_extra <= 0.0 {
        return (0.0, 0.0);
    }
    let z = zenith_deg.to_radians();
    let kz3 = 1.041 * z.powi(3);
    let epsilon = ((dhi + dni) / dhi + kz3) / (1.0 + kz3);
    let delta = dhi * airmass / dni_extra;
    let bin = EPSILON_EDGES.iter().filter(|&&e| epsilon >= e).count();
    let f = |c: &[f64; 3]| c[0] + c[1] * delta + c[2] * z;
    (f(&F1[bin]).max(0.0), f(&F2[bin]))
}

/// Relative (not pressure-corrected) optical air mass at zenith angle `zenith_deg`
/// (Kasten & Young 1989); `None` with the sun below the horizon.
pub fn relative_airmass(zenith_deg: f64) -> Option<f64> {
    (zenith_deg <= 90.0).then(|| {
        1.0 / (zenith_deg.to_radians().cos()
            + 0.50572 * (6.07995 + (90.0 - zenith_deg)).powf(-1.6364))
    })
}

/// Extraterrestrial normal irradiance (W/m²) on day of year `doy` (1–366), Spencer 1971
/// with a solar constant of 1366.1 W/m².
pub fn extraterrestrial(doy: u32) -> f64 {
    let b = 2.0 * std::f64::consts::PI / 365.0 * (f64::from(doy) - 1.0);
    1366.1
        * (1.00011
            + 0.034221 * b.cos()
            + 0.00128 * b.sin()
            + 0.000719 * (2.0 * b).cos()
            + 0.000077 * (2.0 * b).sin())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_of_pvlib() {
        // pvlib 0.16: irradiance.perez(..., return_components=True) at tilt 90 gives F1, F2
        // through poa_circumsolar = dhi F1 a/b and poa_horizon = dhi F2; these are its
        // coefficients evaluated by hand for a clear (bin 7) and an overcast (bin 0) hour.
        let (f1, f2) = brightening(100.0, 800.0, 30.0, relative_airmass(30.0).unwrap(), 1400.0);
        let z = 30f64.to_radians();
        let kz3 = 1.041 * z.powi(3);
        let eps = (9.0 + kz3) / (1.0 + kz3);
        assert!(eps >= 6.2);
        let delta = 100.0 * relative_airmass(30.0).unwrap() / 1400.0;
        assert!((f1 - (0.678 - 0.327 * delta - 0.25 * z)).abs() < 1e-12);
        assert!((f2 - (0.156 - 1.377 * delta + 0.251 * z)).abs() < 1e-12);
        let (f1, f2) = brightening(200.0, 0.0, 60.0, 2.0, 1366.0);
        let delta = 200.0 * 2.0 / 1366.0;
        let z = 60f64.to_radians();
        assert!((f1 - (-0.008 + 0.588 * delta - 0.062 * z).max(0.0)).abs() < 1e-12);
        assert!((f2 - (-0.06 + 0.072 * delta - 0.022 * z)).abs() < 1e-12);
        assert_eq!(brightening(0.0, 500.0, 30.0, 1.2, 1366.0), (0.0, 0.0));
    }

    #[test]
    fn airmass_and_extraterrestrial() {
        assert!((relative_airmass(0.0).unwrap() - 0.999_711_99).abs() < 1e-8); // pvlib 0.16
        assert!((relative_airmass(60.0).unwrap() - 1.994_292_85).abs() < 1e-8);
        assert!((relative_airmass(90.0).unwrap() - 37.919_608_4).abs() < 1e-6);
        assert_eq!(relative_airmass(91.0), None);
        assert!((extraterrestrial(3) - 1_414.019_201).abs() < 1e-5); // perihelion, pvlib 0.16
        assert!((extraterrestrial(185) - 1_320.457_747).abs() < 1e-5); // aphelion
    }
}
