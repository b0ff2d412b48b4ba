"""Independent reader for tests/it/edit.rs: the top-level members of a CityGML document.

Prints JSON: for each cityObjectMember its feature's gml:id, type (local name), box of its
coordinates (x/y/z min and max over gml:posList / gml:pos / gml:coordinates, leaving out
implicit-geometry prototypes and gml:boundedBy envelopes) and LoDs (the N of every lod<N>...
property); the root envelope's corners; every gml:id; every local reference (#id of
xlink:href, app:target text, target/@uri).
Usage: python3 citygml_members.py FILE(.gz)
"""
import gzip
import json
import re
import sys
import xml.etree.ElementTree as ET

GML = ("http://www.opengis.net/gml", "http://www.opengis.net/gml/3.2")
XLINK = "{http://www.w3.org/1999/xlink}href"
LOD = re.compile(r"^lod([0-4])[A-Z]")


def split(tag):
    ns, _, local = tag[1:].partition("}") if tag.startswith("{") else ("", "", tag)
    return ns, local


def points(el):
    ns, local = split(el.tag)
    if ns not in GML or local not in ("posList", "pos", "coordinates") or not el.text:
        return []
    if local == "coordinates":
        vals = [[float(v) for v in t.split(",")] for t in el.text.split()]
        return [v + [0.0] * (3 - len(v)) for v in vals]
    nums = [float(v) for v in el.text.split()]
    dim = 3 if local == "pos" and len(nums) == 3 else int(el.get("srsDimension", "3"))
    if local == "pos":
        dim = len(nums)
    return [nums[i:i + dim] + [0.0] * (3 - dim) for i in range(0, len(nums), dim)]


def walk(el, skip, out):
    ns, local = split(el.tag)
    skip = skip or local in ("relativeGMLGeometry", "relativeGeometry") or (
        local == "boundedBy" and ns in GML)
    if not skip:
        out["pts"].extend(points(el))
    m = LOD.match(local)
    if m and ns not in GML:
        out["lods"].add(int(m.group(1)))
    for c in el:
        walk(c, skip, out)


def main(path):
    opener = gzip.open if open(path, "rb").read(2) == b"\x1f\x8b" else open
    with opener(path, "rb") as f:
        root = ET.parse(f).getroot()
    members, env = [], None
    for child in root:
        ns, local = split(child.tag)
        if local == "boundedBy" and ns in GML:
            corners = [e.text.split() for e in child.iter() if split(e.tag)[1] in ("lowerCorner", "upperCorner")]
            env = [[float(v) for v in c] for c in corners]
        if local not in ("cityObjectMember", "featureMember") or len(child) == 0:
            continue
        feat = child[0]
        acc = {"pts": [], "lods": set()}
        walk(feat, False, acc)
        pts = acc["pts"]
        box = None
        if pts:
            box = [min(p[i] for p in pts) for i in range(3)] + [max(p[i] for p in pts) for i in range(3)]
        members.append({
            "id": feat.get("{%s}id" % GML[0]) or feat.get("{%s}id" % GML[1]),
            "type": split(feat.tag)[1],
            "box": box,
            "lods": sorted(acc["lods"]),
        })
    ids, refs = set(), []
    for el in root.iter():
        for g in GML:
            if el.get("{%s}id" % g):
                ids.add(el.get("{%s}id" % g))
        r = el.get(XLINK)
        if split(el.tag)[1] == "target":
            r = r or el.get("uri") or (el.text or "").strip()
        if r and r.startswith("#"):
            refs.append(r[1:])
    print(json.dumps({"members": members, "envelope": env, "ids": sorted(ids), "refs": refs}))


if __name__ == "__main__":
    main(sys.argv[1])
