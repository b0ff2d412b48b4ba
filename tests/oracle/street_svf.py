#!/usr/bin/env python3
"""Independent SVF oracle for LoD3 CityGML 2.0 files in a projected CRS (metres), oracle of
tests/it/bound.rs: the SVF of the full model (the inputs) and of the mixed-LoD model
(skylod's outputs) at facade POIs, with numpy, not with skylod's reader, triangulator or BVH.

Polygons: every element with `lodN...` geometry properties as direct children (thematic
surfaces, openings, installations: skylod's assets) contributes the gml:Polygons of its
highest LoD (xlink:href to polygons resolved by gml:id); exterior rings only (openings are
polygons of their own, so a hole is always filled). Triangulated by ear clipping
(plateau_svf.ear_clip). Bundle: k x k jittered cells of the unit disk lifted to the
cosine-weighted hemisphere (Malley), turned into the POI's normal frame; a ray counts as sky
when it points above the horizon and hits nothing (numpy Moller-Trumbore, triangles behind
the POI's plane culled). Ray origin 1 cm out along the normal.

  python3 street_svf.py K SEED POIS.csv FULL_FILES... -- LOD_FILES...
prints one line per POI: "id svf_full svf_lod".
"""
import gzip
import re
import sys
import xml.etree.ElementTree as ET

import numpy as np

from plateau_svf import blocked, bundle, ear_clip

GML = "{http://www.opengis.net/gml}"
XLINK = "{http://www.w3.org/1999/xlink}href"
LOD_RE = re.compile(r"^lod(\d)(MultiSurface|Solid|Geometry|Surface|CompositeSurface)$")


def local(tag):
    return tag.rsplit("}", 1)[-1]


def rings_of(files):
    rings = []
    for path in files:
        opener = gzip.open if path.endswith(".gz") else open
        with opener(path, "rb") as f:
            root = ET.parse(f).getroot()
        ids = {p.get(GML + "id"): p for p in root.iter(GML + "Polygon") if p.get(GML + "id")}
        for elem in root.iter():
            props = [(int(m.group(1)), c) for c in elem if (m := LOD_RE.match(local(c.tag)))]
            if not props:
                continue
            top = max(l for l, _ in props)
            for lod, prop in props:
                if lod != top:
                    continue
                polys = list(prop.iter(GML + "Polygon"))
                for ref in prop.iter():
                    href = ref.get(XLINK)
                    if href and href.startswith("#") and href[1:] in ids:
                        polys.append(ids[href[1:]])
                for poly in polys:
                    pl = poly.find(f"{GML}exterior/{GML}LinearRing/{GML}posList")
                    if pl is not None:
                        rings.append(np.array(pl.text.split(), dtype=float).reshape(-1, 3))
                    else:
                        pos = poly.findall(f"{GML}exterior/{GML}LinearRing/{GML}pos")
                        if pos:
                            rings.append(np.array([p.text.split() for p in pos], dtype=float))
    return rings


def triangles(rings, origin):
    out = []
    for r in rings:
        r = r - origin
        for t in ear_clip(r):
            out.append(r[list(t)])
    return np.array(out)


def frame(n):
    n = n / np.linalg.norm(n)
    a = np.array([0.0, 0.0, 1.0]) if abs(n[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    u = np.cross(a, n)
    u /= np.linalg.norm(u)
    return u, np.cross(n, u), n


def svf(tris, p, n, local_dirs):
    u, v, w = frame(n)
    dirs = local_dirs[:, :1] * u + local_dirs[:, 1:2] * v + local_dirs[:, 2:3] * w
    up = dirs[:, 2] > 0
    o = p + 0.01 * n
    # cull triangles wholly behind the POI's plane
    front = ((tris - o) @ n).max(axis=1) > 0
    b = blocked(o, dirs[up], tris[front], chunk=64)
    return (~b).sum() / len(dirs)


def main():
    k, seed, pois_csv = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3]
    rest = sys.argv[4:]
    cut = rest.index("--")
    full_files, lod_files = rest[:cut], rest[cut + 1 :]
    pois = []
    with open(pois_csv) as f:
        next(f)
        for line in f:
            i, x, y, z, nx, ny, nz = line.strip().split(",")
            pois.append((i, np.array([x, y, z], dtype=float), np.array([nx, ny, nz], dtype=float)))
    origin = np.mean([p for _, p, _ in pois], axis=0)
    full = triangles(rings_of(full_files), origin)
    lod = triangles(rings_of(lod_files), origin)
    dirs = bundle(k, seed)
    for i, p, n in pois:
        print(f"{i} {svf(full, p - origin, n, dirs):.6f} {svf(lod, p - origin, n, dirs):.6f}", flush=True)


if __name__ == "__main__":
    main()
