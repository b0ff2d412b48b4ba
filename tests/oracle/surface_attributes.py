#!/usr/bin/env python3
"""Oracle of `skylod irradiance --output-attributes` (tests/it/irradiance_lod.rs): which
surface holds each POI, from the written model's own geometry, and the mean of the POIs'
`global_kwh_m2` per surface against the attribute written there.

Usage: surface_attributes.py OUT.gml|OUT.city.json IRRADIANCE.json OFFSET
  -> {"surfaces": n with the attribute, "held": POIs found on a surface,
      "max_rel": largest |attribute - mean| / mean, "missing": surfaces holding POIs without
      the attribute, "stray": surfaces with the attribute and no POI, "values": the
      attributes, sorted}

A POI is held by a surface when the point OFFSET metres behind it (along its normal
reversed) lies within 3 cm of the mean plane of one of the surface's polygons (real LoD3
polygons are not quite planar) and inside its exterior ring or within 2 mm of it (2D test in
the plane); of several (a POI on the edge between a wall and a roof) those with a polygon
within 25 degrees of the POI's plane, then (coincident duplicate walls, in the Ingolstadt
data) the one whose plane is nearest behind the POI. CityGML: every element ending in `Surface` with
`lodN…` geometry, its gml:Polygons (xlinks resolved), the attribute read from its
gen:doubleAttribute; CityJSON: the semantic surfaces of every geometry, their polygons by
the `values` array, the attribute read from the semantic object.
"""
import gzip
import json
import sys
import xml.etree.ElementTree as ET

import numpy as np

GML = "{http://www.opengis.net/gml}"
XLINK = "{http://www.w3.org/1999/xlink}href"
NAME = "skylodAnnualIrradiation"


def local(tag):
    return tag.rsplit("}", 1)[-1]


def gml_surfaces(path):
    opener = gzip.open if path.endswith(".gz") else open
    with opener(path, "rb") as f:
        root = ET.parse(f).getroot()
    by_id = {e.get(GML + "id"): e for e in root.iter() if e.get(GML + "id")}

    def rings(elem):
        out = []
        for poly in elem.iter(GML + "Polygon"):
            ext = poly.find(GML + "exterior")
            pos = ext.find(".//" + GML + "posList") if ext is not None else None
            if pos is not None:
                v = np.array(pos.text.split(), dtype=float).reshape(-1, 3)
                out.append(v)
        for sm in elem.iter(GML + "surfaceMember"):
            ref = sm.get(XLINK)
            if ref and ref.lstrip("#") in by_id:
                out.extend(rings(by_id[ref.lstrip("#")]))
        return out

    out = []
    for e in root.iter():
        if not local(e.tag).endswith("Surface") or e.tag.startswith(GML):
            continue
        polys = []
        for child in e:
            if local(child.tag).startswith("lod"):
                polys.extend(rings(child))
        if not polys:
            continue
        value = None
        for child in e:
            if local(child.tag) == "doubleAttribute" and child.get("name") == NAME:
                value = float(child.find("{*}value").text)
        out.append((polys, value))
    return out


def cityjson_surfaces(path):
    doc = json.load(open(path))
    t = doc["transform"]
    verts = np.array(doc["vertices"], dtype=float) * t["scale"] + t["translate"]
    out = []
    for obj in doc["CityObjects"].values():
        for g in obj.get("geometry", []):
            sem = g.get("semantics")
            if not sem or g["type"] != "MultiSurface":
                continue
            polys = {k: [] for k in range(len(sem["surfaces"]))}
            for b, v in zip(g["boundaries"], sem["values"]):
                if v is not None:
                    polys[v].append(verts[b[0]])
            for k, s in enumerate(sem["surfaces"]):
                if polys[k]:
                    out.append((polys[k], s.get(NAME)))
    return out


def normal(ring):
    n = np.zeros(3)
    for a, b in zip(ring, np.roll(ring, -1, axis=0)):
        n += np.cross(a, b)
    norm = np.linalg.norm(n)
    return n / norm if norm > 0 else None


def on_polygon(q, ring):
    n = normal(ring)
    if n is None:
        return False
    if abs(np.dot(q - ring.mean(axis=0), n)) > 0.03:
        return False
    u = np.cross(n, [0, 0, 1.0])
    if np.linalg.norm(u) < 1e-9:
        u = np.array([1.0, 0, 0])
    u /= np.linalg.norm(u)
    v = np.cross(n, u)
    p2 = np.stack([(ring - ring[0]) @ u, (ring - ring[0]) @ v], axis=1)
    x, y = (q - ring[0]) @ u, (q - ring[0]) @ v
    inside = False
    for (x1, y1), (x2, y2) in zip(p2, np.roll(p2, -1, axis=0)):
        if (y1 > y) != (y2 > y) and x < x1 + (y - y1) * (x2 - x1) / (y2 - y1):
            inside = not inside
        # within 2 mm of the edge counts as on it
        e = np.array([x2 - x1, y2 - y1])
        t = np.clip(np.dot([x - x1, y - y1], e) / max(np.dot(e, e), 1e-18), 0, 1)
        if np.hypot(x - x1 - t * e[0], y - y1 - t * e[1]) < 0.002:
            return True
    return inside


def main():
    out, rows, offset = sys.argv[1], json.load(open(sys.argv[2]))["pois"], float(sys.argv[3])
    surfaces = cityjson_surfaces(out) if out.endswith(".json") else gml_surfaces(out)
    values = {k: [] for k in range(len(surfaces))}
    held = 0
    for r in rows:
        n = np.array(r["normal"])
        q = np.array(r["poi"]) - offset * n
        holders = [k for k, (polys, _) in enumerate(surfaces)
                   if any(on_polygon(q, ring) for ring in polys)]
        aligned = [k for k in holders
                   if any(abs(np.dot(normal(ring), n)) > 0.9 for ring in surfaces[k][0]
                          if normal(ring) is not None)]
        def behind(k):
            return min(abs(np.dot(np.array(r["poi"]) - ring.mean(axis=0), normal(ring)))
                       for ring in surfaces[k][0] if normal(ring) is not None and
                       on_polygon(q, ring))

        pick = sorted(aligned or holders, key=behind)[:1]
        for k in pick:
            values[k].append(r["global_kwh_m2"])
            held += 1
    max_rel, missing, stray = 0.0, 0, 0
    for k, (_, attr) in enumerate(surfaces):
        if values[k] and attr is None:
            missing += 1
        elif attr is not None and not values[k]:
            stray += 1
        elif attr is not None:
            mean = sum(values[k]) / len(values[k])
            max_rel = max(max_rel, abs(attr - mean) / abs(mean) if mean else abs(attr))
    n = sum(1 for _, a in surfaces if a is not None)
    print(json.dumps({"surfaces": n, "held": held, "max_rel": max_rel, "missing": missing,
                      "stray": stray,
                      "values": sorted(a for _, a in surfaces if a is not None)}))


if __name__ == "__main__":
    main()
