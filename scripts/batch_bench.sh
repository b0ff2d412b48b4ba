#!/usr/bin/env bash
# Batch throughput: a directory of 50 tiles (the 40 largest shared Ingolstadt LoD3 tiles and
# 10 synthetic Eixample districts of 2x2 blocks, seeds 1-10) run through `stats`, `convert`
# (to a mirrored directory) and `lod` (3 POIs, 2,000 rays; --allow-mixed-crs, since the
# synthetic districts are in Barcelona's CRS) at --jobs 1 and --jobs 2, best of 3. Prints files/s
# and MB/s (decompressed XML bytes) per command and the speed-up, with the load average.
#
#   scripts/batch_bench.sh [WORK_DIR]      (default: a new directory under /tmp)
#
# SKYLOD (default: target/release/skylod) is the binary to run. Needs ../shared/data.
set -euo pipefail

here=$(cd "$(dirname "$0")/.." && pwd)
SKYLOD=${SKYLOD:-$here/target/release/skylod}
[ -x "$SKYLOD" ] || { echo "no $SKYLOD (cargo build --release)" >&2; exit 2; }
data=$here/../shared/data/ingolstadt-lod3
[ -d "$data" ] || { echo "no $data" >&2; exit 2; }
work=${1:-$(mktemp -d /tmp/skylod-batch-XXXXXX)}
tiles=$work/tiles
rm -rf "$tiles" && mkdir -p "$tiles/ingolstadt" "$tiles/synth"
# shellcheck disable=SC2012
ls -S "$data"/*.xml.gz | head -40 | xargs -I{} cp {} "$tiles/ingolstadt/"
for s in $(seq 1 10); do
  "$SKYLOD" synth --preset paper --blocks 2x2 --seed "$s" -o "$tiles/synth/district$s.gml.gz" 2>/dev/null
  rm -f "$tiles/synth/district$s.gml.pois.csv" "$tiles/synth/district$s".*.csv 2>/dev/null || true
done
find "$tiles" -name '*.csv' -delete
n=$(find "$tiles" -type f | wc -l)
gz=$(find "$tiles" -type f -printf '%s\n' | awk '{s+=$1} END {printf "%.2f", s/1e6}')
mb=$(find "$tiles" -type f -exec zcat {} + | wc -c | awk '{printf "%.1f", $1/1e6}')
echo "tiles: $n files, $gz MB gzip, $mb MB of XML (MB/s below: XML) in $tiles"
echo "load average before: $(cut -d' ' -f1-3 /proc/loadavg), cores: $(nproc)"

t() { # seconds of one run of "$@"
  local s e
  s=$(date +%s.%N); "$@" >/dev/null 2>&1 || true; e=$(date +%s.%N)
  echo "$e - $s" | bc -l
}
pois=(--poi 678060,5403830,416 --poi 678070,5403800,416 --poi 678090,5403835,418)
printf '%-8s %6s %9s %8s %9s %8s %8s\n' command jobs seconds files/s MB/s speedup
for cmd in stats convert lod; do
  declare -A secs=()
  for j in 1 2; do
    best=""
    for rep in 1 2 3; do
      rm -rf "$work/out"
      case $cmd in
        stats) s=$(t "$SKYLOD" stats --jobs "$j" "$tiles") ;;
        convert) s=$(t "$SKYLOD" convert --jobs "$j" "$tiles" -o "$work/out") ;;
        lod) s=$(t "$SKYLOD" lod --jobs "$j" --allow-mixed-crs --rays 2000 "${pois[@]}" "$tiles" -o "$work/out") ;;
      esac
      if [ -z "$best" ] || (( $(echo "$s < $best" | bc -l) )); then best=$s; fi
    done
    secs[$j]=$best
    sp=$(echo "${secs[1]} / $best" | bc -l)
    printf '%-8s %6s %9.2f %8.1f %9.2f %7.2fx\n' "$cmd" "$j" "$best" \
      "$(echo "$n / $best" | bc -l)" "$(echo "$mb / $best" | bc -l)" "$sp"
  done
  unset secs
done
echo "load average after: $(cut -d' ' -f1-3 /proc/loadavg)"
