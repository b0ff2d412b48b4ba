#!/usr/bin/env python3
"""Independent counts of a CityJSON / CityJSONSeq document and of the CityGML skylod wrote
from it (`skylod convert x.city.json -o x.gml`): Python's json and xml.etree only.

Usage: citygml_from_cityjson.py SRC.city.json[l] OUT.gml [SRC OUT ...]
Prints a JSON list, one {"cityjson": counts, "citygml": counts} per pair, with counts:
  objects      city objects by CityGML 2.0 element (the documented mapping of types)
  semantic     polygons by thematic surface / opening (LoD 2 and 3 semantic surfaces of the
               features that have thematic surfaces; a LoD 2 opening counts as its parent)
  polygons     polygons (exterior of 3 or more vertices; a TIN's triangles), templates once
               per instance
  coordinates  coordinate tuples of rings (closed) and lines
  attributes   city object attributes (not null)
"""
import gzip
import json
import sys
import xml.etree.ElementTree as ET

TYPES = {
    "Building": "Building", "BuildingPart": "BuildingPart",
    "BuildingInstallation": "BuildingInstallation", "Bridge": "Bridge",
    "BridgePart": "BridgePart", "BridgeInstallation": "BridgeInstallation",
    "BridgeConstructiveElement": "BridgeConstructionElement",
    "BridgeConstructionElement": "BridgeConstructionElement", "Tunnel": "Tunnel",
    "TunnelPart": "TunnelPart", "TunnelInstallation": "TunnelInstallation",
    "CityFurniture": "CityFurniture", "SolitaryVegetationObject": "SolitaryVegetationObject",
    "PlantCover": "PlantCover", "LandUse": "LandUse", "WaterBody": "WaterBody",
    "Road": "Road", "Railway": "Railway", "TransportSquare": "Square",
    "TINRelief": "TINRelief", "GenericCityObject": "GenericCityObject",
    "OtherConstruction": "GenericCityObject", "Waterway": "GenericCityObject",
    "CityObjectGroup": "CityObjectGroup",
}
BOUNDARY = {"RoofSurface", "WallSurface", "GroundSurface", "ClosureSurface",
            "OuterCeilingSurface", "OuterFloorSurface", "FloorSurface",
            "InteriorWallSurface", "CeilingSurface"}
FAMILY = {}
for t in ["Building", "BuildingPart", "BuildingInstallation", "Bridge", "BridgePart",
          "BridgeInstallation", "BridgeConstructiveElement", "BridgeConstructionElement",
          "Tunnel", "TunnelPart", "TunnelInstallation"]:
    FAMILY[t] = (BOUNDARY, True)
FAMILY["WaterBody"] = ({"WaterSurface", "WaterGroundSurface", "WaterClosureSurface"}, False)
for t in ["Road", "Railway", "TransportSquare"]:
    FAMILY[t] = ({"TrafficArea", "AuxiliaryTrafficArea"}, False)
THEMATIC = set().union(*[s for s, _ in FAMILY.values()]) | {"Window", "Door"}


def values_of(geom):
    """(surface rings, semantic index) of every polygon of a geometry, in order."""
    b, sem = geom.get("boundaries", []), (geom.get("semantics") or {}).get("values")
    t = geom["type"]

    def at(v, *ks):
        for k in ks:
            if not isinstance(v, list) or k >= len(v):
                return None
            v = v[k]
        return v if isinstance(v, int) else None
    if t in ("MultiSurface", "CompositeSurface"):
        return [(s, at(sem, i)) for i, s in enumerate(b)]
    if t == "Solid":
        return [(s, at(sem, i, j)) for i, sh in enumerate(b) for j, s in enumerate(sh)]
    if t in ("MultiSolid", "CompositeSolid"):
        return [(s, at(sem, i, j, k)) for i, so in enumerate(b) for j, sh in enumerate(so)
                for k, s in enumerate(sh)]
    return []


def lod_of(g):
    try:
        v = float(g.get("lod"))
    except (TypeError, ValueError):
        return None
    return int(v) if 0 <= v < 4 else None


def ring_tuples(surface):
    if not surface or len(surface[0]) < 3:
        return 0, 0
    return 1, sum(len(r) + 1 for r in surface if len(r) >= 3)


