"""Errors raise SkylodError with the library's message; POIs in every accepted form; the
shapes of the arrays."""

from __future__ import annotations

from pathlib import Path

import re

import numpy as np
import pytest

import skylod
from conftest import FIXTURES, csv_rows


def centre(synth: Path) -> list:
    b = skylod.stats(synth)["bbox"]
    return [(b[0] + b[3]) / 2, (b[1] + b[4]) / 2, b[2] + 1.5]


def test_skylod_error_is_an_exception():
    assert issubclass(skylod.SkylodError, Exception)
    assert skylod.SkylodError.__module__.startswith("skylod")


def test_a_missing_file_names_it():
    with pytest.raises(skylod.SkylodError, match="missing-tile.gml"):
        skylod.stats("/nonexistent/missing-tile.gml")


def test_a_broken_file_gives_the_cli_s_message_with_line_column_and_gml_id(cli):
    for name, gml_id in (
        ("mismatched-tag.gml", "R1"),
        ("href-dangling.gml", "MS1"),
        ("coord-nan.gml", "P1"),
    ):
        bad = FIXTURES / "bad" / name
        with pytest.raises(skylod.SkylodError) as e:
            skylod.stats(bad)
        msg = str(e.value)
        assert re.match(rf".*{re.escape(name)}:\d+:\d+ \[gml:id {gml_id}\]: ", msg), msg
        r = cli.run("stats", bad, ok=False)
        assert r.returncode == 1 and f"error: {msg}" in r.stderr, (msg, r.stderr)


def test_poi_errors(synth, synth_pois, tmp_path):
    c = centre(synth)
    with pytest.raises(skylod.SkylodError, match="expected"):
        skylod.svf(synth, [c[:2]])
    with pytest.raises(skylod.SkylodError, match=r"\(N, 3\) or \(N, 6\)"):
        skylod.svf(synth, np.zeros((2, 4)))
    with pytest.raises(skylod.SkylodError, match="no point of interest"):
        skylod.svf(synth, [])
    with pytest.raises(skylod.SkylodError, match="numbers"):
        skylod.svf(synth, [("a", "b", "c")])
    # Far outside the scene (x and y swapped): refused before tracing, the POI named.
    with pytest.raises(skylod.SkylodError, match="poi-1"):
        skylod.svf(synth, [(c[1], c[0], c[2])])
    with pytest.raises(skylod.SkylodError, match="finite|NaN|nan"):
        skylod.svf(synth, [(c[0], float("nan"), c[2])])
    dup = tmp_path / "dup.csv"
    dup.write_text("id,x,y,z\na,%r,%r,%r\na,%r,%r,%r\n" % (*c, *c))
    with pytest.raises(skylod.SkylodError, match="dup.csv"):
        skylod.svf(synth, dup)
    with pytest.raises(skylod.SkylodError, match="2 ids for 1 POIs"):
        skylod.svf(synth, [c], ids=["a", "b"])
    with pytest.raises(skylod.SkylodError, match="poi_crs"):
        skylod.svf(synth, [c], poi_crs="EPSG:no-such-crs")
    with pytest.raises(skylod.SkylodError, match="cell"):
        skylod.svf(synth, [c], rays=0)


def test_option_errors(synth, synth_pois, tmp_path):
    c = centre(synth)
    with pytest.raises(skylod.SkylodError, match="sky"):
        skylod.irradiance(synth, [c], tmp_path / "w.epw", sky="cloudy")
    with pytest.raises(skylod.SkylodError, match="albedo"):
        skylod.irradiance(synth, [c], tmp_path / "w.epw", albedo=2.0)
    with pytest.raises(skylod.SkylodError, match="w.epw"):
        skylod.irradiance(synth, [c], tmp_path / "w.epw")
    with pytest.raises(skylod.SkylodError, match="step"):
        skylod.horizon(synth, [c], step=0.0)
    with pytest.raises(skylod.SkylodError, match="angle"):
        skylod.lod(synth, [c], tmp_path / "o.gml", angle=120.0)
    with pytest.raises(skylod.SkylodError, match="format"):
        skylod.convert(synth, tmp_path / "o.x", format="shapefile")
    assert not (tmp_path / "o.gml").exists()


def test_overwriting_an_input_is_refused(synth, tmp_path):
    src = tmp_path / "in.gml"
    src.write_bytes(synth.read_bytes())
    with pytest.raises(skylod.SkylodError, match="in.gml"):
        skylod.convert(src, src, overwrite=True)
    assert src.read_bytes() == synth.read_bytes()


def test_poi_forms_and_array_shapes(synth, synth_pois):
    rows = csv_rows(synth_pois)
    n = len(rows)
    by_csv = skylod.svf(synth, synth_pois, rays=500)
    assert by_csv.shape == (n,) and by_csv.dtype == np.float64
    assert ((by_csv >= 0) & (by_csv <= 1)).all()
    # The same points without their CSV ids (named poi-1, ...: a POI's rays are seeded
    # from its id, so the figures differ from the CSV's by ray noise only).
    as_6 = skylod.svf(synth, np.array(rows), rays=500)
    as_tuples = skylod.svf(synth, [tuple(r) for r in rows], rays=500)
    assert as_6.tolist() == as_tuples.tolist()
    assert np.abs(as_6 - by_csv).max() < 0.05
    ids = ["B0_0_0_o6", "B0_0_1_o7", "B0_0_2_o4"]
    assert skylod.svf(synth, np.array(rows), rays=500, ids=ids).tolist() == by_csv.tolist()
    # (N, 3): no normals, a horizontal plane: another answer, same shape.
    as_3 = skylod.svf(synth, np.array(rows)[:, :3], rays=500)
    assert as_3.shape == (n,)
    # Mixed 3- and 6-tuples in one list.
    mixed = skylod.svf(synth, [rows[0][:3], rows[1]], rays=500)
    assert mixed.shape == (2,) and mixed[1] == as_6[1] and mixed[0] == as_3[0]
    assert skylod.sun_hours(synth, synth_pois, step=120).shape == (n,)
    h = skylod.horizon(synth, synth_pois, step=10.0)
    assert h.shape == (n, 36) and h.dtype == np.float64
    full = skylod.horizon(synth, synth_pois, step=10.0, full=True)
    assert full["pois"][0]["azimuth"] == [10.0 * k for k in range(36)]
