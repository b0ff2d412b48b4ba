"""skylod from Python: skyline-controlled mixed level-of-detail CityGML for solar analysis.

The calls mirror the library's pipeline (read → frame the POIs → levels / SVF / sun hours /
horizon / irradiance → write) with Python types: paths are ``str`` or ``os.PathLike`` (files,
directories searched recursively, glob patterns), POIs are ``(x, y, z)`` or
``(x, y, z, nx, ny, nz)`` tuples or an ``(N, 3)`` / ``(N, 6)`` numpy array (named by ``ids=``,
else ``poi-1``, ``poi-2``, ... as ``--poi``; a POI's rays are seeded from its id), or the path
of a POI CSV file (``id,x,y,z[,nx,ny,nz]``), results are numpy arrays and dicts. The numbers are the
command line's: ``skylod.svf(...)`` gives what ``skylod svf --json`` prints, from the same code.

Every call releases the GIL while it works (other Python threads run, two calls run in
parallel), takes an optional ``progress(stage, done, total)`` callable (called on the calling
thread; raising in it cancels the call) and stops on Ctrl-C through the library's
cancellation (``KeyboardInterrupt`` is raised once the call has stopped). Errors of the
library raise :class:`SkylodError` with its message (file, line:column and gml:id where known).

>>> import skylod
>>> skylod.stats("tiles/")["buildings"]                                  # doctest: +SKIP
1204
>>> skylod.svf("tiles/", [(391200.0, 5820100.0, 1.5)])                    # doctest: +SKIP
array([0.6123])
"""

from __future__ import annotations

import json
import os
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from . import _skylod
from ._skylod import SkylodError

__all__ = [
    "SkylodError",
    "stats",
    "svf",
    "sun_hours",
    "horizon",
    "irradiance",
    "irradiance_surfaces",
    "evaluate",
    "lod",
    "convert",
    "__version__",
]

__version__: str = _skylod.__version__

PathArg = Union[str, "os.PathLike[str]"]
Paths = Union[PathArg, Sequence[PathArg]]
Pois = Union[PathArg, Sequence[Sequence[float]], np.ndarray]
Progress = Optional[Callable[[str, int, int], Any]]
Site = Optional[Tuple[float, float]]

#: POIs farther than this (m) outside the scene's bounding box are refused (``--poi-margin``).
DEFAULT_POI_MARGIN = 1000.0


def _paths(paths: Paths) -> List[str]:
    if isinstance(paths, (str, os.PathLike)):
        return [os.fspath(paths)]
    return [os.fspath(p) for p in paths]


def _pois(pois: Pois) -> Tuple[List[List[float]], Optional[str]]:
    """POIs as rows of 3 or 6 floats, or the path of a CSV file."""
    if isinstance(pois, (str, os.PathLike)):
        return [], os.fspath(pois)
    if isinstance(pois, np.ndarray):
        a = np.asarray(pois, dtype=np.float64)
        if a.ndim != 2 or a.shape[1] not in (3, 6):
            raise SkylodError(
                f"pois: expected an (N, 3) or (N, 6) array, got shape {a.shape}"
            )
        return a.tolist(), None
    rows = []
    for k, p in enumerate(pois):
        try:
            rows.append([float(v) for v in p])
        except (TypeError, ValueError) as e:
            raise SkylodError(
                f"POI {k + 1}: expected (x, y, z) or (x, y, z, nx, ny, nz) numbers: {e}"
            ) from None
    return rows, None


def _setup(
    paths: Paths,
    pois: Pois,
    ids: Optional[Sequence[str]],
    poi_crs: Optional[str],
    source_crs: Optional[str],
    poi_margin: float,
    allow_mixed_crs: bool,
) -> Dict[str, Any]:
    rows, csv = _pois(pois)
    return {
        "paths": _paths(paths),
        "pois": rows,
        "ids": None if ids is None else [str(i) for i in ids],
        "pois_csv": csv,
        "poi_crs": poi_crs,
        "source_crs": source_crs,
        "poi_margin": float(poi_margin),
        "allow_mixed_crs": bool(allow_mixed_crs),
        "surfaces": [],
        "spacing": 1.0,
    }


