#!/usr/bin/env python3
"""Oracle for tests/it/reproject.rs: checks a reprojected CityGML document against pyproj.

Usage: pyproj_reproject.py INPUT OUTPUT SOURCE_CRS TARGET_CRS

Reads every coordinate of INPUT and OUTPUT (gml posList, pos, coordinates, in document order,
outside envelopes and implicit-geometry templates; .gz read transparently) with the standard
library's XML parser, transforms the input's with pyproj.Transformer.from_crs(SOURCE, TARGET)
in the CRSs' own EPSG axis order (latitude first for EPSG:4326 and 6697, easting first for UTM:
what the files write), and prints JSON:
  {"points": n, "max_d0": .., "max_d1": .., "max_dz": .. (largest differences per axis, in the
   target's units; heights compared with the input's, which must be kept),
   "srs_names": [distinct srsName values of OUTPUT], "envelope_error": largest difference of the
   root envelope's corners from the bounding box of OUTPUT's coordinates}
"""
import gzip
import json
import sys
import xml.etree.ElementTree as ET

from pyproj import Transformer

GML = ("http://www.opengis.net/gml", "http://www.opengis.net/gml/3.2")
TEMPLATE = ("relativeGMLGeometry", "relativeGeometry")


def local(tag):
    return tag.rsplit("}", 1)[-1]


def ns(tag):
    return tag[1:].split("}", 1)[0] if tag.startswith("{") else ""


def coords(path):
    """Points (tuples of 2 or 3 floats) in document order, srsNames, and the root envelope."""
    opener = gzip.open if open(path, "rb").read(2) == b"\x1f\x8b" else open
    with opener(path, "rb") as f:
        root = ET.parse(f).getroot()
    pts, srs, env = [], set(), None

    def walk(el, dim, skip):
        nonlocal env
        name = local(el.tag)
        if el.get("srsName") is not None:
            srs.add(el.get("srsName"))
        d = el.get("srsDimension")
        dim = int(d) if d else dim
        if name in TEMPLATE:
            skip = True
        if ns(el.tag) in GML and name == "Envelope":
            if env is None:
                corners = [
                    [float(v) for v in (c.text or "").split()]
                    for c in el
                    if local(c.tag) in ("lowerCorner", "upperCorner")
                ]
                env = corners
            return
        if ns(el.tag) in GML and not skip:
            text = (el.text or "").split()
            if name == "posList":
                vals = [float(v) for v in text]
                pts.extend(tuple(vals[i : i + dim]) for i in range(0, len(vals), dim))
            elif name == "pos":
                pts.append(tuple(float(v) for v in text))
            elif name == "coordinates":
                cs, ts, dec = el.get("cs", ","), el.get("ts", " "), el.get("decimal", ".")
                tuples = (el.text or "").split() if ts == " " else (el.text or "").split(ts)
                for t in tuples:
                    if t.strip():
                        pts.append(tuple(float(v.replace(dec, ".")) for v in t.split(cs)))
        for c in el:
            walk(c, dim, skip)

    walk(root, 3, False)
    return pts, sorted(srs), env


def main():
    src, out, s_crs, t_crs = sys.argv[1:5]
    a, _, _ = coords(src)
    b, srs, env = coords(out)
    if len(a) != len(b):
        json.dump({"error": f"{len(a)} input points, {len(b)} output points"}, sys.stdout)
        return
    tr = Transformer.from_crs(s_crs, t_crs)
    xs, ys = tr.transform([p[0] for p in a], [p[1] for p in a])
    m0 = m1 = mz = 0.0
    for p, q, x, y in zip(a, b, xs, ys):
        m0 = max(m0, abs(q[0] - x))
        m1 = max(m1, abs(q[1] - y))
        if len(p) == 3:
            mz = max(mz, abs(q[2] - p[2]))
    env_err = None
    if env and len(env) == 2 and b:
        dims = min(len(env[0]), min(len(p) for p in b))
        lo = [min(p[i] for p in b) for i in range(dims)]
        hi = [max(p[i] for p in b) for i in range(dims)]
        env_err = max(
            max(abs(env[0][i] - lo[i]) for i in range(dims)),
            max(abs(env[1][i] - hi[i]) for i in range(dims)),
        )
    json.dump(
        {
            "points": len(a),
            "max_d0": m0,
            "max_d1": m1,
            "max_dz": mz,
            "srs_names": srs,
            "envelope_error": env_err,
        },
        sys.stdout,
    )


if __name__ == "__main__":
    main()
