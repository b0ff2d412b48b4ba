"""Shared fixtures of the Python tests: the repository's fixtures, the shared data beside the
checkout (``../shared/data``) and the ``skylod`` binary the Python results are compared with.

A resource a test needs and cannot find fails the test under ``CI=true`` and skips it with
the reason otherwise, as the Rust tests do (``tests/it/util.rs``).
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path
from typing import Any, Dict, List

import pytest

REPO = Path(__file__).resolve().parents[2]
FIXTURES = REPO / "fixtures"


def missing(what: str) -> None:
    """A required resource is missing: fail under CI, skip otherwise."""
    if os.environ.get("CI") == "true":
        pytest.fail(f"CI=true but {what} is missing")
    pytest.skip(f"{what} is missing (set CI=true to make this a failure)")


@pytest.fixture(scope="session")
def shared_data() -> Path:
    p = REPO.parent / "shared" / "data"
    if not p.is_dir():
        missing(f"shared test data {p}")
    return p


def _find_binary() -> Path | None:
    env = os.environ.get("SKYLOD_BIN")
    if env:
        return Path(env)
    targets = [os.environ.get("CARGO_TARGET_DIR"), str(REPO / "target")]
    for t in filter(None, targets):
        for profile in ("debug", "release"):
            b = Path(t) / profile / "skylod"
            if b.is_file():
                return b
    w = shutil.which("skylod")
    return Path(w) if w else None


@pytest.fixture(scope="session")
def skylod_bin() -> Path:
    b = _find_binary()
    if b is None or not b.is_file():
        missing("the skylod binary (SKYLOD_BIN, $CARGO_TARGET_DIR or target/ debug|release)")
    return b


class Cli:
    """Runs the skylod binary."""

    def __init__(self, binary: Path):
        self.binary = binary

    def run(self, *args: Any, ok: bool = True) -> subprocess.CompletedProcess:
        r = subprocess.run(
            [str(self.binary), *map(str, args)], capture_output=True, text=True, timeout=900
        )
        if ok:
            assert r.returncode == 0, f"skylod {args}: {r.returncode}\n{r.stderr}"
        return r

    def json(self, *args: Any) -> Dict[str, Any]:
        return json.loads(self.run(*args, "--json").stdout)


@pytest.fixture(scope="session")
def cli(skylod_bin: Path) -> Cli:
    return Cli(skylod_bin)


@pytest.fixture(scope="session")
def synth() -> Path:
    return FIXTURES / "synth-small.gml"


@pytest.fixture(scope="session")
def synth_pois() -> Path:
    return FIXTURES / "synth-small.pois.csv"


def without_timings(doc: Any) -> Any:
    """The document without its wall-clock fields (``timings_ms``, ``select_ms``, ``bvh_ms``,
    ...: every key ``ms`` or ending in ``_ms`` or ``_s``)."""
    if isinstance(doc, dict):
        return {
            k: without_timings(v)
            for k, v in doc.items()
            if not (k == "ms" or k.endswith("_ms") or k.endswith("_s"))
        }
    if isinstance(doc, list):
        return [without_timings(v) for v in doc]
    return doc


def tree(root: Path) -> Dict[str, bytes]:
    """Every file below ``root`` (relative path → bytes)."""
    return {
        str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()
    }


def csv_rows(path: Path) -> List[List[float]]:
    """The ``x,y,z[,nx,ny,nz]`` of a POI CSV with a header."""
    import csv

    with open(path, newline="") as f:
        r = csv.DictReader(f)
        cols = [c for c in ("x", "y", "z", "nx", "ny", "nz") if c in (r.fieldnames or [])]
        return [[float(row[c]) for c in cols] for row in r]
