"""pyproj oracle for tests/it/national_crs.rs.

stdin: JSON [[code, lon, lat, x, y], ...]. For each, with the SAME method skylod's default
build uses (the proj4 definition of crs-definitions, towgs84 Helmert, no grids; given as
argv[1] JSON {code: proj4}), prints [x_fwd, y_fwd, lon_inv, lat_inv, x_epsg, y_epsg]:
(lon, lat) WGS 84 -> the projected CRS, (x, y) -> WGS 84 lon/lat, and for information the
forward result of pyproj's own EPSG pipeline (which may use grids).
"""
import json
import sys

from pyproj import CRS, Transformer

defs = json.loads(sys.argv[1])
wgs = CRS.from_proj4("+proj=longlat +datum=WGS84 +no_defs")
out = []
for code, lon, lat, x, y in json.load(sys.stdin):
    crs = CRS.from_proj4(defs[str(code)])
    fwd = Transformer.from_crs(wgs, crs, always_xy=True)
    inv = Transformer.from_crs(crs, wgs, always_xy=True)
    epsg = Transformer.from_crs("EPSG:4326", f"EPSG:{code}", always_xy=True)
    xf, yf = fwd.transform(lon, lat)
    li, bi = inv.transform(x, y)
    xe, ye = epsg.transform(lon, lat)
    out.append([xf, yf, li, bi, xe, ye])
print(json.dumps(out))
