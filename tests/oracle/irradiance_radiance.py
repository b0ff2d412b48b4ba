#!/usr/bin/env python3
"""Annual irradiation of points of interest in OBJ models by Radiance's daylight coefficients
(the binaries of the `pyradiance` wheel: epw2wea, gendaymtx, obj2rad, xform, oconv, rcontrib,
dctimestep), the oracle of `skylod irradiance` in tests/it/irradiance.rs.

Usage: irradiance_radiance.py TMY3.csv POIS.csv MODEL.obj [MODEL.obj ...]
  -> {"id": {"global_kwh_m2": .., "direct_kwh_m2": .., "diffuse_kwh_m2": ..}, ..} (JSON)

The weather: the TMY3 file (pvlib's bundled Greensboro year) written as an EPW by Python's
csv (as tests/it/irradiance.rs does), then epw2wea. The sky: `gendaymtx -m 4 -O1 -g 0 -r 0`
(Reinhart subdivision MF 4, 2 305 patches + ground; Perez all-weather sky; the sun's energy
shared among the patches around it; solar radiance in W/sr/m2; a white sky, `-c 1 1 1`, so
the three channels are the radiometric value rather than a tint whose mean is 2.7 % high;
ground reflectance 0; no rotation). The daylight coefficients: every surface black (plastic, reflectance 0), one
glow source over the whole sphere binned by reinhart.cal (`rcontrib -I+ -ab 1 -e MF:4`,
65 536 hemisphere samples per point along its normal, bin 0 the ground), so each point sees
each patch exactly where the model does not hide it; dctimestep multiplies them by the sky
of every hour (W/m2) and the hours are summed (Wh/m2, one hour each).

The scene and the POIs as in radiance_svf.py (its OBJ origin convention, 1 cm along the
normal). Compare with `skylod irradiance --albedo 0` (no ground nor obstruction light here).
Both use the Perez all-weather sky on the same patches; skylod traces the sun as a ray per
hour where Radiance smears it over the four patches nearest to it.
"""

import csv
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

from radiance_svf import BIN, LIB, POI_OFFSET, materials, origin_of, read_pois, tool

MF = "4"
AMBIENT = ["-ab", "1", "-ad", "65536", "-as", "0", "-aa", "0", "-lw", "1e-8"]


def epw_from_tmy3(src, dst):
    """The TMY3 file's hours as an EPW (same columns as the EPW test of irradiance.rs)."""
    rows = list(csv.reader(open(src, newline="")))
    st, head, data = rows[0], rows[1], rows[2:]
    col = {h.split(" (")[0]: i for i, h in enumerate(head)}
    with open(dst, "w", newline="") as f:
        f.write(f"LOCATION,{st[1]},{st[2]},USA,TMY3,{st[0]},{st[4]},{st[5]},{st[3]},{st[6]}\n")
        for line in [
            "DESIGN CONDITIONS,0",
            "TYPICAL/EXTREME PERIODS,0",
            "GROUND TEMPERATURES,0",
            "HOLIDAYS/DAYLIGHT SAVINGS,No,0,0,0",
            "COMMENTS 1,from TMY3",
            "COMMENTS 2,",
            "DATA PERIODS,1,1,Data,Sunday, 1/ 1,12/31",
        ]:
            f.write(line + "\n")
        for r in data:
            m, d, y = r[col["Date"]].split("/")
            h = int(r[col["Time"]].split(":")[0])
            vals = [y, str(int(m)), str(int(d)), str(h), "60", "?", "10", "5", "70", "101325",
                    "0", "0", "300", r[col["GHI"]], r[col["DNI"]], r[col["DHI"]]] + ["0"] * 19
            f.write(",".join(vals) + "\n")


def read_matrix(text):
    """A Radiance ASCII matrix (header, blank line, rows of RGB triples) as rows x cols x 3."""
    head, _, body = text.partition("\n\n")
    nrows = ncols = None
    for line in head.splitlines():
        if line.startswith("NROWS="):
            nrows = int(line.split("=")[1])
        elif line.startswith("NCOLS="):
            ncols = int(line.split("=")[1])
    v = np.array(body.split(), dtype=float)
    if nrows is None:
        nrows = v.size // (3 * ncols)
    return v.reshape(nrows, ncols, 3)


