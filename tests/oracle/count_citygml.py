#!/usr/bin/env python3
"""Independent counter of CityGML assets (test oracle for tests/it/read.rs).

Implements the asset mapping of DESIGN.md ("CityGML -> assets") from scratch, with the Python
standard library only (xml.etree.ElementTree.iterparse, start/end events, gzip), matching
elements by namespace URI, never by prefix.

Usage: count_citygml.py FILE...   -> prints one JSON object {path: counts} on stdout.
A file that is not CityGML (no CityGML namespace on any element) gets {"error": "not_citygml"};
a file that is not well-formed XML gets {"error": "xml: ..."}.
"""

import gzip
import io
import re
import json
import sys
import xml.etree.ElementTree as ET

GML = {"http://www.opengis.net/gml", "http://www.opengis.net/gml/3.2"}
CITYGML = "http://www.opengis.net/citygml/"
VERSIONS = ("1.0", "2.0", "3.0")

SURFACES = {
    "RoofSurface": "roof_surfaces",
    "WallSurface": "wall_surfaces",
    "GroundSurface": "ground_surfaces",
    "ClosureSurface": "closure_surfaces",
    "OuterCeilingSurface": "outer_ceiling_surfaces",
    "OuterFloorSurface": "outer_floor_surfaces",
}
# Elements whose content never yields shell surfaces, installations or openings.
INTERIOR = {
    "Room",
    "IntBuildingInstallation",
    "BuildingFurniture",
    "BuildingRoom",
    "InteriorWallSurface",
    "CeilingSurface",
    "FloorSurface",
}
INSTALLATIONS = {"BuildingInstallation", "BuildingConstructiveElement"}
WINDOWS = {"Window", "WindowSurface"}
DOORS = {"Door", "DoorSurface"}
POLYGONS = {"Polygon", "PolygonPatch", "Triangle", "Rectangle"}


def split(tag):
    """'{uri}local' -> (uri, local)."""
    if tag.startswith("{"):
        uri, local = tag[1:].split("}", 1)
        return uri, local
    return "", tag


def citygml_module(uri):
    """(module, version) of a CityGML namespace URI, or None."""
    if not uri.startswith(CITYGML):
        return None
    rest = uri[len(CITYGML):].rstrip("/")
    if "/" in rest:
        module, version = rest.rsplit("/", 1)
    else:
        module, version = "", rest
    if version not in VERSIONS:
        return None
    return module, version


def classify(uri, local):
    """Role of an element: 'building', 'part', 'surface', 'installation', 'window', 'door',
    'interior', 'foreign_object' (a city object of a non-building module), or None."""
    cm = citygml_module(uri)
    if cm is None:
        return None
    module, version = cm
    building_ns = module == "building"
    shell_ns = (module == "building" and version in ("1.0", "2.0")) or (
        module == "construction" and version == "3.0"
    )
    if building_ns and local == "Building":
        return "building"
    if building_ns and local == "BuildingPart":
        return "part"
    if local in SURFACES and (
        shell_ns or (module == "" and version == "3.0" and local == "ClosureSurface")
    ):
        return "surface"
    if local in INSTALLATIONS and building_ns:
        return "installation"
    if local in WINDOWS and shell_ns:
        return "window"
    if local in DOORS and shell_ns:
        return "door"
    if local in INTERIOR and (building_ns or shell_ns):
        return "interior"
    # Top-level features of other thematic modules (bridges, tunnels, vegetation, ...):
    # anything below them is not a building asset. Feature names start upper-case.
    if module not in ("", "building", "construction", "appearance", "generics") and local[:1].isupper():
        return "foreign_object"
    return None


