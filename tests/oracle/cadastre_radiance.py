#!/usr/bin/env python3
"""Annual irradiation of cadastre points of a CityGML file by Radiance's daylight
coefficients, with the geometry this script reads and writes itself: the oracle of
`skylod irradiance --surfaces` in tests/it/cadastre.rs.

Usage: cadastre_radiance.py TMY3.csv MODEL.gml[.gz] POINTS.csv [EPSG]
  -> {"id": {"global_kwh_m2": .., "direct_kwh_m2": .., "diffuse_kwh_m2": ..}, ..} (JSON)

POINTS.csv: id,x,y,z,nx,ny,nz, positions and normals in the model's axes. With EPSG (the
model's geographic CRS, latitude first: 6697), positions are converted by pyproj to a
transverse Mercator centred on the points, whose axes are east, north and up there, and a
normal's (north, east, up) becomes (east, north, up).

The scene: every `Building` and `BuildingPart` (not descending into nested parts) as the
polygons of its most detailed LoD from 1 up (every `lodN…` property under it, xlinks to
polygons resolved, each polygon once), read with Python's XML parser and written as
Radiance `polygon`s (interior rings joined to their exterior by a seam) in a frame at the
first point. The diffuse part: the daylight coefficients of irradiance_radiance.py
(`annual`: Perez all-weather sky without the sun on 2 305 patches, every surface and the
ground black). The direct part: the sun as a ray per hour, as skylod documents it, from
independent parts: pvlib's solar position at the middle of each hour (apparent zenith),
DNI x cos(incidence) where Radiance's `rtrace` finds the ray from the point to the sun
free (it reaches the sky's glow, value 1, rather than a black surface); gendaymtx's `-d`
would spread the sun over the patches around it, blurring a shadow's edge by degrees.
Global = direct + diffuse.
"""

import csv
import gzip
import json
import os
import re
import sys
import tempfile
import xml.etree.ElementTree as ET

import numpy as np

from irradiance_radiance import annual
import subprocess

from radiance_svf import LIB, tool

GML = "{http://www.opengis.net/gml}"
XLINK = "{http://www.w3.org/1999/xlink}href"
LOD = re.compile(r"lod(\d)")
BUILDINGS = ("Building", "BuildingPart")


def local(tag):
    return tag.rsplit("}", 1)[-1]


def rings_of(polygon, convert):
    """The exterior and interior rings of a gml:Polygon as n x 3 arrays (closing point off)."""
    out = []
    for r in [polygon.find(f"{GML}exterior"), *polygon.findall(f"{GML}interior")]:
        pl = r.find(f".//{GML}posList")
        if pl is not None:
            v = np.array(pl.text.split(), float)
        else:
            v = np.array([float(x) for p in r.iter(f"{GML}pos") for x in p.text.split()])
        v = convert(v.reshape(-1, 3))
        if len(v) > 1 and np.allclose(v[0], v[-1]):
            v = v[:-1]
        out.append(v)
    return out


def seamed(rings):
    """One loop of points: the exterior, each hole entered from its nearest exterior point
    and left back to it (Radiance's way of a polygon with holes)."""
    loop = [p for p in rings[0]]
    for hole in rings[1:]:
        d = [np.linalg.norm(hole - q, axis=1) for q in loop]
        i = int(np.argmin([x.min() for x in d]))
        j = int(np.argmin(d[i]))
        h = [hole[(j + k) % len(hole)] for k in range(len(hole))] + [hole[j]]
        loop = loop[: i + 1] + h + loop[i:]
    return loop


def scene_polygons(root, convert):
    """Each building's (or part's) polygons of its most detailed LoD from 1 up."""
    polygons = {p.get(f"{GML}id"): p for p in root.iter(f"{GML}Polygon") if p.get(f"{GML}id")}

    def own(el):
        """el's descendants, not entering nested buildings."""
        for child in el:
            if local(child.tag) in BUILDINGS:
                continue
            yield child
            yield from own(child)

    out = []
    for b in root.iter():
        if local(b.tag) not in BUILDINGS:
            continue
        by_lod = {}
        for prop in own(b):
            m = LOD.match(local(prop.tag))
            if not m or int(m.group(1)) < 1:
                continue
            found = by_lod.setdefault(int(m.group(1)), {})
            for el in prop.iter():
                if local(el.tag) == "Polygon":
                    found[id(el)] = el
                href = (el.get(XLINK) or "").lstrip("#")
                if href in polygons:
                    found[id(polygons[href])] = polygons[href]
        if by_lod:
            out.extend(rings_of(p, convert) for p in by_lod[max(by_lod)].values())
    return out


