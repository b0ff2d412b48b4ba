#!/usr/bin/env python3
"""Oracle for tests/it/horizon.rs: sun hours from pvlib's sun positions masked by a horizon profile.

This is how a pvlib user applies a PVGIS-style horizon file: the sun is blocked at a time step
when its apparent elevation is below the profile's elevation at its azimuth (linear
interpolation, wrapping around north, as PVGIS does), and, for a surface, when the angle of
incidence on it (`pvlib.irradiance.aoi`) is 90 degrees or more. The profile comes from
`skylod horizon`; the sun positions (NREL SPA, `pvlib.solarposition.spa_python`), the angle of
incidence and the masking are pvlib's and numpy's, independent of skylod's own sun-hours ray
tracing.

Reads JSON from stdin:
  {"latitude", "longitude", "elevation_m", "pressure_mbar", "temperature_c", "delta_t_s",
   "year", "step_minutes",
   "profiles": [{"id", "azimuth": [...], "elevation": [...], "normal": [nx, ny, nz] or null,
                 "overhang": [... number or null] (optional)}]}
(normal: outward surface normal, x east, y north, z up; null for a free point. overhang: where
sky above the skyline is blocked again, per azimuth; the sun at or above the overhang of the
nearest azimuth sample is blocked.)
Time steps are those of skylod's SunTable: the UTC calendar year in steps of step_minutes,
each evaluated at its middle. Writes JSON to stdout, one object per profile in input order:
  {"id", "sun_hours", "open_hours", "direct_kwh_m2", "open_direct_kwh_m2"}
where sun_hours counts steps with the sun above the horizontal and above the profile,
open_hours those with the sun above the horizontal, and direct_kwh_m2 is the clear-sky beam
(normal) irradiation of the unmasked steps (simplified Solis model), for information.
"""
import json
import sys

import numpy as np
import pandas as pd
import pvlib


def main():
    cfg = json.load(sys.stdin)
    step = int(cfg["step_minutes"])
    year = int(cfg["year"])
    start = pd.Timestamp(f"{year}-01-01T00:00:00Z")
    end = pd.Timestamp(f"{year + 1}-01-01T00:00:00Z")
    n = int((end - start) / pd.Timedelta(minutes=step))
    times = start + pd.to_timedelta(np.arange(n) * step + step / 2.0, unit="min")
    times = pd.DatetimeIndex(times)
    sp = pvlib.solarposition.spa_python(
        times,
        cfg["latitude"],
        cfg["longitude"],
        altitude=cfg["elevation_m"],
        pressure=cfg["pressure_mbar"] * 100.0,  # pvlib wants pascals
        temperature=cfg["temperature_c"],
        delta_t=cfg["delta_t_s"],
        how="numpy",
    )
    elev = 90.0 - sp["apparent_zenith"].to_numpy()
    az = sp["azimuth"].to_numpy()
    up = elev > 0.0
    cs = pvlib.clearsky.simplified_solis(np.where(up, elev, 0.0))
    dni = np.where(up, np.nan_to_num(cs["dni"]), 0.0)
    hours = step / 60.0
    out = []
    for p in cfg["profiles"]:
        a = np.asarray(p["azimuth"], dtype=float)
        e = np.asarray(p["elevation"], dtype=float)
        order = np.argsort(a)
        a, e = a[order], e[order]
        # Periodic interpolation: repeat the first sample at +360 and the last at -360.
        a = np.concatenate(([a[-1] - 360.0], a, [a[0] + 360.0]))
        e = np.concatenate(([e[-1]], e, [e[0]]))
        skyline = np.interp(np.mod(az, 360.0), a, e)
        sunny = up & (elev > skyline)
        if p.get("overhang") is not None:
            ov = np.asarray([np.nan if v is None else float(v) for v in p["overhang"]])
            a0 = np.asarray(p["azimuth"], dtype=float)
            # Nearest azimuth sample, wrapping around north.
            d = np.abs(np.mod(az, 360.0)[:, None] - a0[None, :])
            nearest = np.argmin(np.minimum(d, 360.0 - d), axis=1)
            o = ov[nearest]
            sunny &= ~(~np.isnan(o) & (elev >= np.nan_to_num(o, nan=np.inf)))
        n = p.get("normal")
        if n is not None:
            nx, ny, nz = (float(v) for v in n)
            norm = (nx * nx + ny * ny + nz * nz) ** 0.5
            tilt = np.degrees(np.arccos(nz / norm))
            surface_azimuth = np.degrees(np.arctan2(nx, ny)) % 360.0
            aoi = pvlib.irradiance.aoi(tilt, surface_azimuth, sp["apparent_zenith"], sp["azimuth"])
            sunny &= aoi.to_numpy() < 90.0
        out.append(
            {
                "id": p["id"],
                "sun_hours": float(sunny.sum() * hours),
                "open_hours": float(up.sum() * hours),
                "direct_kwh_m2": float(dni[sunny].sum() * hours / 1000.0),
                "open_direct_kwh_m2": float(dni.sum() * hours / 1000.0),
            }
        )
    json.dump(out, sys.stdout)


if __name__ == "__main__":
    main()
