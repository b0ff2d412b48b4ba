"""Independent reader for tests/it/upgrade.rs: what a CityGML 1.0 / 2.0 document holds and
what its CityGML 3.0 upgrade must hold, counted with Python's xml.etree.

For each file prints one JSON object (a list, in argument order):
  version        "1.0" / "2.0" / "3.0" (of the root's namespace)
  types          city objects by type, named as in 3.0 (Window -> WindowSurface, Door ->
                 DoorSurface, Room -> BuildingRoom, IntBuildingInstallation ->
                 BuildingInstallation, GenericCityObject -> GenericOccupiedSpace,
                 WaterClosureSurface -> ClosureSurface)
  polygons       gml:Polygon elements, tuples: coordinate tuples of gml:posList / gml:pos /
                 gml:coordinates / gml:coord (envelopes left out)
  lod4_*         the same under LoD4 properties (3.0 has none: dropped unless LoD4 -> LoD3)
  lod3_replaced_* the same under LoD3 properties of top-level objects that have LoD4
  roof_edges, lod1_surfaces  lod0RoofEdge properties, LoD1 multi-surfaces of spaces (mapped
                 onto a RoofSurface / GenericThematicSurface by the options)
  generic        generic attributes (nested ones of sets too)
  targets        sorted appearance target URIs (app:target text or @uri)
A file xml.etree cannot read (e.g. an unbound prefix) gives {"error": message}.
Usage: python3 citygml_upgrade.py FILE(.gz)...
"""
import gzip
import json
import re
import sys
import xml.etree.ElementTree as ET

GML = ("http://www.opengis.net/gml", "http://www.opengis.net/gml/3.2")
CITYGML = "http://www.opengis.net/citygml/"
RENAMED = {
    "Window": "WindowSurface",
    "Door": "DoorSurface",
    "Room": "BuildingRoom",
    "IntBuildingInstallation": "BuildingInstallation",
    "GenericCityObject": "GenericOccupiedSpace",
    "WaterClosureSurface": "ClosureSurface",
}
CITY_OBJECTS = set(
    """Building BuildingPart RoofSurface WallSurface GroundSurface ClosureSurface
    OuterCeilingSurface OuterFloorSurface CeilingSurface InteriorWallSurface FloorSurface
    Window Door WindowSurface DoorSurface BuildingInstallation IntBuildingInstallation Room
    BuildingRoom BuildingFurniture GenericCityObject GenericOccupiedSpace
    GenericThematicSurface CityFurniture SolitaryVegetationObject PlantCover WaterBody
    WaterSurface WaterGroundSurface WaterClosureSurface LandUse ReliefFeature TINRelief
    Road Railway Track Square TrafficArea AuxiliaryTrafficArea Bridge BridgePart
    CityObjectGroup Tunnel TunnelPart""".split()
)
LOD = re.compile(r"^lod([0-4])[A-Z]")
SPACE_LOD1 = ("lod1MultiSurface", "lod1Geometry")
NOT_SURFACES = ("Solid", "CompositeSolid", "MultiCurve", "LineString", "Point", "MultiPoint")


def split(tag):
    if not isinstance(tag, str):
        return "", ""
    if tag.startswith("{"):
        ns, _, local = tag[1:].partition("}")
        return ns, local
    return "", tag


def tuples(el, local):
    text = el.text or ""
    if local == "coord":
        return 1
    if local == "coordinates":
        ts = el.get("ts", " ")
        return len([t for t in re.split(r"\s+" if ts == " " else re.escape(ts), text.strip()) if t])
    n = len(text.split())
    if local == "pos":
        return 1 if n else 0
    dim = int(el.get("srsDimension", "3"))
    return n // dim


def has_lod4(el):
    return any(LOD.match(split(e.tag)[1] or "") and split(e.tag)[1].startswith("lod4") for e in el.iter())


def count(path):
    opener = gzip.open if path.endswith(".gz") else open
    try:
        with opener(path, "rb") as f:
            root = ET.parse(f).getroot()
    except ET.ParseError as e:
        # not namespace-well-formed (an unbound prefix): nothing to count
        return {"error": str(e)}
    ns, _ = split(root.tag)
    version = ns.rstrip("/").rsplit("/", 1)[-1]
    out = {
        "version": version, "types": {}, "polygons": 0, "tuples": 0, "lod4_polygons": 0,
        "lod4_tuples": 0, "lod3_replaced_polygons": 0, "lod3_replaced_tuples": 0,
        "roof_edges": 0, "lod1_surfaces": 0, "generic": 0, "targets": [],
    }

    def walk(el, lod, in_env, lod4_member, parent_local):
        ens, local = split(el.tag)
        m = LOD.match(local) if ens.startswith(CITYGML) else None
        if m:
            lod = int(m.group(1))
            if local == "lod0RoofEdge":
                out["roof_edges"] += 1
            kids = [split(c.tag)[1] for c in el]
            solid_or_curves = any(k in NOT_SURFACES for k in kids)
            if local in SPACE_LOD1 and not solid_or_curves and parent_local not in (
                "TrafficArea", "AuxiliaryTrafficArea"
            ):
                # a space's LoD1 multi-surface (thematic surfaces have no LoD1 in 1.0 / 2.0)
                out["lod1_surfaces"] += 1
        if ens.startswith(CITYGML) and local in CITY_OBJECTS:
            t = RENAMED.get(local, local)
            out["types"][t] = out["types"].get(t, 0) + 1
        if ens.startswith(CITYGML) and "/generics/" in ens and (
            local.endswith("Attribute") or local in ("genericAttributeSet", "GenericAttributeSet")
        ):
            out["generic"] += 1
        if ens.startswith(CITYGML) and "/appearance/" in ens and local == "target":
            out["targets"].append((el.get("uri") or el.text or "").strip())
        in_env = in_env or (ens in GML and local == "Envelope")
        if ens in GML and not in_env:
            n = p = 0
            if local == "Polygon":
                p = 1
            if local in ("posList", "pos", "coordinates", "coord"):
                n = tuples(el, local)
            out["polygons"] += p
            out["tuples"] += n
            if lod == 4:
                out["lod4_polygons"] += p
                out["lod4_tuples"] += n
            if lod == 3 and lod4_member:
                out["lod3_replaced_polygons"] += p
                out["lod3_replaced_tuples"] += n
        for c in el:
            walk(c, lod, in_env, lod4_member, local)

    for member in root:
        walk(member, None, False, has_lod4(member), split(root.tag)[1])
    out["targets"].sort()
    return out


print(json.dumps([count(p) for p in sys.argv[1:]]))