def declare_unbound(data):
    """Real files sometimes use a prefix they never declare (PLATEAU: `energy:`). Declare every
    such prefix on the root with a dummy URI so that the rest of the document can be counted."""
    declared = set(re.findall(rb"xmlns:([A-Za-z_][\w.-]*)\s*=", data))
    used = set(re.findall(rb"</?([A-Za-z_][\w.-]*):[A-Za-z_]", data))
    used |= set(re.findall(rb"\s([A-Za-z_][\w.-]*):[A-Za-z_][\w.-]*\s*=", data))
    missing = sorted(used - declared - {b"xmlns", b"xml"})
    decl = b"".join(b' xmlns:%s="urn:skylod-oracle:unbound:%s"' % (m, m) for m in missing)
    root = re.search(rb"<[A-Za-z_][\w.:-]*", re.sub(rb"<\?.*?\?>|<!--.*?-->", lambda m: b" " * len(m.group()), data, flags=re.S))
    return data[: root.end()] + decl + data[root.end():], [m.decode() for m in missing]


def count(path):
    try:
        return count_source(path, None)
    except ET.ParseError as e:
        if "unbound prefix" not in str(e):
            raise
    opener = gzip.open if path.endswith(".gz") else open
    with opener(path, "rb") as f:
        data, missing = declare_unbound(f.read())
    c = count_source(path, data)
    c["unbound_prefixes"] = missing
    return c


def count_source(path, data):
    c = {
        "citygml_version": None,
        "buildings": 0,
        "building_parts": 0,
        "roof_surfaces": 0,
        "wall_surfaces": 0,
        "ground_surfaces": 0,
        "closure_surfaces": 0,
        "outer_ceiling_surfaces": 0,
        "outer_floor_surfaces": 0,
        "installations": 0,
        "windows": 0,
        "doors": 0,
        "polygons": 0,
        "implicit_geometries": 0,
        # Every element of a CityGML namespace whose local name is UpperCamelCase (a feature
        # or object type), wherever it nests.
        "features": {},
    }
    opener = gzip.open if path.endswith(".gz") else open
    # Stack of roles of the open elements (None for plain elements).
    stack = []
    # Counters of open ancestors by role, to test nesting in O(1).
    open_roles = {}
    versions = []
    with (io.BytesIO(data) if data is not None else opener(path, "rb")) as f:
        for event, elem in ET.iterparse(f, events=("start", "end")):
            if event == "end":
                role = stack.pop()
                if role:
                    open_roles[role] -= 1
                elem.clear()
                continue
            uri, local = split(elem.tag)
            cm = citygml_module(uri)
            if cm is not None and not versions:
                versions.append(cm[1])
            if cm is not None and local[:1].isupper():
                c["features"][local] = c["features"].get(local, 0) + 1
            if uri in GML and local in POLYGONS:
                c["polygons"] += 1
            if cm is not None and cm[0] == "" and local == "ImplicitGeometry":
                c["implicit_geometries"] += 1
            role = classify(uri, local)
            has = lambda r: open_roles.get(r, 0) > 0  # noqa: E731
            in_building = has("building") or has("part")
            blocked = (
                has("installation")
                or has("window")
                or has("door")
                or has("interior")
                or has("foreign_object")
            )
            if role == "building":
                c["buildings"] += 1
            elif role == "part":
                c["building_parts"] += 1
            elif role == "surface":
                if in_building and not blocked:
                    c[SURFACES[local]] += 1
            elif role == "installation":
                if not blocked:
                    c["installations"] += 1
            elif role == "window":
                if not blocked:
                    c["windows"] += 1
            elif role == "door":
                if not blocked:
                    c["doors"] += 1
            stack.append(role)
            if role:
                open_roles[role] = open_roles.get(role, 0) + 1
    if not versions:
        return {"error": "not_citygml"}
    c["citygml_version"] = versions[0]
    return c


def main(paths):
    out = {}
    for p in paths:
        try:
            out[p] = count(p)
        except ET.ParseError as e:
            out[p] = {"error": f"xml: {e}"}
    json.dump(out, sys.stdout, indent=1, sort_keys=True)
    sys.stdout.write("\n")


if __name__ == "__main__":
    main(sys.argv[1:])
