"""An ETL step with skylod from Python: a directory of CityGML tiles, POIs from a CSV, the
mixed-LoD tiles written, SVF and sun hours of the POIs in a pandas DataFrame.

    python examples/etl.py TILES/ POIS.csv OUT_DIR/ [RESULTS.csv]

Without arguments: the repository's synthetic fixture, written to a temporary directory.
"""

import sys
import tempfile
from pathlib import Path

import pandas as pd

import skylod


def etl(tiles: str, pois_csv: str, out_dir: str) -> pd.DataFrame:
    pois = pd.read_csv(pois_csv, comment="#")
    xyz = pois[["x", "y", "z", "nx", "ny", "nz"]] if "nx" in pois else pois[["x", "y", "z"]]
    points, ids = xyz.to_numpy(dtype=float), pois["id"].astype(str).tolist()
    # The mixed-LoD model for these POIs, one output per tile below out_dir (mirrored).
    report = skylod.lod(tiles, points, out_dir.rstrip("/") + "/", ids=ids, overwrite=True)
    l0, l1, l2 = report["totals"]["levels"]
    print(f"etl: assets at level 0/1/2 = {l0}/{l1}/{l2}", file=sys.stderr)
    # Solar figures of the POIs against the full model (the GIL is released meanwhile).
    return pd.DataFrame(
        {
            "id": pois["id"],
            "svf": skylod.svf(tiles, points, ids=ids),
            "sun_hours": skylod.sun_hours(tiles, points, ids=ids, step=30),
        }
    )


def main() -> None:
    fixtures = Path(__file__).resolve().parents[2] / "fixtures"
    args = sys.argv[1:]
    tiles = args[0] if len(args) > 0 else str(fixtures / "synth-small.gml")
    csv = args[1] if len(args) > 1 else str(fixtures / "synth-small.pois.csv")
    with tempfile.TemporaryDirectory() as tmp:
        out = args[2] if len(args) > 2 else tmp + "/lod/"
        df = etl(tiles, csv, out)
    if len(args) > 3:
        df.to_csv(args[3], index=False)
    print(df.to_string(index=False))


if __name__ == "__main__":
    main()
