#!/usr/bin/env python3
"""What skylod should find in CityJSON (.city.json) and CityJSONSeq (.city.jsonl) files,
computed independently of skylod from the JSON itself, with the mapping of DESIGN.md
("CityGML -> assets", as CityJSON's semantic surfaces): one JSON object per file.

Usage: cityjson_assets.py FILE...  ->  {"FILE": {"buildings": n, "building_parts": n,
"assets": n, "polygons": n, "roof": n, "wall": n, ..., "installations": n, "bodies": n,
"others": n, "lods": [...], "bbox": [minx, miny, minz, maxx, maxy, maxz]}, ...}

Rules (the ones skylod documents in src/cityjson/map.rs):
* Building / BuildingPart: the semantic objects of the object's most detailed geometries
  (highest "lod" as a number) that some surface points to, or that are the parent of such an
  opening, are one asset each (Roof/Wall/Ground/Closure/OuterCeiling/OuterFloor surfaces,
  Window, Door); when none of an object's geometries gives a shell surface, its geometries
  are one Body asset (all of them: polygons of every LoD count).
* BuildingInstallation / BuildingConstructiveElement and every other type with polygons
  (not BuildingRoom, BuildingStorey, BuildingUnit, BuildingFurniture, CityObjectGroup): one
  asset with all its polygons.
* GeometryInstance: the template's polygons (matrix, then the reference point).
The file is also loaded with cjio (the CityJSON project's library) when it is a .city.json,
so that a file cjio cannot read fails here.
"""

import json
import sys

SHELL = {"RoofSurface": "roof", "WallSurface": "wall", "GroundSurface": "ground",
         "ClosureSurface": "closure", "OuterCeilingSurface": "outer_ceiling",
         "OuterFloorSurface": "outer_floor"}
OPENING = {"Window": "window", "Door": "door"}
INTERIOR = {"BuildingRoom", "BuildingStorey", "BuildingUnit", "BuildingFurniture",
            "CityObjectGroup"}


def surfaces(g, templates):
    """[(rings, semantic index)] of a geometry, and its semantics object."""
    t = g["type"]
    if t == "GeometryInstance":
        return surfaces(templates["templates"][g["template"]], templates)
    b = g.get("boundaries", [])
    v = (g.get("semantics") or {}).get("values")
    out = []
    if t in ("MultiSurface", "CompositeSurface"):
        for k, s in enumerate(b):
            out.append((s, v[k] if v else None))
    elif t == "Solid":
        for i, sh in enumerate(b):
            for k, s in enumerate(sh):
                out.append((s, v[i][k] if v and v[i] else None))
    elif t in ("MultiSolid", "CompositeSolid"):
        for j, so in enumerate(b):
            for i, sh in enumerate(so):
                for k, s in enumerate(sh):
                    out.append((s, v[j][i][k] if v and v[j] and v[j][i] else None))
    return [(r, s) for r, s in out if len(r) and len(r[0]) >= 3], g.get("semantics")


def lod(g, templates):
    if g["type"] == "GeometryInstance":
        g = templates["templates"][g["template"]]
    return float(g["lod"])


def count(objects, templates, res):
    for oid, o in objects.items():
        ty = o["type"]
        geoms = o.get("geometry", [])
        polys = [(g, *surfaces(g, templates)) for g in geoms]
        n_all = sum(len(p) for _, p, _ in polys)
        if ty in ("Building", "BuildingPart"):
            res["buildings" if ty == "Building" else "building_parts"] += 1
            with_polys = [lod(g, templates) for g, p, _ in polys if p]
            # every LoD of a building's geometry (its own geometry included)
            res["lods"].update(int(l) for l in with_polys)
            best = max(with_polys) if with_polys else None
            shell = 0
            for g, p, sem in polys:
                if not p or lod(g, templates) != best or not sem:
                    continue
                types = [s["type"] for s in sem.get("surfaces", [])]
                used = {}
                for _, k in p:
                    if k is not None and k < len(types) and (types[k] in SHELL or types[k] in OPENING):
                        used[k] = used.get(k, 0) + 1
                for k in list(used):
                    par = sem["surfaces"][k].get("parent")
                    if par is not None and par < len(types) and par not in used and (types[par] in SHELL or types[par] in OPENING):
                        used[par] = 0
                for k, n in used.items():
                    kind = SHELL.get(types[k]) or OPENING.get(types[k])
                    res[kind] += 1
                    res["assets"] += 1
                    res["polygons"] += n
                    shell += types[k] in SHELL
                    res["lods"].add(int(lod(g, templates)))
            if shell == 0 and n_all:
                res["bodies"] += 1
                res["assets"] += 1
                res["polygons"] += n_all
                res["lods"].update(int(lod(g, templates)) for g, p, _ in polys if p)
        elif ty in INTERIOR or n_all == 0:
            continue
        else:
            key = "installations" if ty in ("BuildingInstallation", "BuildingConstructiveElement") else "others"
            res[key] += 1
            res["assets"] += 1
            res["polygons"] += n_all
            res["lods"].update(int(lod(g, templates)) for g, p, _ in polys if p)


def one(path):
    res = {k: 0 for k in ["buildings", "building_parts", "assets", "polygons", "installations",
                          "bodies", "others", *SHELL.values(), *OPENING.values()]}
    res["lods"] = set()
    with open(path, encoding="utf-8") as f:
        if path.endswith(".jsonl"):
            lines = [json.loads(l) for l in f if l.strip()]
        else:
            lines = [json.load(f)]
    head = lines[0]
    templates = head.get("geometry-templates", {})
    for d in lines:
        count(d.get("CityObjects", {}), templates, res)
    if not path.endswith(".jsonl"):
        try:
            from cjio import cityjson
        except ImportError:
            pass
        else:
            with open(path, encoding="utf-8") as f:
                cm = cityjson.reader(f, ignore_duplicate_keys=True)
            cm.get_info()
    res["lods"] = sorted(res["lods"])
    return res


if __name__ == "__main__":
    print(json.dumps({p: one(p) for p in sys.argv[1:]}))
