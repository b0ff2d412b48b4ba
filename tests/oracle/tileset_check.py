#!/usr/bin/env python3
"""Independent checks of a 3D Tiles 1.1 tileset written by skylod (tests/it/tiles.rs).

usage: tileset_check.py TILESET_DIR [--source FILE --epsg N]...

Reads tileset.json and every glb with Python's json and struct only (no skylod code), and
prints one JSON object:
  problems: what breaks the 3D Tiles 1.1 rules a viewer relies on (read from the
    specification's schema: asset.version, boundingVolume.box of 12 numbers, transform of 16,
    geometricError >= 0, refine, content.uri that exists) and skylod's promises (a parent's
    geometric error >= its children's, a parent's box holding its children's boxes, glb
    header and chunk lengths, property tables of the glTF's feature counts);
  tiles, leaves, depth, leaf_ids (every gml_id in the leaves' property tables), buildings
    (every building value in the leaves), classes, max_error, leaf_rows and leaf_levels (rows
    of the leaves' tables, and per level);
  source_buildings: with --source, the gml:id of every Building element of the sources;
  irradiance: gml_id -> the leaves' irradiance property, where one is given;
  position_error_m: with --source/--epsg, the largest distance (m) from a sample of leaf
    vertices of full detail (level 2), placed on the globe by the tile transforms (EPSG:4978), to the nearest vertex
    of the source files placed by pyproj (the source CRS's horizontal part to EPSG:4979 with
    the source height taken as ellipsoidal, then EPSG:4978): skylod's documented rule.
"""
import gzip
import json
import re
import struct
import sys
from pathlib import Path

import numpy as np


def mat(a):
    return np.array(a, dtype=float).reshape(4, 4).T  # column-major


def read_glb(path):
    b = path.read_bytes()
    magic, version, length = struct.unpack_from("<4sII", b, 0)
    problems = []
    if magic != b"glTF" or version != 2 or length != len(b):
        problems.append(f"{path}: bad glb header")
    jlen, jtype = struct.unpack_from("<I4s", b, 12)
    doc = json.loads(b[20:20 + jlen])
    at = 20 + jlen
    blen, btype = struct.unpack_from("<I4s", b, at)
    if jtype != b"JSON" or btype != b"BIN\0" or at + 8 + blen != len(b):
        problems.append(f"{path}: bad glb chunks")
    return doc, b[at + 8:at + 8 + blen], problems


def view_bytes(doc, binary, v):
    bv = doc["bufferViews"][v]
    off = bv.get("byteOffset", 0)
    return binary[off:off + bv["byteLength"]]


def strings(doc, binary, prop, count):
    if prop is None:  # a property left out of a table: empty in every row
        return [""] * count
    values = view_bytes(doc, binary, prop["values"])
    offs = np.frombuffer(view_bytes(doc, binary, prop["stringOffsets"]), dtype=np.uint32)
    if len(offs) != count + 1:
        raise ValueError("string offsets of the wrong length")
    return [values[offs[i]:offs[i + 1]].decode() for i in range(count)]


def positions(doc, binary):
    """Every vertex in the tile's frame (z up), and its feature id."""
    out, ids = [], []
    for mesh in doc["meshes"]:
        for p in mesh["primitives"]:
            acc = doc["accessors"][p["attributes"]["POSITION"]]
            a = np.frombuffer(view_bytes(doc, binary, acc["bufferView"]), dtype=np.float32)
            a = a.reshape(-1, 3).astype(float)
            # glTF y up to the tile's z up: (x, y, z) -> (x, -z, y)
            out.append(np.stack([a[:, 0], -a[:, 2], a[:, 1]], axis=1))
            f = doc["accessors"][p["attributes"]["_FEATURE_ID_0"]]
            ids.append(np.frombuffer(view_bytes(doc, binary, f["bufferView"]), dtype=np.float32))
    if not out:
        return np.zeros((0, 3)), np.zeros(0)
    return np.concatenate(out), np.concatenate(ids)


