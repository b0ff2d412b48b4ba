#!/usr/bin/env python3
"""Oracle for tests/it/sun_pvlib.rs: apparent solar zenith and azimuth from pvlib's SPA.

Reads JSON from stdin: {"cases": [{"time": RFC 3339 UTC, "latitude": deg, "longitude": deg,
"elevation_m": m, "pressure_mbar": mbar, "temperature_c": C, "delta_t_s": s}, ...]}
and writes JSON to stdout: [{"apparent_zenith": deg, "azimuth": deg}, ...] in input order.
The cases are chosen by the Rust test; this script only evaluates them.
"""
import json
import sys

import pandas as pd
import pvlib


def main():
    cases = json.load(sys.stdin)["cases"]
    out = []
    for c in cases:
        times = pd.DatetimeIndex([pd.Timestamp(c["time"])])
        if times.tz is None:
            times = times.tz_localize("UTC")
        sp = pvlib.solarposition.spa_python(
            times,
            c["latitude"],
            c["longitude"],
            altitude=c["elevation_m"],
            pressure=c["pressure_mbar"] * 100.0,  # pvlib wants pascals
            temperature=c["temperature_c"],
            delta_t=c["delta_t_s"],
            how="numpy",
        )
        out.append(
            {
                "apparent_zenith": float(sp["apparent_zenith"].iloc[0]),
                "azimuth": float(sp["azimuth"].iloc[0]),
            }
        )
    json.dump(out, sys.stdout)


if __name__ == "__main__":
    main()