def cityjson_counts(path):
    op = gzip.open if open(path, "rb").read(2) == b"\x1f\x8b" else open
    with op(path, "rt", encoding="utf-8-sig") as f:
        text = f.read()
    dec, values, i = json.JSONDecoder(), [], 0
    while i < len(text):
        while i < len(text) and text[i].isspace():
            i += 1
        if i >= len(text):
            break
        v, i = dec.raw_decode(text, i)
        values.append(v)
    templates = (values[0].get("geometry-templates") or {}).get("templates", [])
    c = {"objects": {}, "semantic": {}, "polygons": 0, "coordinates": 0, "attributes": 0}
    for doc in values:
        for key, o in doc.get("CityObjects", {}).items():
            ty = o["type"]
            el = TYPES.get(ty, "GenericCityObject" if ty.startswith("+") else None)
            if el is None:
                continue
            c["objects"][el] = c["objects"].get(el, 0) + 1
            attrs = o.get("attributes") or {}
            c["attributes"] += sum(1 for v in attrs.values() if v is not None)
            fam = FAMILY.get(ty)
            for g in o.get("geometry", []):
                if g["type"] == "GeometryInstance":
                    t = templates[g["template"]] if g.get("template") is not None else None
                    if t is not None and lod_of(t) is not None:
                        for s, _ in values_of(t):
                            n, k = ring_tuples(s)
                            c["polygons"] += n
                            c["coordinates"] += k
                    continue
                lod = lod_of(g)
                if lod is None:
                    continue
                if g["type"] == "MultiLineString":
                    c["coordinates"] += sum(len(l) for l in g["boundaries"] if len(l) >= 2)
                surfaces = (g.get("semantics") or {}).get("surfaces", [])
                for s, si in values_of(g):
                    if ty == "TINRelief":
                        if s and len(s[0]) >= 3:
                            c["polygons"] += len(s[0]) - 2
                            c["coordinates"] += 4 * (len(s[0]) - 2)
                        continue
                    n, k = ring_tuples(s)
                    c["polygons"] += n
                    c["coordinates"] += k
                    if not n or fam is None or lod < 2 or si is None or si >= len(surfaces):
                        continue
                    st = surfaces[si].get("type")
                    kinds, openings = fam
                    if st in kinds:
                        kind = st
                    elif openings and st in ("Window", "Door"):
                        p = surfaces[si].get("parent")
                        ok = isinstance(p, int) and p < len(surfaces) and surfaces[p].get("type") in kinds
                        if not ok:
                            continue
                        kind = st if lod >= 3 else surfaces[p]["type"]
                    else:
                        continue
                    c["semantic"][kind] = c["semantic"].get(kind, 0) + 1
            if ty == "TINRelief" and not any(values_of(g) for g in o.get("geometry", [])):
                c["objects"][el] -= 1
    c["objects"] = {k: v for k, v in c["objects"].items() if v}
    return c


def local(tag):
    return tag.rsplit("}", 1)[-1]


def citygml_counts(path):
    root = ET.parse(path).getroot()
    features = set(TYPES.values())
    gml = "{http://www.opengis.net/gml}"
    c = {"objects": {}, "semantic": {}, "polygons": 0, "coordinates": 0, "attributes": 0}
    for e in root.iter():
        name = local(e.tag)
        if name in features and e.get(gml + "id") is not None:
            c["objects"][name] = c["objects"].get(name, 0) + 1
            names = set()
            for ch in e:
                ln = local(ch.tag)
                if ln.endswith("Attribute") and ch.tag.startswith("{http://www.opengis.net/citygml/generics"):
                    if ch.get("name") != "cityjson_type":
                        c["attributes"] += 1
                elif ln in ("class", "function", "usage", "yearOfConstruction", "yearOfDemolition",
                            "roofType", "measuredHeight", "storeysAboveGround",
                            "storeysBelowGround", "isMovable", "species", "height",
                            "averageHeight", "trunkDiameter", "crownDiameter"):
                    names.add(ln)
            c["attributes"] += len(names)
        if name in THEMATIC and e.tag.startswith("{http://www.opengis.net/citygml/"):
            n = sum(1 for ch in e if local(ch.tag).startswith("lod")
                    for p in ch.iter(gml + "Polygon"))
            if n:
                c["semantic"][name] = c["semantic"].get(name, 0) + n
        if e.tag in (gml + "Polygon", gml + "Triangle"):
            c["polygons"] += 1
        if e.tag == gml + "posList" and e.text:
            c["coordinates"] += len(e.text.split()) // 3
    return c


def main(args):
    out = []
    for src, gml in zip(args[::2], args[1::2]):
        out.append({"source": src, "cityjson": cityjson_counts(src), "citygml": citygml_counts(gml)})
    json.dump(out, sys.stdout)


if __name__ == "__main__":
    main(sys.argv[1:])
