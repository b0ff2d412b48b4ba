#!/usr/bin/env python3
"""CPU time per pipeline stage of a `skylod lod` profile, and its wall time on 2 idle cores.

    perf record -F 2000 --call-graph dwarf,32768 -o p.data skylod lod IN.gml --pois P.csv -o OUT.gml
    perf script -i p.data -F tid,time,ip,sym > p.txt
    scripts/perf_stages.py p.txt 2000

A sample belongs to the first stage (in the order of STAGES) that a frame of its stack names;
a stage's wall time on 2 idle cores is estimated as max(its samples / 2, its busiest
thread's samples) / rate: stages run one after the other, each as parallel as its threads.
"""
import collections
import re
import sys

STAGES = [
    "SunTable::range_with", "AssetBoxes", "detail_boxes", "lazy_hits_with", "full_scene_part",
    "mixed_scene", "bound_with", "write_mixed", "Prescan", "write_edits", "Surroundings",
    "rough_model", "selection_scene", "select_with", "read::assemble", "parse_events",
    "read_split", "lod_with", "frame", "main_loop",
]


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    rate = float(sys.argv[2])
    samples, cur = [], None
    for line in open(sys.argv[1]):
        m = re.match(r"\s*(\d+)\s+([\d.]+):\s*$", line)
        if m:
            if cur:
                samples.append(cur)
            cur = (int(m.group(1)), [])
        elif cur is not None and line.strip():
            cur[1].append(line.strip())
    if cur:
        samples.append(cur)
    per = collections.defaultdict(collections.Counter)
    for tid, stack in samples:
        stage = next((s for s in STAGES if any(s in f for f in stack)), "other")
        per[stage][tid] += 1
    cpu = wall = 0.0
    for stage, threads in sorted(per.items(), key=lambda x: -sum(x[1].values())):
        n = sum(threads.values())
        w = max(n / 2, max(threads.values()))
        cpu, wall = cpu + n, wall + w
        busiest = sorted(threads.values(), reverse=True)[:3]
        print(f"{stage:22s} cpu {n / rate * 1e3:7.1f} ms   2-core wall {w / rate * 1e3:7.1f} ms   "
              f"samples per thread {busiest}")
    print(f"total cpu {cpu / rate * 1e3:.0f} ms, 2-core wall {wall / rate * 1e3:.0f} ms")


if __name__ == "__main__":
    main()
