#!/usr/bin/env bash
# Same outputs from two skylod binaries: runs the same commands with OLD_BIN and NEW_BIN and
# compares, per case, the exit code, standard output, standard error and every file the
# command wrote (names and bytes; gzip outputs compared as written, not decompressed). Prints
# one line per case (`same` or `DIFF`, with what differs) and a final `N same, M differ`
# line; exits 1 on any difference (2 on a usage error). Made to prove that a refactoring
# changed no output, e.g. issue 23's redesign against the commit before it:
#
#   scripts/same_outputs.sh OLD_BIN NEW_BIN [WORK_DIR]     (default: a new directory under /tmp)
#
# The cases (about 1,080, ~4 minutes with two debug builds on 2 cores): every CityGML file
# under ../shared/data (.gml, .xml, .gz) and in fixtures/ (fixtures/*.gml, fixtures/scenes,
# tests/data) through `stats --json`, `convert` to CityGML, OBJ, CityJSON and CityJSONSeq
# and `rough`; `synth --preset small` and `--preset paper` with their POI CSVs through `lod`
# (report, error bound, OBJ/CityJSON, --jobs 1 and 2), `evaluate`, `svf`, `sun-hours`,
# `horizon`, `fisheye`, `--facade`/`--region`; the real-data commands of the README and
# docs/GUIDE.md (the Ingolstadt LoD3 street, PLATEAU EPSG:6697 with --poi-crs, -o DIR
# mirroring, merges of several tiles into one file, standard input and output, --shard
# and --reduce); and errors: a missing file, every file of fixtures/bad/, refused POIs,
# outputs that exist, usage errors.
#
# Every command runs in its own directory (WORK_DIR/old/CASE/files, WORK_DIR/new/CASE/files),
# which is where it writes; inputs are absolute paths (the same for both binaries), or, for
# files an earlier case made (synth districts, levels files), paths relative to the case's
# directory, so that both binaries get the same arguments. The scheduler variables of
# `--shard` are unset, LC_ALL=C, a 300 s timeout. The two binaries run at the same time (one
# sequence of cases each). A part of a case is the same when its bytes are equal. Only when
# they are not, and only for standard output, standard error and written `*.json` and
# `*.jsonl` files other than CityJSON (reports, `--json` output, `lod --shard` levels files),
# are these masked on both sides before comparing again (the line then says
# `same (masked: PARTS)`):
#   - a number followed by `ms` or `s` as a word, with or without a space (`read 4 ms`,
#     `0.02 s`, `7886 ms`) becomes `T`;
#   - the work directory's path (WORK_DIR/old, WORK_DIR/new) becomes `WORK`, and the random
#     part of skylod's temporary directories (`/tmp/skylod-stdin-znJFDZ/stdin`, where standard
#     input is kept) becomes `XXXXXX`;
#   - in `evaluate`'s table (lines `<poi> full|lod|boxes <number> ...`) the last three
#     columns (bvh ms, trace ms, select ms) become `T`;
#   - in JSON, every number inside a `"timings_ms": {...}` object, and the value of every
#     key named `ms`, `seconds` or ending in `_ms` (`"select_ms"`, `"bvh_ms"`, `"trace_ms"`),
#     becomes `T`;
#   - for the cases that write OBJ or CityJSON files from several inputs in parallel
#     (`convert`/`rough -o DIR --format obj|cityjson --jobs 2`), the lines of standard error
#     are sorted: each file's summary line is printed as that file is done, in an order that
#     varies from run to run of one binary (the same cases at `--jobs 1` are not sorted).
# Written CityGML, OBJ, CityJSON(Seq), CSV and SVG files are never masked, nor is
# the exit code. A DIFF leaves WORK_DIR/diffs/CASE.diff (unified diffs, masked as above;
# gzip outputs decompressed) and prints its first lines.
#
# Needs ../shared/data (the cases that need it are left out, with a note, when it is missing).
set -euo pipefail

