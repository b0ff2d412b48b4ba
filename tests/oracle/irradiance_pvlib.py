"""Oracle of `skylod irradiance` (tests/it/irradiance.rs): annual irradiation from pvlib.

Reads a JSON request on stdin:
  {"tmy3": PATH, "lat": .., "lon": .., "albedo": .., "planes": [{"tilt": deg, "azimuth": deg}],
   "canyon": {"w": .., "h": ..}}
and prints, per plane and sky model, pvlib's `get_total_irradiance` summed over the year
(kWh/m2), and for the canyon floor centre the closed form (direct with the walls' shadow +
DHI x SVF, isotropic, albedo 0). Conventions are skylod's documented ones: the sun at the
middle of each hour (pvlib's convention for hourly data), no beam with the sun below the
horizon, and with the sun below the horizon (Perez undefined: pvlib gives 0) the hour's DHI
taken as isotropic.
"""
import json
import sys

import numpy as np
import pvlib

req = json.load(sys.stdin)
data, meta = pvlib.iotools.read_tmy3(req["tmy3"], map_variables=True)
times = data.index - np.timedelta64(30, "m")
lat, lon = req["lat"], req["lon"]
sp = pvlib.solarposition.get_solarposition(times, lat, lon)
zen = sp["apparent_zenith"].to_numpy()
azi = sp["azimuth"].to_numpy()
up = zen < 90.0
ghi, dni, dhi = (data[k].to_numpy(dtype=float) for k in ("ghi", "dni", "dhi"))
extra = pvlib.irradiance.get_extra_radiation(times).to_numpy()
airmass = pvlib.atmosphere.get_relative_airmass(zen)
out = {"ghi": ghi.sum() / 1000, "horizontal_beam_plus_dhi": (np.where(up, dni * np.cos(np.radians(zen)), 0).clip(0) + dhi).sum() / 1000}
for p in req["planes"]:
    tilt, az = p["tilt"], p["azimuth"]
    for model in ("perez", "isotropic"):
        t = pvlib.irradiance.get_total_irradiance(
            tilt, az, zen, azi, dni, ghi, dhi, dni_extra=extra, airmass=airmass,
            albedo=req["albedo"], model=model)
        beam = np.where(up, np.asarray(t["poa_direct"]), 0.0)
        sky = np.asarray(t["poa_sky_diffuse"], dtype=float)
        iso = dhi * (1 + np.cos(np.radians(tilt))) / 2
        sky = np.where(up, np.nan_to_num(sky), iso)
        ground = np.asarray(t["poa_ground_diffuse"], dtype=float)
        key = f"{tilt:g}/{az:g}/{model}"
        out[key] = {
            "direct": beam.sum() / 1000,
            "diffuse": sky.sum() / 1000,
            "reflected": ground.sum() / 1000,
            "global": (beam + sky + ground).sum() / 1000,
        }
c = req.get("canyon")
if c:
    ratio = 2 * c["h"] / c["w"]
    z = np.radians(zen)
    sx = np.sin(z) * np.sin(np.radians(azi))
    sz = np.cos(z)
    lit = up & (sz > ratio * np.abs(sx))
    direct = np.where(lit, dni * sz, 0.0).sum() / 1000
    svf = 1 / np.sqrt(1 + ratio**2)
    out["canyon"] = {"direct": direct, "diffuse": dhi.sum() * svf / 1000, "svf": svf}
json.dump(out, sys.stdout)
