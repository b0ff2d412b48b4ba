#!/usr/bin/env python3
"""Read CityJSON (.city.json) and CityJSONSeq (.city.jsonl) files with cjio, the CityJSON
project's own Python library, and print what they hold as one JSON object per file.

Usage: cjio_counts.py FILE...  ->  {"FILE": {"objects": {type: n}, "semantics": {type: n},
"surfaces": n, "vertices": n, "lods": [...], "levels": {level: n}, "epsg": n}, ...}

A .city.jsonl file is read the way `cjio stdin` reads a stream (first line CityJSON, then
CityJSONFeature lines merged with CityJSON.add_cityjsonfeature); a .city.json file with
cjio.cityjson.reader. cjio's own summary (get_info) is computed too, so a file it cannot
digest fails here.

Semantic surfaces are counted per city object and type as the largest number of distinct
semantic objects of that type referenced by one of its geometries (a CityGML surface with
LoD2 and LoD3 geometry appears once in each), so the sum equals the number of CityGML
thematic surfaces and openings. A semantic object counts when a surface points to it, or when
it is the parent of one that counts (a wall made only of windows). `levels` counts the `skylod_level` values of city objects
(attributes) and of the semantic objects surfaces point to, per geometry.
"""

import json
import sys

from cjio import cityjson


def load(path):
    if path.endswith(".city.jsonl"):
        with open(path, encoding="utf-8") as f:
            first = json.loads(f.readline())
            cm = cityjson.CityJSON(j=first)
            cm.j.setdefault("CityObjects", {})
            cm.j.setdefault("vertices", [])
            for n, line in enumerate(f, start=2):
                if not line.strip():
                    continue
                feature = json.loads(line)
                if feature.get("type") != "CityJSONFeature":
                    raise SystemExit(f"{path}:{n}: not a CityJSONFeature")
                cm.add_cityjsonfeature(feature)
        return cm
    with open(path, encoding="utf-8") as f:
        return cityjson.reader(f)


def count(path):
    cm = load(path)
    cm.get_info()  # cjio's own summary: fails on what it cannot digest
    objects, semantics, levels = {}, {}, {}
    surfaces = 0
    lods = set()
    for co in cm.j["CityObjects"].values():
        objects[co["type"]] = objects.get(co["type"], 0) + 1
        lvl = co.get("attributes", {}).get("skylod_level")
        if lvl is not None:
            levels[str(lvl)] = levels.get(str(lvl), 0) + 1
        best = {}
        for g in co.get("geometry", []):
            lods.add(g["lod"])
            surfaces += len(g["boundaries"])
            sem = g.get("semantics")
            if not sem:
                continue
            used = {v for v in sem["values"] if v is not None}
            for k in used:
                s = sem["surfaces"][k]
                if "skylod_level" in s:
                    key = str(s["skylod_level"])
                    levels[key] = levels.get(key, 0) + 1
            # A surface without polygons of its own still counts as the parent of a used one
            # (a wall that is all windows).
            present = set(used)
            for k in used:
                p = sem["surfaces"][k].get("parent")
                while p is not None and p not in present:
                    present.add(p)
                    p = sem["surfaces"][p].get("parent")
            per = {}
            for k in present:
                t = sem["surfaces"][k]["type"]
                per[t] = per.get(t, 0) + 1
            for t, n in per.items():
                best[t] = max(best.get(t, 0), n)
        for t, n in best.items():
            semantics[t] = semantics.get(t, 0) + n
    return {
        "objects": objects,
        "semantics": semantics,
        "surfaces": surfaces,
        "vertices": len(cm.j["vertices"]),
        "lods": sorted(lods),
        "levels": levels,
        "epsg": cm.get_epsg(),
    }


def main():
    print(json.dumps({p: count(p) for p in sys.argv[1:]}))


if __name__ == "__main__":
    main()