def _lod_args(
    rays: int,
    seed: int,
    threshold: Optional[float],
    roof_tolerance: float,
    angle: float,
    thickness: float,
    prefer_lod2: bool,
) -> Dict[str, Any]:
    return {
        "rays": rays,
        "seed": seed,
        "threshold": threshold,
        "roof_tolerance": roof_tolerance,
        "angle": angle,
        "thickness": thickness,
        "prefer_lod2": prefer_lod2,
    }


def _column(doc: Dict[str, Any], key: str) -> np.ndarray:
    return np.array([p[key] for p in doc["pois"]], dtype=np.float64)


def stats(
    paths: Paths, *, source_crs: Optional[str] = None, progress: Progress = None
) -> Dict[str, Any]:
    """Counts of the model in ``paths``: the ``total`` of ``skylod stats --json``.

    ``paths`` is a file (``.gml``, ``.xml``, gzip told by content), a directory (searched
    recursively), a glob pattern, or a list of them; every file must be readable.

    >>> skylod.stats("fzk_haus_lod2_v2.gml")["buildings"]               # doctest: +SKIP
    1
    """
    doc: Dict[str, Any] = json.loads(
        _skylod.stats(_paths(paths), source_crs=source_crs, progress=progress)
    )
    total: Dict[str, Any] = doc["total"]
    return total


def svf(
    paths: Paths,
    pois: Pois,
    rays: int = 10_000,
    seed: int = 1,
    *,
    ids: Optional[Sequence[str]] = None,
    poi_crs: Optional[str] = None,
    source_crs: Optional[str] = None,
    poi_margin: float = DEFAULT_POI_MARGIN,
    allow_mixed_crs: bool = False,
    full: bool = False,
    progress: Progress = None,
) -> Any:
    """Sky view factor of every POI against the full-detail model (``skylod svf``).

    Returns an ``(N,)`` float64 array (POI order: the given points, then the CSV's rows), or
    with ``full=True`` the document of ``skylod svf --json`` (per POI ``svf``,
    ``sky_exposure``, ``flags``; ``rays``, ``seed``, ``inputs``, ``timings_ms``).
    ``poi_crs`` names the POIs' CRS when it is not the model's (``EPSG:4326``, ...).

    >>> skylod.svf("tiles/", np.array([[391200.0, 5820100.0, 1.5]]))    # doctest: +SKIP
    array([0.6123])
    """
    setup = _setup(paths, pois, ids, poi_crs, source_crs, poi_margin, allow_mixed_crs)
    doc = json.loads(_skylod.svf(setup, rays, seed, progress=progress))
    return doc if full else _column(doc, "svf")


def sun_hours(
    paths: Paths,
    pois: Pois,
    *,
    site: Site = None,
    year: int = 2025,
    step: int = 15,
    timezone: str = "UTC",
    ids: Optional[Sequence[str]] = None,
    poi_crs: Optional[str] = None,
    source_crs: Optional[str] = None,
    poi_margin: float = DEFAULT_POI_MARGIN,
    allow_mixed_crs: bool = False,
    full: bool = False,
    progress: Progress = None,
) -> Any:
    """Hours of direct sun over a year at every POI (``skylod sun-hours``).

    ``site`` is ``(lat, lon)`` in WGS84 degrees (default: the centre of the model from its
    CRS); ``step`` in minutes; ``timezone`` attributes steps to months. Returns an ``(N,)``
    array of hours, or with ``full=True`` the document of ``skylod sun-hours --json``
    (with ``monthly`` and ``possible_hours`` per POI).

    >>> skylod.sun_hours("tiles/", [(391200.0, 5820100.0, 1.5)], step=30)   # doctest: +SKIP
    array([1873.5])
    """
    setup = _setup(paths, pois, ids, poi_crs, source_crs, poi_margin, allow_mixed_crs)
    doc = json.loads(
        _skylod.sun_hours(setup, site, year, step, timezone, progress=progress)
    )
    return doc if full else _column(doc, "sun_hours")