def box_corners(box):
    c = np.array(box[:3])
    axes = [np.array(box[3:6]), np.array(box[6:9]), np.array(box[9:12])]
    return np.array([c + sx * axes[0] + sy * axes[1] + sz * axes[2]
                     for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])


def inside_box(box, pts, tol):
    c = np.array(box[:3])
    ok = True
    for k in range(3):
        axis = np.array(box[3 + 3 * k:6 + 3 * k])
        n = np.linalg.norm(axis)
        if n == 0:
            continue
        d = np.abs((pts - c) @ (axis / n))
        ok = ok and bool(np.all(d <= n + tol))
    return ok


def source_vertices(files):
    coords = []
    pat = re.compile(rb"<(?:gml:)?(posList|pos)\b[^>]*>([^<]*)<")
    for f in files:
        data = Path(f).read_bytes()
        if data[:2] == b"\x1f\x8b":
            data = gzip.decompress(data)
        for m in pat.finditer(data):
            nums = np.array(m.group(2).split(), dtype=float)
            if len(nums) % 3 == 0 and len(nums):
                coords.append(nums.reshape(-1, 3))
    return np.concatenate(coords) if coords else np.zeros((0, 3))


def main():
    args = sys.argv[1:]
    root_dir = Path(args[0])
    sources, epsg = [], None
    i = 1
    while i < len(args):
        if args[i] == "--source":
            sources.append(args[i + 1])
        elif args[i] == "--epsg":
            epsg = int(args[i + 1])
        i += 2
    ts = json.loads((root_dir / "tileset.json").read_text())
    problems = []
    if ts.get("asset", {}).get("version") != "1.1":
        problems.append("asset.version is not 1.1")
    if not isinstance(ts.get("geometricError"), (int, float)) or ts["geometricError"] < 0:
        problems.append("tileset geometricError")
    out = {"tiles": 0, "leaves": 0, "depth": 0, "leaf_ids": [], "buildings": [],
           "classes": [], "max_error": 0.0, "leaf_rows": 0, "leaf_levels": {},
           "source_buildings": [], "irradiance": {}}
    samples = []
    classes = set()

    def walk(tile, parent_m, depth, parent):
        out["tiles"] += 1
        out["depth"] = max(out["depth"], depth)
        name = f"tile at depth {depth}"
        box = tile.get("boundingVolume", {}).get("box")
        if not (isinstance(box, list) and len(box) == 12):
            problems.append(f"{name}: boundingVolume.box is not 12 numbers")
            return
        err = tile.get("geometricError")
        if not isinstance(err, (int, float)) or err < 0:
            problems.append(f"{name}: geometricError")
        if tile.get("refine", parent and parent.get("refine")) not in ("ADD", "REPLACE"):
            problems.append(f"{name}: refine")
        t = tile.get("transform", [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1])
        if len(t) != 16:
            problems.append(f"{name}: transform is not 16 numbers")
            return
        m = parent_m @ mat(t)
        out["max_error"] = max(out["max_error"], err)
        if parent is not None:
            if parent["geometricError"] < err:
                problems.append(f"{name}: geometric error {err} above its parent's")
            # the parent's box, in the parent's frame, holds this tile's box
            corners = box_corners(box)
            world = (m @ np.c_[corners, np.ones(8)].T).T[:, :3]
            pm = parent["_m"]
            local = (np.linalg.inv(pm) @ np.c_[world, np.ones(8)].T).T[:, :3]
            if not inside_box(parent["boundingVolume"]["box"], local, 0.01):
                problems.append(f"{name}: box outside its parent's")
        tile["_m"] = m
        children = tile.get("children", [])
        content = tile.get("content")
        if content is not None:
            path = root_dir / content["uri"]
            if not path.is_file():
                problems.append(f"{name}: content {content['uri']} missing")
            else:
                doc, binary, p = read_glb(path)
                problems.extend(p)
                if any(v["byteLength"] < 1 for v in doc["bufferViews"]):
                    problems.append(f"{content['uri']}: a buffer view of 0 bytes")
                pts, fids = positions(doc, binary)
                full_detail = pts
                if len(pts) and not inside_box(box, pts, 0.01):
                    problems.append(f"{content['uri']}: vertices outside the tile's box")
                ext = doc.get("extensions", {}).get("EXT_structural_metadata", {})
                tables = ext.get("propertyTables", [])
                if len(tables) != 1:
                    problems.append(f"{content['uri']}: {len(tables)} property tables")
                else:
                    table = tables[0]
                    count = table["count"]
                    ids = strings(doc, binary, table["properties"]["gml_id"], count)
                    cls = strings(doc, binary, table["properties"]["class"], count)
                    bld = strings(doc, binary, table["properties"].get("building"), count)
                    lv = view_bytes(doc, binary, table["properties"]["level"]["values"])
                    classes.update(cls)
                    seen = 0
                    for mesh in doc["meshes"]:
                        for prim in mesh["primitives"]:
                            fid = prim["extensions"]["EXT_mesh_features"]["featureIds"][0]
                            acc = doc["accessors"][prim["attributes"]["_FEATURE_ID_0"]]
                            v = np.frombuffer(view_bytes(doc, binary, acc["bufferView"]),
                                              dtype=np.float32)
                            uniq = np.unique(v)
                            if len(uniq) != fid["featureCount"] or uniq.max() >= count:
                                problems.append(f"{content['uri']}: feature ids and counts")
                            seen += len(uniq)
                    if seen != count:
                        problems.append(f"{content['uri']}: {count} rows, {seen} features")
                    level_of = np.frombuffer(lv, dtype=np.uint8)
                    full_detail = pts[level_of[fids.astype(int)] == 2]
                    kwh = table["properties"].get("irradiance")
                    if kwh is not None and not children:
                        vals = np.frombuffer(view_bytes(doc, binary, kwh["values"]),
                                             dtype=np.float32)
                        for k in range(count):
                            if vals[k] != -1.0:
                                out["irradiance"][ids[k]] = float(vals[k])
                    if not children:
                        out["leaf_rows"] += count
                        for v in lv:
                            out["leaf_levels"][str(v)] = out["leaf_levels"].get(str(v), 0) + 1
                        out["leaf_ids"].extend(ids)
                        out["buildings"].extend(b for b in bld if b)
                if not children and len(full_detail):
                    step = max(1, len(full_detail) // 60)
                    sel = full_detail[::step]
                    samples.append((m @ np.c_[sel, np.ones(len(sel))].T).T[:, :3])
        if not children:
            out["leaves"] += 1
        for c in children:
            walk(c, m, depth + 1, tile)

    walk(ts["root"], np.eye(4), 0, None)
    out["leaf_ids"] = sorted(set(out["leaf_ids"]))
    out["buildings"] = sorted(set(out["buildings"]))
    out["classes"] = sorted(classes)
    out["problems"] = problems
    for f in sources:
        data = Path(f).read_bytes()
        if data[:2] == b"\x1f\x8b":
            data = gzip.decompress(data)
        for m in re.finditer(rb"<(?:\w+:)?Building\b[^>]*?gml:id=\"([^\"]+)\"", data):
            out["source_buildings"].append(m.group(1).decode())
    out["source_buildings"] = sorted(set(out["source_buildings"]))
    if sources and epsg is not None and samples:
        from pyproj import Transformer
        src = source_vertices(sources)
        to_ll = Transformer.from_crs(f"EPSG:{epsg}", "EPSG:4326")
        to_ecef = Transformer.from_crs("EPSG:4979", "EPSG:4978")
        lat, lon = to_ll.transform(src[:, 0], src[:, 1])
        x, y, z = to_ecef.transform(lat, lon, src[:, 2])
        src_ecef = np.stack([x, y, z], axis=1)
        got = np.concatenate(samples)
        worst = 0.0
        for p in got:
            d = np.min(np.linalg.norm(src_ecef - p, axis=1))
            worst = max(worst, float(d))
        out["position_error_m"] = worst
        out["position_samples"] = int(len(got))
    print(json.dumps(out))


if __name__ == "__main__":
    main()
