#!/usr/bin/env python3
"""EPSG facts skylod's CRS tables claim, checked against pyproj's EPSG database (oracle of
tests/it/crs_frames.rs), and the generator of the foot-unit table in src/crs/feet.rs.

  python3 crs_tables.py --emit-rust   # print the body of src/crs/feet.rs's two tables
  python3 crs_tables.py < claims.json # check claims; prints "ok N" or the mismatches, exit 1

claims.json: {"feet_us": [codes], "feet_intl": [codes], "geographic": [[code, lat_first,
semi_major_m, inv_flattening]], "projected_m": [codes]}. The foot tables must equal the set
of non-deprecated EPSG projected CRSs whose first axis is in US survey feet / feet.
"""
import json
import sys

from pyproj import CRS
from pyproj.database import query_crs_info
from pyproj.enums import PJType


def foot_codes():
    us, ft = [], []
    for info in query_crs_info(auth_name="EPSG", pj_types=[PJType.PROJECTED_CRS]):
        if info.deprecated:
            continue
        try:
            c = CRS.from_epsg(int(info.code))
        except Exception:
            continue
        unit = c.axis_info[0].unit_name
        if unit == "US survey foot":
            us.append(int(info.code))
        elif unit == "foot":
            ft.append(int(info.code))
    return sorted(us), sorted(ft)


def emit(name, codes):
    print(f"pub(super) const {name}: [u16; {len(codes)}] = [")
    line = "   "
    for c in codes:
        if len(line) + len(str(c)) + 2 > 96:
            print(line)
            line = "   "
        line += f" {c},"
    print(line)
    print("];")


def main():
    if "--emit-rust" in sys.argv:
        us, ft = foot_codes()
        emit("US_SURVEY_FEET", us)
        emit("INTERNATIONAL_FEET", ft)
        return 0
    claims = json.load(sys.stdin)
    bad = []
    n = 0
    us, ft = foot_codes()
    if sorted(claims["feet_us"]) != us:
        bad.append(f"US survey feet table differs: {sorted(set(us) ^ set(claims['feet_us']))[:20]}")
    if sorted(claims["feet_intl"]) != ft:
        bad.append(f"international feet table differs: {sorted(set(ft) ^ set(claims['feet_intl']))[:20]}")
    n += len(us) + len(ft)
    for code, lat_first, a, inv_f in claims["geographic"]:
        n += 1
        c = CRS.from_epsg(code)
        if not c.is_geographic:
            bad.append(f"EPSG:{code} is not geographic")
            continue
        dirs = [ax.direction for ax in c.axis_info[:2]]
        first_lat = dirs[0] == "north"
        if first_lat != lat_first:
            bad.append(f"EPSG:{code}: axis order {dirs}, skylod says lat_first={lat_first}")
        e = c.ellipsoid
        if abs(e.semi_major_metre - a) > 1e-3 or abs(e.inverse_flattening - inv_f) > 1e-6:
            bad.append(f"EPSG:{code}: ellipsoid {e.name} a={e.semi_major_metre} 1/f={e.inverse_flattening}, skylod says {a} {inv_f}")
    for code in claims["projected_m"]:
        n += 1
        c = CRS.from_epsg(code)
        if not c.is_projected:
            bad.append(f"EPSG:{code} is not projected")
        elif c.axis_info[0].unit_name != "metre":
            bad.append(f"EPSG:{code} unit {c.axis_info[0].unit_name}")
    for b in bad:
        print(b)
    if bad:
        return 1
    print(f"ok {n}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
