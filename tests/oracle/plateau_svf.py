#!/usr/bin/env python3
"""Independent SVF oracle for a PLATEAU (EPSG:6697: latitude, longitude, metres) CityGML
file, oracle of tests/it/crs_frames.rs.

The model's polygons are projected with pyproj to JGD2011 / Japan Plane Rectangular CS IX
(EPSG:6677; easting, northing in metres with always_xy; heights unchanged), triangulated by
ear clipping, and a cosine-weighted stratified hemisphere bundle (k x k jittered cells of the
unit disk, lifted to the hemisphere: Malley's method) is cast from each POI with a numpy
Moller-Trumbore test. SVF = share of unobstructed rays (horizontal POIs, no normal).

Which polygons: as skylod's assets at full detail: every thematic surface of a Building or
BuildingPart (bldg:boundedBy/*) at its highest LoD; a building without thematic surfaces
contributes its own highest-LoD geometry (LoD1 solid and above).

  python3 plateau_svf.py FILE.gml K SEED LAT,LON,H [LAT,LON,H ...]
prints one line per POI: "LAT,LON,H svf rays", then "triangles N holes_ignored M".
"""
import gzip
import re
import sys
import xml.etree.ElementTree as ET

import numpy as np
from pyproj import Transformer

GML = "{http://www.opengis.net/gml}"
BLDG = "{http://www.opengis.net/citygml/building/2.0}"
LOD_RE = re.compile(r"^lod(\d)(MultiSurface|Solid|Geometry|MultiCurve)$")


def local(tag):
    return tag.rsplit("}", 1)[-1]


def highest_lod_polygons(elem):
    """Rings (exterior posLists, holes counted) of the highest lodN property directly below elem."""
    best, props = -1, []
    for child in elem:
        m = LOD_RE.match(local(child.tag))
        if not m or m.group(2) == "MultiCurve":
            continue
        lod = int(m.group(1))
        if lod > best:
            best, props = lod, [child]
        elif lod == best:
            props.append(child)
    rings, holes = [], 0
    for p in props:
        for poly in p.iter(GML + "Polygon"):
            ext = poly.find(f"{GML}exterior/{GML}LinearRing/{GML}posList")
            if ext is None:
                continue
            v = np.array(ext.text.split(), dtype=float).reshape(-1, 3)
            rings.append(v)
            holes += len(poly.findall(f"{GML}interior"))
    return rings, holes


def read_root(path):
    """Parse the file; prefixes used without a declaration (PLATEAU files use `energy:`
    undeclared) get a placeholder namespace, as skylod's reader tolerates them."""
    opener = gzip.open if path.endswith(".gz") else open
    with opener(path, "rb") as f:
        text = f.read().decode("utf-8")
    used = set(re.findall(r"</?([A-Za-z_][\w.-]*):", text))
    declared = set(re.findall(r"xmlns:([A-Za-z_][\w.-]*)=", text))
    missing = sorted(used - declared - {"xml"})
    if missing:
        decl = "".join(f' xmlns:{p}="urn:undeclared:{p}"' for p in missing)
        text = re.sub(r"(<[A-Za-z_][\w.-]*:CityModel)", lambda m: m.group(1) + decl, text, count=1)
    return ET.fromstring(text)


def model_rings(path):
    root = read_root(path)
    rings, holes = [], 0
    for b in list(root.iter(BLDG + "Building")) + list(root.iter(BLDG + "BuildingPart")):
        surfaces = [s for bb in b.findall(BLDG + "boundedBy") for s in bb]
        if surfaces:
            for s in surfaces:
                r, h = highest_lod_polygons(s)
                rings += r
                holes += h
        else:
            r, h = highest_lod_polygons(b)
            rings += r
            holes += h
    return rings, holes


