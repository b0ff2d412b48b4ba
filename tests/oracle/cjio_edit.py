#!/usr/bin/env python3
"""cjio's own subset and LoD filter of a CityJSON file, to compare with skylod's `subset` and
`filter-lods` on the same input (tests/it/cityjson_input.rs).

Usage:
  cjio_edit.py bbox FILE X0 Y0 X1 Y1   ->  {"top": [ids], "objects": [ids], "vertices": n}
      cjio's `subset --bbox` (CityJSON.get_subset_bbox: a city object whose vertex centroid
      lies in [X0, X1) x [Y0, Y1), with its children and parents).
  cjio_edit.py radius FILE X Y R       ->  the same for cjio's `subset --radius`
      (CityJSON.get_subset_radius: a vertex centroid closer than R to (X, Y)).
  cjio_edit.py ids FILE ID...          ->  the same for cjio's `subset --id` (get_subset_ids:
      the objects named, with their children and parents), to check what `subset --random`
      keeps of the top-level objects it drew (cjio draws its own unseeded, so its ids
      cannot be compared).
  cjio_edit.py lod FILE LOD            ->  {"objects": {id: [lod, ...]}, "vertices": n}
      cjio's `lod_filter LOD` (CityJSON.filter_lod: geometries whose lod, as text, is not
      LOD removed; city objects are kept, even left without geometry).
  cjio_edit.py info FILE               ->  {"objects": {type: n}, "vertices": n, "lods": [..]}

`vertices` is the number of vertices of cjio's result (cjio drops unused and duplicate ones).
"""

import json
import sys

from cjio import cityjson


def load(path):
    with open(path, encoding="utf-8") as f:
        return cityjson.reader(f)


def top(j):
    return sorted(i for i, co in j["CityObjects"].items() if not co.get("parents"))


def main():
    what, path = sys.argv[1], sys.argv[2]
    cm = load(path)
    if what == "bbox":
        box = [float(x) for x in sys.argv[3:7]]
        j = cm.get_subset_bbox(box).j
        out = {"top": top(j), "objects": sorted(j["CityObjects"]), "vertices": len(j["vertices"])}
    elif what == "radius":
        x, y, r = (float(v) for v in sys.argv[3:6])
        j = cm.get_subset_radius(x, y, r).j
        out = {"top": top(j), "objects": sorted(j["CityObjects"]), "vertices": len(j["vertices"])}
    elif what == "ids":
        j = cm.get_subset_ids(sys.argv[3:]).j
        out = {"top": top(j), "objects": sorted(j["CityObjects"]), "vertices": len(j["vertices"])}
    elif what == "lod":
        cm.filter_lod(sys.argv[3])
        j = cm.j
        out = {
            "objects": {
                i: sorted(str(g["lod"]) for g in co.get("geometry", []))
                for i, co in j["CityObjects"].items()
            },
            "vertices": len(j["vertices"]),
        }
    elif what == "info":
        j = cm.j
        objects = {}
        lods = set()
        for co in j["CityObjects"].values():
            objects[co["type"]] = objects.get(co["type"], 0) + 1
            for g in co.get("geometry", []):
                if "lod" not in g:  # a GeometryInstance: its template's
                    g = j["geometry-templates"]["templates"][g["template"]]
                lods.add(str(g["lod"]))
        out = {"objects": objects, "vertices": len(j["vertices"]), "lods": sorted(lods)}
    else:
        raise SystemExit(f"unknown request {what!r}: bbox, radius, ids, lod or info")
    json.dump(out, sys.stdout)


if __name__ == "__main__":
    main()
