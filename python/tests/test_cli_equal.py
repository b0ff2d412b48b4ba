"""The Python calls give the command line's answers: the same JSON documents (timings aside),
the same numbers in the arrays, the same bytes written."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import numpy as np
import pytest

import skylod
from conftest import csv_rows, missing, tree, without_timings


def ingolstadt_tiles(shared_data: Path) -> list:
    tiles = sorted((shared_data / "ingolstadt-lod3").glob("*.xml.gz"))[:3]
    if len(tiles) < 3:
        missing(f"Ingolstadt LoD3 tiles in {shared_data}")
    return [str(t) for t in tiles]


def street_pois(tiles: list) -> np.ndarray:
    """Points 1.5 m above the ground across the tiles' box (some may be inside buildings:
    the flags say so, on both sides)."""
    b = skylod.stats(tiles)["bbox"]
    xs = np.linspace(b[0], b[3], 5)[1:-1]
    ys = np.linspace(b[1], b[4], 4)[1:-1]
    return np.array([[x, y, b[2] + 1.5] for x in xs for y in ys])


def poi_flags(pois: np.ndarray) -> list:
    return [a for p in pois for a in ("--poi", ",".join(repr(float(v)) for v in p))]


def test_stats_is_the_total_of_stats_json(cli, synth, shared_data):
    tiles = ingolstadt_tiles(shared_data)
    for paths in ([str(synth)], tiles, [str(shared_data / "ingolstadt-lod3")]):
        assert skylod.stats(paths) == cli.json("stats", *paths)["total"]
    assert skylod.stats(synth) == skylod.stats([synth])


def test_svf_equals_the_cli_on_a_poi_csv(cli, synth, synth_pois):
    doc = skylod.svf(synth, synth_pois, rays=2000, seed=3, full=True)
    want = cli.json("svf", synth, "--pois", synth_pois, "--rays", 2000, "--seed", 3)
    assert without_timings(doc) == without_timings(want)
    # The array is the document's column, POI by POI; the CSV's points as an array agree.
    a = skylod.svf(synth, synth_pois, rays=2000, seed=3)
    assert a.tolist() == [p["svf"] for p in want["pois"]]
    ids = ["B0_0_0_o6", "B0_0_1_o7", "B0_0_2_o4"]
    b = skylod.svf(synth, np.array(csv_rows(synth_pois)), rays=2000, seed=3, ids=ids)
    assert b.tolist() == a.tolist()


def test_svf_and_sun_hours_equal_the_cli_on_shared_tiles(cli, shared_data):
    tiles = ingolstadt_tiles(shared_data)
    pois = street_pois(tiles)
    doc = skylod.svf(tiles, pois, rays=1000, full=True)
    want = cli.json("svf", *tiles, *poi_flags(pois), "--rays", 1000)
    assert without_timings(doc) == without_timings(want)
    assert len(doc["pois"]) == len(pois)
    hours = skylod.sun_hours(tiles, pois, step=60, full=True)
    want = cli.json("sun-hours", *tiles, *poi_flags(pois), "--step", 60)
    assert without_timings(hours) == without_timings(want)


def test_sun_hours_site_and_timezone_equal_the_cli(cli, synth, synth_pois):
    got = skylod.sun_hours(
        synth, synth_pois, site=(41.39, 2.16), step=60, year=2024, timezone="Europe/Madrid", full=True
    )
    want = cli.json(
        "sun-hours", synth, "--pois", synth_pois, "--lat", 41.39, "--lon", 2.16,
        "--step", 60, "--year", 2024, "--timezone", "Europe/Madrid",
    )
    assert without_timings(got) == without_timings(want)
    a = skylod.sun_hours(synth, synth_pois, site=(41.39, 2.16), step=60, year=2024)
    assert a.tolist() == [p["sun_hours"] for p in want["pois"]]


def test_horizon_equals_the_cli(cli, synth, synth_pois):
    got = skylod.horizon(synth, synth_pois, step=5.0, full=True)
    want = cli.json("horizon", synth, "--pois", synth_pois, "--step", 5)
    assert without_timings(got) == without_timings(want)
    a = skylod.horizon(synth, synth_pois, step=5.0)
    assert a.tolist() == [p["elevation"] for p in want["pois"]]


def test_evaluate_equals_the_cli(cli, synth, synth_pois):
    got = skylod.evaluate(synth, synth_pois, rays=2000, svf_rays=2000, step=120)
    want = cli.json(
        "evaluate", synth, "--pois", synth_pois, "--rays", 2000, "--svf-rays", 2000, "--step", 120
    )
    assert without_timings(got) == without_timings(want)
    assert got["sun"] is not None and len(got["pois"]) == 3


def pvlib_tmy3() -> Path:
    """pvlib's bundled TMY3 file (Greensboro), found through the system's python3."""
    try:
        o = subprocess.run(
            ["python3", "-c", "import pvlib, os; print(os.path.dirname(pvlib.__file__))"],
            capture_output=True, text=True,
        )
    except OSError:
        o = None
    if o is None or o.returncode != 0:
        missing("pvlib (its bundled TMY3 file) for python3")
    p = Path(o.stdout.strip()) / "data" / "723170TYA.CSV"
    if not p.is_file():
        missing(str(p))
    return p


def test_irradiance_equals_the_cli(cli, synth, synth_pois):
    tmy = pvlib_tmy3()
    got = skylod.irradiance(synth, synth_pois, tmy, site=(36.1, -79.9), rays=1000, full=True)
    want = cli.json(
        "irradiance", synth, "--pois", synth_pois, "--weather", tmy,
        "--lat", 36.1, "--lon", -79.9, "--rays", 1000,
    )
    assert without_timings(got) == without_timings(want)
    a = skylod.irradiance(synth, synth_pois, tmy, site=(36.1, -79.9), rays=1000)
    assert a.tolist() == [p["global_kwh_m2"] for p in want["pois"]]
    assert (a > 0).all()
    # The station is ~6,900 km from the model: refused without a site, as on the CLI.
    with pytest.raises(skylod.SkylodError, match="km from the weather station"):
        skylod.irradiance(synth, synth_pois, tmy)


def test_irradiance_surfaces_equals_the_cli_s_tables(cli, shared_data, tmp_path):
    import csv

    import pandas as pd

    tmy = pvlib_tmy3()
    house = shared_data / "kit-fzk-haus" / "citygml2" / "fzk_haus_lod2_v2.gml"
    table, points = tmp_path / "t.csv", tmp_path / "p.csv"
    cli.run(
        "irradiance", house, "--surfaces", "roof,wall", "--weather", tmy, "--lat", 36.1,
        "--lon", -79.9, "--rays", 1000, "--threshold", 1000, "--table", table,
        "--points", points,
    )
    kw = dict(site=(36.1, -79.9), rays=1000)
    got = skylod.irradiance_surfaces(house, tmy, ("roof", "wall"), threshold=1000, **kw)
    want = list(csv.DictReader(open(table)))
    assert got["surface_id"].tolist() == [r["surface_id"] for r in want]
    assert got["kind"].tolist() == [r["kind"] for r in want]
    assert got["points"].tolist() == [int(r["points"]) for r in want]
    for k in ("area_m2", "mean_kwh_m2", "min_kwh_m2", "max_kwh_m2", "area_above_m2"):
        assert np.allclose(got[k], [float(r[k]) for r in want], atol=6e-4), k
    p = skylod.irradiance_surfaces(house, tmy, ["roof", "wall"], points=True, **kw)
    want = list(csv.DictReader(open(points)))
    assert p["surface_id"].tolist() == [r["surface_id"] for r in want]
    assert np.allclose(p["global_kwh_m2"], [float(r["global_kwh_m2"]) for r in want], atol=6e-4)
    # the twelve months, as --monthly writes them
    monthly_table = tmp_path / "m.csv"
    cli.run(
        "irradiance", house, "--surfaces", "roof,wall", "--weather", tmy, "--lat", 36.1,
        "--lon", -79.9, "--rays", 1000, "--monthly", "--table", monthly_table,
    )
    m = skylod.irradiance_surfaces(house, tmy, ("roof", "wall"), monthly=True, **kw)
    want = list(csv.DictReader(open(monthly_table)))
    assert list(m) == list(want[0])  # the CLI's columns, in its order
    names = list(want[0])[8:20]
    assert names[0] == "jan_kwh_m2" and names[-1] == "dec_kwh_m2"
    for k in names:
        assert np.allclose(m[k], [float(r[k]) for r in want], atol=6e-4), k
    mp = skylod.irradiance_surfaces(house, tmy, ("roof",), points=True, monthly=True, **kw)
    months = np.stack([mp[k] for k in names])
    assert np.allclose(months.sum(axis=0), mp["global_kwh_m2"], rtol=1e-6)
    # a DataFrame in one line; roofs only by default, no threshold column without one
    roofs = pd.DataFrame(skylod.irradiance_surfaces(house, tmy, **kw))
    assert set(roofs["kind"]) == {"roof"} and "area_above_m2" not in roofs
    with pytest.raises(skylod.SkylodError, match="roof"):
        skylod.irradiance_surfaces(house, tmy, ("roofs",), **kw)


def test_lod_writes_the_cli_s_bytes_and_report(cli, synth, synth_pois, tmp_path):
    out = tmp_path / "lod.gml"
    rep = tmp_path / "report.json"
    cli.run("lod", synth, "--pois", synth_pois, "-o", out, "--report", rep, "--rays", 2000)
    want_bytes, want = out.read_bytes(), json.loads(rep.read_text())
    out.unlink()
    report = skylod.lod(synth, synth_pois, out, rays=2000)
    assert out.read_bytes() == want_bytes
    assert without_timings(report) == without_timings(want)
    assert report["guarantee"]["svf_error"] == 0.01
    # Without overwrite an existing output is refused, naming it; with it, the same bytes.
    with pytest.raises(skylod.SkylodError, match="lod.gml"):
        skylod.lod(synth, synth_pois, out, rays=2000)
    out.write_bytes(b"stale")
    skylod.lod(synth, synth_pois, out, rays=2000, overwrite=True)
    assert out.read_bytes() == want_bytes


def test_lod_mirrors_shared_tiles_as_the_cli(cli, shared_data, tmp_path):
    tiles = ingolstadt_tiles(shared_data)
    pois = street_pois(tiles)
    out = tmp_path / "out"
    rep = tmp_path / "report.json"
    cli.run("lod", *tiles, *poi_flags(pois), "-o", f"{out}/", "--report", rep, "--no-bound")
    want_tree = tree(out)
    want = json.loads(rep.read_text())
    assert len(want_tree) == len(tiles)
    for p in out.rglob("*"):
        if p.is_file():
            p.unlink()
    report = skylod.lod(tiles, pois, f"{out}/", bound=False)
    assert tree(out) == want_tree
    # The report says how the bound was turned off in the caller's terms.
    assert want["guarantee"]["not_bounded"] == ["SVF and sun hours: no error bound (--no-bound)"]
    want["guarantee"]["not_bounded"] = ["SVF and sun hours: no error bound (bound=False)"]
    assert without_timings(report) == without_timings(want)


def test_convert_writes_the_cli_s_bytes(cli, synth, shared_data, tmp_path):
    tiles = ingolstadt_tiles(shared_data)
    for name, inputs in (
        ("one.gml", [synth]),
        ("one.city.json", [synth]),
        ("one.obj", [synth]),
        ("merged.gml", tiles),
        ("mirror/", tiles),
        ("web/tileset.json", [synth]),
        ("street/tileset.json", tiles),
    ):
        a, b = tmp_path / "cli" / name, tmp_path / "py" / name
        a.parent.mkdir(parents=True, exist_ok=True)
        b.parent.mkdir(parents=True, exist_ok=True)
        cli.run("convert", *inputs, "-o", f"{a}/" if name.endswith("/") else a)
        written = skylod.convert(inputs, f"{b}/" if name.endswith("/") else b)
        if name.endswith("tileset.json"):
            assert tree(a.parent) == tree(b.parent) and len(tree(b.parent)) > 1, name
            assert written == [str(b)]
        elif name.endswith("/"):
            assert tree(a) == tree(b) and len(tree(b)) == len(tiles)
            assert sorted(written) == sorted(str(p) for p in b.rglob("*") if p.is_file())
        else:
            assert a.read_bytes() == b.read_bytes(), name
            assert written == [str(b)]