[ $# -ge 2 ] && [ $# -le 3 ] || { sed -n '2,10p' "$0" >&2; exit 2; }
old=$(realpath "$1")
new=$(realpath "$2")
for b in "$old" "$new"; do [ -x "$b" ] || { echo "no executable $b" >&2; exit 2; }; done
here=$(cd "$(dirname "$0")/.." && pwd)
work=$(realpath -m "${3:-$(mktemp -d /tmp/skylod-same-XXXXXX)}")
fix=$here/fixtures
data=$(realpath -m "$here/../shared/data")
rm -rf "$work/old" "$work/new" "$work/diffs"
mkdir -p "$work/old" "$work/new" "$work/diffs"
: > "$work/cases"

# ---------------------------------------------------------------------------------------------
# Running: `c NAME ARGS...` runs the binary in ROOT/NAME/files; `ci NAME STDIN ARGS...` the
# same with STDIN as standard input. `@ROOT@` in an argument is ROOT named relative to the
# case's directory (`@ROOT@/synth-small/files/small.gml`: a file an earlier case made), so
# that both binaries get the same arguments.

c() { ci "$1" /dev/null "${@:2}"; }
# `cu NAME ARGS...`: as `c`, for a command whose standard error lines come in an order that
# varies from run to run (see the header)
cu() { ci "$1" /dev/null "${@:2}"; touch "$root/$1/unordered"; }
ci() {
  local name=$1 in=$2 d rc=0 up=../.. x i args=()
  shift 2
  d=$root/$name
  [ ! -e "$d" ] || { echo "case $name twice" >&2; exit 2; }
  mkdir -p "$d/files"
  [ "$root" != "$work/old" ] || echo "$name" >> "$work/cases"
  x=${name//[!\/]/}
  for ((i = 0; i < ${#x}; i++)); do up=$up/..; done
  for x in "$@"; do args+=("${x//@ROOT@/$up}"); done
  (cd "$d/files" && env -u JOB_COMPLETION_INDEX -u SLURM_ARRAY_TASK_ID -u SLURM_ARRAY_TASK_MIN \
    -u SLURM_ARRAY_TASK_COUNT -u AWS_BATCH_JOB_ARRAY_INDEX LC_ALL=C \
    timeout 300 "$bin" "${args[@]}" < "$in" > "$d/stdout" 2> "$d/stderr") || rc=$?
  echo "$rc" > "$d/rc"
}
# a file made by an earlier case
prev() { echo "@ROOT@/$1/files"; }

have_data() { [ -d "$data/ingolstadt-lod3" ] && [ -d "$data/plateau" ]; }

# A name for a case made from a path: data/kit-fzk-haus/a.gml -> kit-fzk-haus__a.gml
slug() { local s=${1#"$data"/}; s=${s#"$here"/}; echo "${s//\//__}"; }

cases() {
  # --- every CityGML file: stats, convert to each format, rough ------------------------------
  local files=() f n i j
  mapfile -t files < <(
    { [ ! -d "$data" ] || find "$data" -type f \( -name '*.gml' -o -name '*.xml' -o -name '*.gz' \);
      ls "$fix"/*.gml "$fix"/scenes/*.gml "$here"/tests/data/*.gml; } | LC_ALL=C sort)
  for f in "${files[@]}"; do
    n=$(slug "$f")
    c "stats/$n" stats --json "$f"
    c "convert-gml/$n" convert "$f" -o x.gml
    c "convert-obj/$n" convert "$f" -o x.obj
    c "convert-cityjson/$n" convert "$f" -o x.city.json
    c "convert-cityjsonseq/$n" convert "$f" -o x.city.jsonl
    c "rough/$n" rough "$f" -o x.gml
  done
  c stats-text-verbose stats -v "$fix/chimney-citygml2.gml" "$fix/chimney-citygml3.gml"
  c rough-options rough "$fix/chimney-citygml2.gml" -o r.gml --angle 10 --thickness 0.5 --no-lod2
  c rough-stdout rough "$fix/synth-small.gml" -o -

  # --- synth small and its POIs through every tracing command ---------------------------------
  c synth-small synth --preset small -o small.gml
  local s p
  s=$(prev synth-small)/small.gml
  p=$(prev synth-small)/small.pois.csv
  c synth-blocks synth --blocks 2x1 --seed 7 --with-lod2 -o d.gml.gz
  for j in 1 2; do
    c "small/lod-j$j" lod "$s" --pois "$p" --poi 430000,4581000,13.5 -o lod.gml \
      --report report.json --jobs "$j"
    c "small/lod-bound-j$j" lod "$s" --pois "$p" --poi 430000,4581000,13.5 -o lod.gml \
      --report report.json --max-svf-error 0.01 --jobs "$j"
    c "small/evaluate-json-j$j" evaluate "$s" --pois "$p" --json --step 60 --jobs "$j"
    c "small/svf-json-j$j" svf "$s" --pois "$p" --json --jobs "$j"
    c "small/sun-hours-json-j$j" sun-hours "$s" --pois "$p" --json --step 30 --jobs "$j"
    c "small/horizon-json-j$j" horizon "$s" --pois "$p" --json --jobs "$j"
    c "small/fisheye-j$j" fisheye "$s" --pois "$p" -o sky.svg --jobs "$j"
  done
  c small/lod-bound-sun lod "$s" --pois "$p" -o lod.gml --report report.json \
    --max-svf-error 0.01 --max-sun-hours-error 0.01 --step 60
  c small/lod-obj lod "$s" --pois "$p" -o lod.obj
  c small/lod-cityjson lod "$s" --pois "$p" -o lod.city.json
  c small/lod-cityjsonseq lod "$s" --pois "$p" -o lod.city.jsonl
  c small/lod-stdout lod "$s" --pois "$p" -o - --rays 2000 --seed 3 --threshold 3
  c small/lod-gz lod "$s" --pois "$p" -o lod.gml.gz --angle 10 --thickness 0.5 --no-lod2
  c small/lod-fixture lod "$fix/synth-small.gml" --pois "$fix/synth-small.pois.csv" \
    --poi 430000,4581000,13.5 -o small-lod.gml --report small-report.json
  c small/evaluate-text evaluate "$s" --pois "$p" --no-sun
  c small/evaluate-text-sun evaluate "$s" --pois "$p" --step 60 --lat 41.39 --lon 2.17
  c small/svf-text svf "$s" --pois "$p" --rays 2000 --seed 5
  c small/svf-csv svf "$fix/synth-small.gml" --poi 430032.4,4581009.95,16.6,0,-1,0 --rays 100000
  c small/sun-hours-text sun-hours "$s" --pois "$p" --lat 41.39 --lon 2.17 \
    --timezone Europe/Madrid --step 60
  c small/horizon-csv horizon "$s" --poi 430032.4,4581009.95,16.6 -o horizon.csv --step 2
  c small/horizon-stdout horizon "$s" --pois "$p" --step 30
  c small/fisheye-one fisheye "$s" --poi 430032.407,4581009.950,16.600,0,-1,0 \
    --lat 41.39 --lon 2.17 -o sky.svg
  c small/fisheye-stereo-stdout fisheye "$s" --poi 430032.407,4581009.950,16.600,0,-1,0 \
    --projection stereographic --rays 500 -o -
  local region="POLYGON((430000 4581000, 430010 4581000, 430010 4581010, 430000 4581010, 430000 4581000))"
  c small/svf-facade svf "$s" --facade B0_0_0_s0 --spacing 2 --json
  c small/lod-facade-region lod "$s" --facade B0_0_0 --region "$region" --height 1.5 \
    --spacing 2 -o out.gml --report r.json
  c small/sun-hours-region sun-hours "$s" --region "$region" --height 1.5 --spacing 3 --step 60
  c small/lod-info lod "$s" --pois "$p" --rays 2000 -o o.gml --log-level info
  c small/lod-debug-quiet lod "$s" --pois "$p" --rays 2000 -o o.gml -q
  for i in 0 1; do
    c "small/lod-shard-$i" lod "$s" --pois "$p" --rays 3000 --shard "$i/2" -o "levels-$i.jsonl"
    c "small/svf-shard-$i" svf "$s" --pois "$p" --rays 1500 --json --shard "$i/2"
  done
  c small/lod-reduce lod "$s" -o reduced.gml --report reduced.json --reduce \
    "$(prev small/lod-shard-1)/levels-1.jsonl" "$(prev small/lod-shard-0)/levels-0.jsonl"

  # --- the paper district ----------------------------------------------------------------------
  c synth-paper synth --preset paper -o paper.gml
  c paper/lod lod "$(prev synth-paper)/paper.gml" --pois "$(prev synth-paper)/paper.pois.csv" \
    -o paper-lod.gml --report report.json

  # --- real data: the README's and the guide's commands ------------------------------------------
  if have_data; then
    local ing=$data/ingolstadt-lod3 tiles=() street=()
    tiles=("$ing/4018106.xml.gz" "$ing/4018115.xml.gz" "$ing/4018128.xml.gz")
    street=(--poi 678090,5403790,415 --poi 678075,5403800,416 --poi 678105,5403805,418
      --poi 678090,5403825,420 --poi 678060,5403780,414)
    local facades=(--poi 678184.488,5403910.026,421.429,0.3969,-0.9178,0
      --poi 678146.706,5403898.825,421.289,0.2584,-0.9660,0
      --poi 678086.159,5403875.438,421.434,0.9321,0.3623,0
      --poi 678150.193,5403776.433,419.363,-0.8357,-0.5492,0
      --poi 678111.129,5403764.510,420.585,-0.8520,-0.5236,0)
    c ingolstadt/stats-dir-json stats --json "$ing/"
    c ingolstadt/stats-glob stats "$ing/40181*.xml.gz"
    for j in 1 2; do
      c "ingolstadt/convert-mirror-j$j" convert "$ing/" -o out/ --jobs "$j"
      c "ingolstadt/lod-street-j$j" lod "${tiles[@]}" "${street[@]}" -o lod/ --report r.json \
        --jobs "$j"
      c "ingolstadt/horizon-json-j$j" horizon "$ing/" --poi 678095,5403890,418,0,-1,0 \
        --json --jobs "$j"
    done
    c ingolstadt/convert-merge convert "${tiles[@]}" -o merged.gml
    c ingolstadt/convert-merge-stdout convert "$ing/4018106.xml.gz" "$ing/4018133.xml.gz" -o -
    # --jobs 1: one order; --jobs 2: the order varies (see the header)
    c ingolstadt/convert-obj-dir-j1 convert "${tiles[@]}" -o objs/ --format obj --jobs 1
    cu ingolstadt/convert-obj-dir-j2 convert "${tiles[@]}" -o objs/ --format obj --jobs 2
    c ingolstadt/rough-dir-obj-j1 rough "$ing/" -o rough/ --format obj --jobs 1
    cu ingolstadt/rough-dir-obj-j2 rough "$ing/" -o rough/ --format obj --jobs 2
    c ingolstadt/convert-cityjson-dir-j1 convert "${tiles[@]}" -o cj/ --format cityjson --jobs 1
    cu ingolstadt/convert-cityjson-dir-j2 convert "${tiles[@]}" -o cj/ --format cityjson --jobs 2
    c ingolstadt/rough-merge rough "${tiles[@]}" -o rough.gml.gz
    c ingolstadt/lod-all-facades lod "$ing/" "${facades[@]}" --poi 678095,5403890,418,0,-1,0 \
      -o lod/ --report r.json
    c ingolstadt/lod-merge-stdout lod "${tiles[@]}" "${street[@]}" -o - --rays 3000
    c ingolstadt/lod-bound lod "${tiles[@]}" "${street[@]}" -o lod/ --max-svf-error 0.01 \
      --report r.json
    c ingolstadt/lod-obj-dir lod "${tiles[@]}" "${street[@]}" -o lod/ --format obj
    c ingolstadt/lod-scene-radius lod "$ing/" --poi 678090,5403790,415 --scene-radius 60 \
      -o lod/ --report r.json
    c ingolstadt/evaluate-json evaluate "${tiles[@]}" "${street[@]}" --json --step 60
    c ingolstadt/svf-json svf "$ing/" "${facades[@]}" --json
    c ingolstadt/sun-hours-json sun-hours "${tiles[@]}" "${street[@]}" --json --step 60
    c ingolstadt/fisheye fisheye "$ing/" --poi 678095,5403890,418,0,-1,0 -o sky.svg
    for i in 0 1; do
      c "ingolstadt/stats-shard-$i" stats --json --shard "$i/2" "$ing/"
      c "ingolstadt/convert-shard-$i" convert "$ing/" -o out/ --shard "$i/2"
      c "ingolstadt/lod-shard-$i" lod "${tiles[@]}" "${street[@]}" --rays 3000 --shard "$i/2" \
        -o "levels-$i.jsonl"
    done
    c ingolstadt/lod-reduce lod "${tiles[@]}" -o reduced/ --report r.json --reduce \
      "$(prev ingolstadt/lod-shard-0)/levels-0.jsonl" "$(prev ingolstadt/lod-shard-1)/levels-1.jsonl"
    ci ingolstadt/convert-stdin-stdout <(gzip -dc "$ing/4018106.xml.gz") convert - -o -
    ci ingolstadt/stats-stdin-gz "$ing/4018115.xml.gz" stats --json -
    c ingolstadt/svf-degrees svf "$ing/4018215.xml.gz" --poi 48.7665,11.4258,400

    local kit=$data/kit-fzk-haus
    c fzk/convert-merge-v2 convert "$kit/citygml2/" -o merged.gml
    c fzk/convert-merge-v3 convert "$kit/citygml3/" -o merged.gml.gz
    c fzk/convert-merge-versions convert "$kit/citygml2/fzk_haus_lod2_v2.gml" \
      "$kit/citygml3/FZK-Haus-LoD2-KIT-IAI-KHH-B36-V1__v3.gml" -o merged.gml
    c fzk/lod-lod3 lod "$kit/citygml2/fzk_haus_lod3_v2.gml" --poi 457848,5439080,113.3 \
      -o lod.gml --report r.json

    local tokyo=$data/plateau/tokyo23ku-2022/53392633_bldg_6697_2_op.gml.gz ll=()
    ll=(--poi 35.53303834,139.79429521,4.7 --poi 35.53312871,139.79501195,4.7
      --poi 35.53281320,139.79495696,4.7 --poi 35.53321917,139.79605951,4.7)
    c plateau/svf-json svf "$tokyo" "${ll[@]}" --json
    c plateau/svf-poi-crs svf "$tokyo" "${ll[@]}" --poi-crs EPSG:4326 --json
    c plateau/svf-poi-crs-urn svf "$tokyo" "${ll[@]}" --poi-crs urn:ogc:def:crs:EPSG::4326
    c plateau/lod lod "$tokyo" "${ll[@]}" --poi-crs EPSG:4326 -o lod.gml --report r.json
    c plateau/lod-cityjson lod "$tokyo" "${ll[@]}" -o lod.city.json
    c plateau/sun-hours sun-hours "$tokyo" "${ll[@]}" --json --step 60
    c plateau/horizon horizon "$tokyo" "${ll[@]}" --step 10
    c plateau/mixed-crs svf "$tokyo" "${tiles[0]}" --poi 35.53303834,139.79429521,4.7
    c plateau/convert-merge convert "$data/plateau/yokosuka/52397519_bldg_6697_op.gml" \
      "$data/plateau/sapporo/64413325_bldg_6697_op.gml" -o merged.gml
    c trust/lod0-no-heights svf "$kit/citygml2/fzk_haus_lod0_v2.gml" --poi 457848,5439080,113.3
  else
    echo "note: no $data/ingolstadt-lod3 or plateau: the real-data cases are left out" >&2
  fi

  # --- errors --------------------------------------------------------------------------------------
  c err/missing-stats stats /nonexistent/no-such-file.gml
  c err/missing-convert convert /nonexistent/no-such-file.gml -o x.gml
  c err/missing-lod lod /nonexistent/no-such-file.gml --poi 0,0,0 -o x.gml
  c err/missing-and-good convert /nonexistent/no-such-file.gml "$fix/chimney-citygml2.gml" -o out/
  c err/missing-pois svf "$fix/synth-small.gml" --pois /nonexistent/pois.csv
  for f in "$fix"/bad/*; do
    case $f in *.py) continue ;; esac
    n=$(basename "$f")
    c "bad/stats/$n" stats "$f"
    c "bad/convert/$n" convert "$f" -o x.gml
  done
  c err/bad-among-good convert "$fix/bad/" -o out/
  c err/bad-lod lod "$fix/bad/coord-nan.gml" "$fix/bad/ok.gml" --poi 0,0,0 -o x.gml
  c err/poi-far svf "$fix/synth-small.gml" --poi 0,0,0
  c err/poi-swapped svf "$fix/synth-small.gml" --poi 4581000,430000,10
  c err/output-over-input convert "$s" -o "$s"
  c err/output-exists lod "$s" --pois "$p" -o "$(prev small/lod-j1)/lod.gml"
  c err/unknown-format convert "$fix/chimney-citygml2.gml" -o x.txt
  c err/unknown-option stats --no-such-option "$fix/chimney-citygml2.gml"
  c err/no-command
  c err/bad-poi svf "$fix/synth-small.gml" --poi 1,2
  c err/bad-shard stats --shard 2/2 "$fix/chimney-citygml2.gml"
  c err/reduce-missing-shard lod "$s" -o x.gml --reduce "$(prev small/lod-shard-0)/levels-0.jsonl"
  c err/synth-output-exists synth --preset small -o "$(prev synth-small)/small.gml"
  c err/reproject-no-proj reproject "$fix/chimney-citygml2.gml" -t EPSG:4326 -o x.gml
  c err/bad-region svf "$fix/synth-small.gml" --region "POLYGON((0 0, 1 0))" --height 1
}

echo "old: $old"
echo "new: $new"
echo "work: $work"
t0=$(date +%s)
(bin=$old root=$work/old cases) &
pid_old=$!
(bin=$new root=$work/new cases) &
pid_new=$!
wait "$pid_old"
wait "$pid_new"
echo "ran $(wc -l < "$work/cases") case(s) per binary in $(($(date +%s) - t0)) s"

# ---------------------------------------------------------------------------------------------
# Comparing

cat > "$work/mask.pl" <<'PERL'
# the masks of the header, on a whole file; WORK is the work directory
sub numbers { my $s = shift; $s =~ s/(:\s*)-?[0-9][0-9.eE+-]*/${1}T/g; return $s; }
s!\Q$ENV{WORK}\E/(?:old|new)!WORK!g;
s!(/skylod-[a-z]+-)[A-Za-z0-9]{6}\b!${1}XXXXXX!g;
s!("timings_ms"\s*:\s*\{)([^{}]*)!$1 . numbers($2)!ge;
s!("(?:[A-Za-z0-9]+_)*ms"\s*:\s*|"seconds"\s*:\s*)-?[0-9][0-9.eE+-]*!${1}T!g;
s!^(\S+ +(?:full|lod|boxes) +[0-9].*?)(?: +\S+){3}$!$1 T T T!mg;
s!\b[0-9]+(?:\.[0-9]+)?( ?)(ms|s)\b!T$1$2!g;
PERL
mask() { # mask FILE: the file with timings and the work directory masked (see the header)
  WORK=$work perl -0777 -p "$work/mask.pl" "$1"
}
# masked CASE_DIR PART: the part masked; the lines sorted for the standard error of a `cu` case
masked() {
  if [ "$2" = stderr ] && [ -e "$1/unordered" ]; then
    mask "$1/$2" | LC_ALL=C sort
  else
    mask "$1/$2"
  fi
}
# same_masked PART: the part of both runs of the case equal once masked (a failing mask is a
# difference)
same_masked() {
  masked "$a" "$1" > "$work/mask.a" && masked "$b" "$1" > "$work/mask.b" \
    && cmp -s "$work/mask.a" "$work/mask.b"
}
maskable() { # stdout, stderr and JSON (and JSON lines) that is not CityJSON
  case $1 in
    stdout | stderr) return 0 ;;
    *.city.json | *.city.jsonl) return 1 ;;
    *.json | *.jsonl) return 0 ;;
  esac
  return 1
}

same=0 differ=0
while IFS= read -r name; do
  a=$work/old/$name b=$work/new/$name
  parts=() masked=() bad=()
  if ! cmp -s <(cd "$a/files" && find . -mindepth 1 | LC_ALL=C sort) \
      <(cd "$b/files" && find . -mindepth 1 | LC_ALL=C sort); then
    bad+=(files)
    diff <(cd "$a/files" && find . -mindepth 1 | LC_ALL=C sort) \
      <(cd "$b/files" && find . -mindepth 1 | LC_ALL=C sort) \
      > "$work/diffs/${name//\//__}.diff" || true
  fi
  mapfile -t parts < <(echo rc; echo stdout; echo stderr;
    cd "$a/files" && find . -type f | LC_ALL=C sort | sed 's|^\./|files/|')
  for part in "${parts[@]}"; do
    [ -f "$b/$part" ] || continue
    cmp -s "$a/$part" "$b/$part" && continue
    if maskable "$(basename "$part")" && same_masked "$part"; then
      masked+=("$part")
    else
      bad+=("$part")
      {
        echo "--- $part"
        case $part in
          *.gz) diff -u <(gzip -dc "$a/$part" 2>&1) <(gzip -dc "$b/$part" 2>&1) || true ;;
          *) diff -u <(masked "$a" "$part") <(masked "$b" "$part") || true ;;
        esac
      } >> "$work/diffs/${name//\//__}.diff"
    fi
  done
  if [ ${#bad[@]} -eq 0 ]; then
    same=$((same + 1))
    if [ ${#masked[@]} -eq 0 ]; then
      printf 'same  %s\n' "$name"
    else
      printf 'same  %s (masked: %s)\n' "$name" "${masked[*]}"
    fi
  else
    differ=$((differ + 1))
    printf 'DIFF  %s: %s (rc %s / %s)\n' "$name" "${bad[*]}" "$(cat "$a/rc")" "$(cat "$b/rc")"
    head -20 "$work/diffs/${name//\//__}.diff" | sed 's/^/      /'
  fi
done < "$work/cases"

echo "$same same, $differ differ"
[ "$differ" -eq 0 ]
