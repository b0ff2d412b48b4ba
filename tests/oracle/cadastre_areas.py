#!/usr/bin/env python3
"""Oracle of the areas in `skylod irradiance --surfaces … --table` (tests/it/cadastre.rs): the
area of every roof and wall of a CityGML file, read with Python's XML parser and numpy.

Usage: cadastre_areas.py FILE.gml[.gz] [FROM_EPSG TO_EPSG]
  -> {"surface name": area_m2, ...} (JSON)

A `RoofSurface` or `WallSurface` with a gml:id: the polygons of its most detailed `lodN…`
geometry (xlinks to polygons resolved), each polygon's area |Newell normal of the exterior|/2
less that of its holes. A building (or part) without thematic surfaces: the polygons of its
most detailed `lodNSolid` / `lodNMultiSurface`, split by their unit normal into `<id>:roof`
(n.z > 0.25) and `<id>:wall` (|n.z| <= 0.25). With two EPSG codes the coordinates are first
converted by pyproj (e.g. 6697, latitude-longitude-height, to a UTM zone in metres).
"""
import gzip
import json
import re
import sys
import xml.etree.ElementTree as ET

import numpy as np

GML = "{http://www.opengis.net/gml}"
XLINK = "{http://www.w3.org/1999/xlink}href"
LOD = re.compile(r"lod(\d)")


def local(tag):
    return tag.rsplit("}", 1)[-1]


def main():
    path = sys.argv[1]
    convert = None
    if len(sys.argv) == 4:
        from pyproj import Transformer

        t = Transformer.from_crs(f"EPSG:{sys.argv[2]}", f"EPSG:{sys.argv[3]}")

        def convert(v):
            x, y = t.transform(v[:, 0], v[:, 1])
            return np.column_stack([x, y, v[:, 2]])

    opener = gzip.open if path.endswith(".gz") else open
    with opener(path, "rb") as f:
        root = ET.parse(f).getroot()
    polygons = {p.get(f"{GML}id"): p for p in root.iter(f"{GML}Polygon") if p.get(f"{GML}id")}

    def ring(r):
        pl = r.find(f".//{GML}posList")
        if pl is not None:
            v = np.array(pl.text.split(), float)
        else:
            v = np.array([float(x) for p in r.iter(f"{GML}pos") for x in p.text.split()])
        v = v.reshape(-1, 3)
        return convert(v) if convert else v

    def newell(v):
        return np.cross(v, np.roll(v, -1, axis=0)).sum(axis=0)

    def polys_of(geom_prop):
        out = []
        for el in geom_prop.iter():
            if local(el.tag) == "Polygon":
                out.append(el)
            href = el.get(XLINK)
            if href and href.lstrip("#") in polygons:
                out.append(polygons[href.lstrip("#")])
        return out

    def area_normal(p):
        ext = p.find(f"{GML}exterior")
        n = newell(ring(ext))
        a = np.linalg.norm(n) / 2
        unit = n / (2 * a) if a > 0 else n
        for h in p.findall(f"{GML}interior"):
            a -= abs(newell(ring(h)) @ unit) / 2
        return a, unit

    def best_geometry(el, kinds):
        """The polygons of el's most detailed lodN property among `kinds` (by local name)."""
        best, lod = [], -1
        for child in el:
            name = local(child.tag)
            m = LOD.match(name)
            if m and any(name.endswith(k) for k in kinds) and int(m.group(1)) > lod:
                ps = polys_of(child)
                if ps:
                    best, lod = ps, int(m.group(1))
        return best

    out = {}
    surfaces = ("MultiSurface", "Solid", "CompositeSurface", "MultiGeometry", "Geometry")
    for el in root.iter():
        name = local(el.tag)
        if name in ("RoofSurface", "WallSurface") and el.get(f"{GML}id"):
            out[el.get(f"{GML}id")] = sum(area_normal(p)[0] for p in best_geometry(el, surfaces))
        elif name in ("Building", "BuildingPart") and el.get(f"{GML}id"):
            has_surfaces = any(local(d.tag).endswith("Surface") and local(d.tag)[0].isupper()
                               and local(d.tag) not in ("MultiSurface", "CompositeSurface")
                               for d in el.iter() if d is not el)
            if has_surfaces:
                continue
            roof = wall = 0.0
            for p in best_geometry(el, ("Solid", "MultiSurface")):
                a, n = area_normal(p)
                if n[2] > 0.25:
                    roof += a
                elif n[2] >= -0.25:
                    wall += a
            bid = el.get(f"{GML}id")
            if roof > 0:
                out[f"{bid}:roof"] = roof
            if wall > 0:
                out[f"{bid}:wall"] = wall
    json.dump(out, sys.stdout)


if __name__ == "__main__":
    main()