def main():
    tmy3, model, points_csv = sys.argv[1:4]
    pois = []
    with open(points_csv, encoding="utf-8", newline="") as f:
        for row in csv.DictReader(f):
            pois.append((row["id"], [float(row[k]) for k in "xyz"],
                         [float(row[k]) for k in ("nx", "ny", "nz")]))
    convert = lambda v: v
    if len(sys.argv) > 4:
        pois = [(i, p, [n[1], n[0], n[2]]) for i, p, n in pois]
        from pyproj import Transformer

        lat = np.mean([p[0] for _, p, _ in pois])
        lon = np.mean([p[1] for _, p, _ in pois])
        t = Transformer.from_crs(
            f"EPSG:{sys.argv[4]}",
            f"+proj=tmerc +lat_0={lat} +lon_0={lon} +k=1 +x_0=0 +y_0=0 +ellps=GRS80 +units=m",
        )

        def convert(v):
            x, y = t.transform(v[:, 0], v[:, 1])
            return np.column_stack([x, y, v[:, 2]])

    opener = gzip.open if model.endswith(".gz") else open
    with opener(model, "rb") as f:
        root = ET.parse(f).getroot()
    polys = scene_polygons(root, convert)
    first = convert(np.array([pois[0][1]]))[0]
    with tempfile.TemporaryDirectory() as tmp:
        rad = os.path.join(tmp, "model.rad")
        with open(rad, "w", encoding="utf-8") as f:
            for k, rings in enumerate(polys):
                loop = seamed([r - first for r in rings])
                if len(loop) < 3:
                    continue
                f.write(f"black polygon p{k}\n0\n0\n{3 * len(loop)}\n")
                for q in loop:
                    f.write(f"  {float(q[0])!r} {float(q[1])!r} {float(q[2])!r}\n")
        rays = []
        for _, p, n in pois:
            # the points lie 5 cm out of their surface already: the same origins as skylod's
            o = convert(np.array([p]))[0] - first
            rays.append(" ".join(repr(float(v)) for v in (*o, *n)))
        values = annual(tmy3, tmp, [rad], {"black"}, rays)
        for v, d in zip(values, direct(tmy3, os.path.join(tmp, "scene.oct"), rays)):
            v["direct_kwh_m2"] = d
            v["global_kwh_m2"] = d + v["diffuse_kwh_m2"]
    print(json.dumps({pid: v for (pid, _, _), v in zip(pois, values)}))


def direct(tmy3, octree, rays):
    """Each ray origin's annual direct irradiation (kWh/m2) on the plane of its direction."""
    import pvlib

    data, meta = pvlib.iotools.read_tmy3(tmy3, map_variables=True)
    times = data.index - np.timedelta64(30, "m")
    sp = pvlib.solarposition.get_solarposition(times, meta["latitude"], meta["longitude"])
    zen = np.radians(sp["apparent_zenith"].to_numpy())
    azi = np.radians(sp["azimuth"].to_numpy())
    dni = data["dni"].to_numpy(dtype=float)
    sun = np.column_stack([np.sin(zen) * np.sin(azi), np.sin(zen) * np.cos(azi), np.cos(zen)])
    lit = (zen < np.pi / 2) & (dni > 0)
    queries, weights = [], []
    for k, ray in enumerate(rays):
        v = np.array(ray.split(), float)
        o, n = v[:3], v[3:]
        cos = sun @ n
        for h in np.nonzero(lit & (cos > 0))[0]:
            queries.append(" ".join(repr(float(x)) for x in (*o, *sun[h])))
            weights.append((k, dni[h] * cos[h]))
    env = dict(os.environ, RAYPATH=os.pathsep.join([".", LIB]))
    out = subprocess.run(
        [tool("rtrace"), "-h", "-ab", "0", "-av", "0", "0", "0", "-ov", octree],
        input=("\n".join(queries) + "\n").encode(), check=True, capture_output=True, env=env,
    ).stdout.decode().split()
    free = np.array(out, float).reshape(-1, 3).mean(axis=1) > 0.5
    total = np.zeros(len(rays))
    for (k, w), f in zip(weights, free):
        total[k] += w * f
    return list(total / 1000.0)


if __name__ == "__main__":
    main()