def ear_clip(pts3):
    """Triangles (index triples) of a simple polygon given as (n, 3) points, open ring."""
    if np.allclose(pts3[0], pts3[-1]):
        pts3 = pts3[:-1]
    n = len(pts3)
    if n < 3:
        return []
    # Newell normal, drop the dominant axis.
    nrm = np.zeros(3)
    for i in range(n):
        a, b = pts3[i], pts3[(i + 1) % n]
        nrm += [(a[1] - b[1]) * (a[2] + b[2]), (a[2] - b[2]) * (a[0] + b[0]), (a[0] - b[0]) * (a[1] + b[1])]
    ax = int(np.argmax(np.abs(nrm)))
    keep = [i for i in range(3) if i != ax]
    p = pts3[:, keep]
    signed = 0.5 * np.sum(p[:, 0] * np.roll(p[:, 1], -1) - np.roll(p[:, 0], -1) * p[:, 1])
    if signed < 0:
        p = p[:, ::-1]  # make the projected ring counter-clockwise
    idx = list(range(n))
    tris = []

    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    guard = 0
    while len(idx) > 3 and guard < 10 * n * n:
        guard += 1
        m = len(idx)
        clipped = False
        for k in range(m):
            i0, i1, i2 = idx[(k - 1) % m], idx[k], idx[(k + 1) % m]
            a, b, c = p[i0], p[i1], p[i2]
            if cross(a, b, c) <= 1e-12:
                continue
            inside = False
            for j in idx:
                if j in (i0, i1, i2):
                    continue
                q = p[j]
                if cross(a, b, q) >= 0 and cross(b, c, q) >= 0 and cross(c, a, q) >= 0:
                    inside = True
                    break
            if inside:
                continue
            tris.append((i0, i1, i2))
            idx.pop(k)
            clipped = True
            break
        if not clipped:
            # degenerate remainder: fan it
            for k in range(1, len(idx) - 1):
                tris.append((idx[0], idx[k], idx[k + 1]))
            return tris
    if len(idx) == 3:
        tris.append(tuple(idx))
    return tris


def triangles(path):
    rings, holes = model_rings(path)
    tr = Transformer.from_crs("EPSG:6668", "EPSG:6677", always_xy=True)
    out = []
    for r in rings:
        e, n = tr.transform(r[:, 1], r[:, 0])
        pts = np.column_stack([e, n, r[:, 2]])
        for t in ear_clip(pts):
            out.append(pts[list(t)])
    return np.array(out), holes, tr


def bundle(k, seed):
    rng = np.random.default_rng(seed)
    i, j = np.meshgrid(np.arange(k), np.arange(k), indexing="ij")
    u = (i.ravel() + rng.random(k * k)) / k
    v = (j.ravel() + rng.random(k * k)) / k
    r = np.sqrt(u)
    phi = 2 * np.pi * v
    return np.column_stack([r * np.cos(phi), r * np.sin(phi), np.sqrt(1 - u)])


def blocked(origin, dirs, tris, chunk=1024):
    v0, e1, e2 = tris[:, 0], tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]
    s = origin - v0  # (T, 3)
    out = np.zeros(len(dirs), dtype=bool)
    for c in range(0, len(dirs), chunk):
        d = dirs[c : c + chunk][:, None, :]  # (R, 1, 3)
        p = np.cross(d, e2[None])  # (R, T, 3)
        det = np.einsum("rtk,tk->rt", p, e1)
        ok = np.abs(det) > 1e-12
        inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
        u = np.einsum("rtk,tk->rt", p, s) * inv
        q = np.cross(s, e1)  # (T, 3)
        w = np.einsum("rk,tk->rt", d[:, 0], q) * inv
        t = np.einsum("tk,tk->t", e2, q)[None] * inv
        hit = ok & (u >= 0) & (w >= 0) & (u + w <= 1) & (t > 1e-6)
        out[c : c + chunk] = hit.any(axis=1)
    return out


def main():
    path, k, seed = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
    tris, holes, tr = triangles(path)
    dirs = bundle(k, seed)
    for arg in sys.argv[4:]:
        lat, lon, h = (float(x) for x in arg.split(","))
        e, n = tr.transform(lon, lat)
        # Rays go upwards: triangles wholly below the POI cannot be hit.
        above = tris[tris[:, :, 2].max(axis=1) > h]
        b = blocked(np.array([e, n, h]), dirs, above)
        print(f"{arg} {1.0 - b.mean():.6f} {len(dirs)}")
    print(f"triangles {len(tris)} holes_ignored {holes}")


if __name__ == "__main__":
    main()