def horizon(
    paths: Paths,
    pois: Pois,
    *,
    step: float = 1.0,
    ids: Optional[Sequence[str]] = None,
    poi_crs: Optional[str] = None,
    source_crs: Optional[str] = None,
    poi_margin: float = DEFAULT_POI_MARGIN,
    allow_mixed_crs: bool = False,
    full: bool = False,
    progress: Progress = None,
) -> Any:
    """Horizon profile of every POI (``skylod horizon``, the PVGIS / pvlib convention).

    Returns an ``(N, K)`` array of elevations in degrees at the azimuths
    ``0, step, 2 step, ... < 360`` (from north, clockwise), or with ``full=True`` the
    document of ``skylod horizon --json``.

    >>> skylod.horizon("tiles/", [(391200.0, 5820100.0, 1.5)], step=90.0)  # doctest: +SKIP
    array([[12.3, 4.1, 0. , 25.8]])
    """
    setup = _setup(paths, pois, ids, poi_crs, source_crs, poi_margin, allow_mixed_crs)
    doc = json.loads(_skylod.horizon(setup, step, progress=progress))
    if full:
        return doc
    k = len(doc["pois"][0]["elevation"]) if doc["pois"] else 0
    return np.array([p["elevation"] for p in doc["pois"]], dtype=np.float64).reshape(-1, k)


def irradiance(
    paths: Paths,
    pois: Pois,
    weather: PathArg,
    *,
    site: Site = None,
    sky: str = "all-weather",
    albedo: float = 0.2,
    rays: int = 10_000,
    seed: int = 1,
    ids: Optional[Sequence[str]] = None,
    poi_crs: Optional[str] = None,
    source_crs: Optional[str] = None,
    poi_margin: float = DEFAULT_POI_MARGIN,
    allow_mixed_crs: bool = False,
    full: bool = False,
    progress: Progress = None,
) -> Any:
    """Global irradiation (kWh/m² over the weather's hours) of every POI (``skylod irradiance``).

    ``weather`` is an EnergyPlus EPW or NREL TMY3 CSV file; ``sky`` is ``"all-weather"``
    (the Perez all-weather sky by daylight coefficients, Radiance's model), ``"perez"`` (the
    Perez 1990 transposition, pvlib's on open planes) or ``"isotropic"``. Returns an ``(N,)`` array, or with ``full=True`` the document of
    ``skylod irradiance --json`` (direct, diffuse, reflected, svf, sun hours per POI).

    >>> skylod.irradiance("tiles/", "pois.csv", "berlin.epw")              # doctest: +SKIP
    array([812.4, 455.0])
    """
    setup = _setup(paths, pois, ids, poi_crs, source_crs, poi_margin, allow_mixed_crs)
    doc = json.loads(
        _skylod.irradiance(
            setup, os.fspath(weather), site, sky, albedo, rays, seed, progress=progress
        )
    )
    return doc if full else _column(doc, "global_kwh_m2")


