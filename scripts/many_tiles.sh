#!/usr/bin/env bash
# many_tiles.sh BIN N [WORK]: time per file of each writing command of BIN on N copies of a
# small real LoD2 tile (../shared/data/berlin/Berlin_Moabit_1Bldg_v2.gml, 19 KB) in
# WORK/tiles-N (made once; WORK defaults to a temporary folder). Prints one line a command:
# its name, N, its exit code and the wall time per file. BENCHMARKS.md, "Many tiles".
set -u
[ $# -ge 2 ] || { sed -n '2,5p' "$0" >&2; exit 2; }
bin=$1 n=$2 work=${3:-$(mktemp -d)}
tile="$(cd "$(dirname "$0")/.." && pwd)/../shared/data/berlin/Berlin_Moabit_1Bldg_v2.gml"
tiles=$work/tiles-$n out=$work/out-$n
if [ ! -d "$tiles" ]; then
  mkdir -p "$tiles"
  for i in $(seq -w 1 "$n"); do cp "$tile" "$tiles/t$i.gml"; done
fi
rm -rf "$out"; mkdir -p "$out"
run() { # NAME ARGS...: one command, timed
  local name=$1; shift
  local t0 t1 rc
  t0=$(date +%s.%N); "$bin" "$@" >/dev/null 2>"$out/$name.err"; rc=$?; t1=$(date +%s.%N)
  printf '%-16s n=%-6s rc=%s %7.3f ms/file\n' "$name" "$n" "$rc" "$(echo "($t1-$t0)*1000/$n" | bc -l)"
}
bbox=388600,5818700,388800,5818900
run stats stats "$tiles"
run convert-dir convert "$tiles" -o "$out/conv/"
run shard-dir convert "$tiles" --shard 0/2 -o "$out/shard/"
run subset-dir subset "$tiles" --bbox $bbox -o "$out/subset/"
run filter-dir filter-lods "$tiles" --lod 2 -o "$out/lods/"
run upgrade-dir upgrade "$tiles" -o "$out/upgrade/"
run rough-dir rough "$tiles" -o "$out/rough/"
run lod-dir lod "$tiles" --poi 388678,5818805,40 -o "$out/lod/"
run convert-gml convert "$tiles" -o "$out/all.gml"
run convert-json convert "$tiles" -o "$out/all.city.json"
run convert-jsonl convert "$tiles" -o "$out/all.city.jsonl"
run convert-obj convert "$tiles" -o "$out/all.obj"