def annual(tmy3, tmp, scene, mats, rays):
    """Global, direct and diffuse Wh/m2 of each of `rays` ("x y z dx dy dz" lines, the scene's
    frame) over the TMY3 year, the scene the Radiance files `scene` whose materials `mats` are
    made black, in the temporary folder `tmp`: [{"global_kwh_m2": ..}, ..] in ray order."""
    env = dict(os.environ, RAYPATH=os.pathsep.join([".", LIB]))
    run = lambda args, **kw: subprocess.run(args, check=True, capture_output=True, env=env, **kw)
    epw = os.path.join(tmp, "w.epw")
    epw_from_tmy3(tmy3, epw)
    wea = os.path.join(tmp, "w.wea")
    run([tool("epw2wea"), epw, wea])
    # the whole sky, the sun alone (-d), the sky without the sun (-s)
    skies = {}
    for part, flag in (("global", []), ("direct", ["-d"]), ("diffuse", ["-s"])):
        sky = run([tool("gendaymtx"), "-m", MF, "-O1", "-c", "1", "1", "1", *flag, "-g", "0",
                   "0", "0", "-r", "0", wea]).stdout
        skies[part] = os.path.join(tmp, f"{part}.smx")
        with open(skies[part], "wb") as f:
            f.write(sky)
    glow = os.path.join(tmp, "glow.rad")
    with open(glow, "w", encoding="utf-8") as f:
        f.write("void glow sky_glow 0 0 4 1 1 1 0\n")
        f.write("sky_glow source sky 0 0 4 0 0 1 360\n")
        for m in sorted(mats):
            f.write(f"void plastic {m} 0 0 5 0 0 0 0 0\n")
    octree = os.path.join(tmp, "scene.oct")
    with open(octree, "wb") as f:
        f.write(run([tool("oconv"), glow, *scene]).stdout)
    dc = run(
        [tool("rcontrib"), "-I+", *AMBIENT, "-fo", "-e", f"MF:{MF}", "-f", "reinhart.cal",
         "-b", "rbin", "-bn", "Nrbins", "-m", "sky_glow", "-faa", octree],
        input=("\n".join(rays) + "\n").encode(),
    ).stdout
    dcm = os.path.join(tmp, "dc.mtx")
    with open(dcm, "wb") as f:
        f.write(dc)
    result = [{} for _ in rays]
    for part, smx in skies.items():
        m = read_matrix(run([tool("dctimestep"), "-oa", dcm, smx]).stdout.decode())
        # rows: points, columns: hours; R = G = B for the solar (-O1) sky
        wh = m.mean(axis=2).sum(axis=1)
        for k in range(len(rays)):
            result[k][f"{part}_kwh_m2"] = float(wh[k]) / 1000.0
    return result


def main():
    tmy3, pois_csv, objs = sys.argv[1], sys.argv[2], sys.argv[3:]
    env = dict(os.environ, RAYPATH=os.pathsep.join([".", LIB]))
    run = lambda args, **kw: subprocess.run(args, check=True, capture_output=True, env=env, **kw)
    frame = origin_of(objs[0])
    with tempfile.TemporaryDirectory() as tmp:
        scene, mats = [], set()
        for k, obj in enumerate(objs):
            mats |= materials(obj)
            path = os.path.join(tmp, f"m{k}.rad")
            with open(path, "wb") as f:
                f.write(run([tool("obj2rad"), obj]).stdout)
            o = origin_of(obj)
            shift = [o[i] - frame[i] for i in range(3)]
            if any(abs(s) > 0 for s in shift):
                moved = run([tool("xform"), "-t", *map(repr, shift), path]).stdout
                with open(path, "wb") as f:
                    f.write(moved)
            scene.append(path)
        pois = read_pois(pois_csv)
        lines = []
        for _, p, n in pois:
            o = [p[i] - frame[i] + POI_OFFSET * n[i] for i in range(3)]
            lines.append(" ".join(repr(v) for v in (*o, *n)))
        values = annual(tmy3, tmp, scene, mats, lines)
    print(json.dumps({pid: v for (pid, _, _), v in zip(pois, values)}))


if __name__ == "__main__":
    main()