def irradiance_surfaces(
    paths: Paths,
    weather: PathArg,
    surfaces: Sequence[str] = ("roof",),
    *,
    spacing: float = 1.0,
    site: Site = None,
    sky: str = "all-weather",
    albedo: float = 0.2,
    rays: int = 10_000,
    seed: int = 1,
    threshold: Optional[float] = None,
    points: bool = False,
    monthly: bool = False,
    source_crs: Optional[str] = None,
    allow_mixed_crs: bool = False,
    progress: Progress = None,
) -> Dict[str, np.ndarray]:
    """A solar cadastre: annual irradiation on every roof and/or wall of the model
    (``skylod irradiance --surfaces … --table``).

    ``surfaces`` holds ``"roof"`` and/or ``"wall"``; points are sampled every ``spacing``
    metres on each surface. Returns the surface table as columns of numpy arrays
    (``surface_id``, ``building_id``, ``kind``, ``area_m2``, ``points``, ``mean_kwh_m2``,
    ``min_kwh_m2``, ``max_kwh_m2``, ``area_above_m2`` with ``threshold``,
    ``building_roof_kwh``), or with ``points=True`` one row per sample point
    (``surface_id``, ``x``, ``y``, ``z``, ``nx``, ``ny``, ``nz``, ``global_kwh_m2``,
    ``direct_kwh_m2``, ``diffuse_kwh_m2``, ``reflected_kwh_m2``); ``monthly=True`` adds
    ``jan_kwh_m2`` … ``dec_kwh_m2`` to either (``--monthly``). A DataFrame in one line:
    ``pandas.DataFrame(skylod.irradiance_surfaces(...))``.

    >>> skylod.irradiance_surfaces("tiles/", "berlin.epw", ("roof", "wall"))  # doctest: +SKIP
    {'surface_id': array(['R1', 'W1'], dtype=object), ..., 'mean_kwh_m2': array([1012.4, 455.0])}
    """
    kinds = [surfaces] if isinstance(surfaces, str) else list(surfaces)
    setup = _setup(paths, [], None, None, source_crs, DEFAULT_POI_MARGIN, allow_mixed_crs)
    setup["surfaces"] = [str(k) for k in kinds]
    setup["spacing"] = float(spacing)
    doc = json.loads(
        _skylod.irradiance_surfaces(
            setup, os.fspath(weather), site, sky, albedo, rays, seed, threshold,
            monthly=monthly, progress=progress,
        )
    )
    table = doc["points" if points else "surfaces"]
    if not points and threshold is None:
        table = [{k: v for k, v in r.items() if k != "area_above_m2"} for r in table]
    keys = list(table[0]) if table else []
    text = {"surface_id", "building_id", "kind"}

    def column(k: str) -> np.ndarray:
        values = [r[k] for r in table]
        if k in text:
            return np.array(values, dtype=object)
        if k == "points":
            return np.array(values, dtype=np.int64)
        return np.array([np.nan if v is None else v for v in values], dtype=np.float64)

    return {k: column(k) for k in keys}


def evaluate(
    paths: Paths,
    pois: Pois,
    *,
    rays: int = 10_000,
    seed: int = 1,
    threshold: Optional[float] = None,
    roof_tolerance: float = 0.5,
    angle: float = 5.0,
    thickness: float = 0.3,
    prefer_lod2: bool = True,
    svf_rays: int = 20_000,
    sun: bool = True,
    site: Site = None,
    year: int = 2025,
    step: int = 15,
    ids: Optional[Sequence[str]] = None,
    poi_crs: Optional[str] = None,
    source_crs: Optional[str] = None,
    poi_margin: float = DEFAULT_POI_MARGIN,
    allow_mixed_crs: bool = False,
    progress: Progress = None,
) -> Dict[str, Any]:
    """Full vs mixed-LoD vs all-boxes model at every POI: the document of
    ``skylod evaluate --json`` (``sun=False`` skips sun hours, as ``--no-sun``).

    >>> e = skylod.evaluate("tiles/", "pois.csv", sun=False)               # doctest: +SKIP
    >>> max(p["lod_svf_error"] for p in e["pois"]) < 0.01                  # doctest: +SKIP
    True
    """
    setup = _setup(paths, pois, ids, poi_crs, source_crs, poi_margin, allow_mixed_crs)
    lod_args = _lod_args(rays, seed, threshold, roof_tolerance, angle, thickness, prefer_lod2)
    doc: Dict[str, Any] = json.loads(
        _skylod.evaluate(setup, lod_args, svf_rays, sun, site, year, step, progress=progress)
    )
    return doc


