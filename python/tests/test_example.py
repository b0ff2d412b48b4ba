"""The example script (python/examples/etl.py, the README's ETL step) runs and its figures
are the calls' own."""

from __future__ import annotations

import runpy
from pathlib import Path

import pytest

import skylod
from conftest import missing


def test_the_etl_example_gives_a_dataframe_of_the_calls_figures(synth, synth_pois, tmp_path):
    try:
        import pandas  # noqa: F401
    except ImportError:
        missing("pandas (pip install pandas)")
    mod = runpy.run_path(str(Path(__file__).resolve().parents[1] / "examples" / "etl.py"))
    df = mod["etl"](str(synth), str(synth_pois), str(tmp_path / "lod"))
    assert list(df.columns) == ["id", "svf", "sun_hours"]
    assert list(df["id"]) == ["B0_0_0_o6", "B0_0_1_o7", "B0_0_2_o4"]
    assert df["svf"].tolist() == skylod.svf(synth, synth_pois).tolist()
    assert df["sun_hours"].tolist() == skylod.sun_hours(synth, synth_pois, step=30).tolist()
    assert (tmp_path / "lod" / "synth-small.gml").is_file()