def lod(
    paths: Paths,
    pois: Pois,
    output: PathArg,
    *,
    format: Optional[str] = None,
    overwrite: bool = False,
    rays: int = 10_000,
    seed: int = 1,
    threshold: Optional[float] = None,
    roof_tolerance: float = 0.5,
    angle: float = 5.0,
    thickness: float = 0.3,
    prefer_lod2: bool = True,
    bound: bool = True,
    max_svf_error: Optional[float] = None,
    max_sun_hours_error: Optional[float] = None,
    bound_rays: int = 20_000,
    site: Site = None,
    year: int = 2025,
    step: int = 15,
    ids: Optional[Sequence[str]] = None,
    poi_crs: Optional[str] = None,
    source_crs: Optional[str] = None,
    poi_margin: float = DEFAULT_POI_MARGIN,
    allow_mixed_crs: bool = False,
    progress: Progress = None,
) -> Dict[str, Any]:
    """Write the skyline-controlled mixed-LoD model for ``pois`` to ``output`` (``skylod lod``)
    and return its report (``schemas/report.schema.json``, as ``--report``).

    ``output`` is a file for one input (``.gml``/``.xml``, ``.gz`` compresses; ``.obj``,
    ``.city.json``, ``.city.jsonl``), a directory ending in ``/`` that mirrors the inputs, or
    for several inputs one CityGML file that merges them. By default the SVF (and, when the
    site is known, the sun hours) of the written model stay within 1 % of the full model's
    at every POI (``max_svf_error``, ``max_sun_hours_error``; ``bound=False`` turns it off);
    when that cannot be met nothing is written and :class:`SkylodError` is raised. An
    existing output is replaced only with ``overwrite=True``.

    >>> r = skylod.lod("tiles/", "pois.csv", "out/")                       # doctest: +SKIP
    >>> r["totals"]["levels"]                                               # doctest: +SKIP
    [812, 96, 35]
    """
    setup = _setup(paths, pois, ids, poi_crs, source_crs, poi_margin, allow_mixed_crs)
    lod_args = _lod_args(rays, seed, threshold, roof_tolerance, angle, thickness, prefer_lod2)
    bound_args = {
        "bound": bool(bound),
        "max_svf_error": max_svf_error,
        "max_sun_hours_error": max_sun_hours_error,
        "bound_rays": bound_rays,
        "site": site,
        "year": year,
        "step": step,
    }
    doc: Dict[str, Any] = json.loads(_skylod.lod(
        setup,
        os.fspath(output),
        lod_args,
        bound_args,
        format=format,
        overwrite=overwrite,
        progress=progress,
    ))
    return doc


def convert(
    paths: Paths,
    output: PathArg,
    *,
    format: Optional[str] = None,
    overwrite: bool = False,
    source_crs: Optional[str] = None,
    viewer: bool = False,
    progress: Progress = None,
) -> List[str]:
    """Read CityGML and write it back (envelopes recomputed) or as OBJ, CityJSON,
    CityJSONSeq or a 3D Tiles 1.1 tileset (``DIR/tileset.json``; ``viewer`` adds a CesiumJS
    page, ``source_crs`` places a model that names no CRS) (``skylod convert``); several
    inputs go to a mirrored directory or are merged into one file. Returns the paths written.

    >>> skylod.convert("fzk_haus_lod2_v2.gml", "haus.city.json")           # doctest: +SKIP
    ['haus.city.json']
    >>> skylod.convert("fzk_haus_lod2_v2.gml", "web/tileset.json", viewer=True)  # doctest: +SKIP
    ['web/tileset.json']
    """
    out = _skylod.convert(
        _paths(paths),
        os.fspath(output),
        format=format,
        overwrite=overwrite,
        source_crs=source_crs,
        viewer=viewer,
        progress=progress,
    )
    return [os.fspath(p) for p in out]
