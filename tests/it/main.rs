//! skylod's integration tests: one test binary (`cargo test --test it`), one module per
//! concern. Run one concern with a filter on its module, e.g. `cargo test --test it
//! bad_input::`; the tests that need the feature `proj` with `cargo test --features proj
//! --test it -- reproject:: proj_poi::`.
//!
//! Rule for external resources (`../shared/data`, xmllint, python3 and its oracles, cjval):
//! when missing, a test FAILS if the environment variable `CI` is `true`, and otherwise
//! prints why it skips (see `util`).

// Helpers shared by the modules: test data, the binary, xmllint, the Python oracles.
mod util;

// The shared argument groups are flattened into every command with one help text.
mod arg_groups;
// The reader and `convert`/`stats` against the bad-input corpus and hostile XML: exact errors.
mod bad_input;
// Faults: global options in every combination, errors in standard input named `<stdin>`.
mod faults;
// SIGTERM and SIGHUP: exit 143 / 129, nothing partial or temporary left behind.
mod signals;
// Batch inputs (directories, globs, `-` with gzip) on the shared Ingolstadt street.
mod batch;
// `lod --max-svf-error` keeps every POI within the bound, checked by independent ray casts.
mod bound;
// examples/etl.rs, the README's library program, run against the CLI.
mod etl;
// `subset` and `filter-lods` against an independent reader and the XSDs.
mod edit;
// CityJSON and CityJSONSeq output is valid for `cjval` and read by `cjio` with skylod's counts.
mod cityjson_edit;
mod cityjson_export;
// CityJSON and CityJSONSeq as inputs of every command (issue 24).
mod cityjson_input;
// A CityJSON document read in chunks of city-object trees by `stats` and `convert`.
mod cityjson_chunks;
mod cityjson_merge;
// CityJSON / CityJSONSeq → CityGML 2.0 and 3.0: valid, counted, round trip; upgrade --jobs.
mod cityjson_to_citygml;
// The command line: exit codes, error messages, `stats --json`, `convert` safety.
mod cli;
// `convert` on every shared file and fixture: same stats, valid, idempotent, gzip output.
mod convert;
// Geographic and foot CRSs, WGS 84 POIs and the EPSG tables agree with pyproj and numpy.
mod crs_frames;
mod national_crs;
// `evaluate`: exit codes, the JSON shape and figures on scenes with known answers.
mod evaluate;
// `horizon`: profiles against closed forms, and pvlib's masked sun hours against `sun-hours`.
mod horizon;
mod irradiance;
// `irradiance --surfaces`: a cadastre's surfaces, areas and rows against an independent reader.
mod cadastre;
// `evaluate --weather`, `lod --max-irradiance-error`, `irradiance --output-attributes` on the
// Ingolstadt street.
mod irradiance_lod;
// One definition of a level's output: report, `evaluate`, writer and reader count alike.
mod levels;
// The house rules: no import cycle between folders of src/, what each stage may import.
mod layout;
// The hollow read of `lod`: the whole read without its polygons, chunk by chunk.
mod hollow;
// Batch work linear in the number of input files, counted by strace, under `ulimit -n 256`.
mod many_tiles;
// `lod` end to end: valid outputs, resolved references, the report schema, determinism.
mod lod;
// `lod` on a hollow read: levels, bound and report the whole read's; which read it takes.
mod lod_hollow;
// Selection on the hand-made scenes: the known level of each named asset.
mod lod_scenes;
// Several inputs merged into one OBJ / CityJSON: the CityGML merge converted (issue 22).
mod merge_export;
// Mixed-LoD output (`rough`, `write_mixed`): valid, resolved, levels and counts consistent.
mod mixed_output;
// Progress bars under a terminal, plain log lines on a pipe, only errors with `--quiet`.
mod progress;
// `--poi-crs` and the sun's site through PROJ land where pyproj puts them (feature `proj`).
#[cfg(feature = "proj")]
mod proj_poi;
// Property tests: ray-box against ray-triangle, `convert` idempotent, translation invariance.
mod properties;
// Radiance computes the SVF of skylod's OBJ output equal to skylod's own.
mod radiance_obj;
// Reading real files and fixtures against the Python oracle; a split read equals the serial one.
mod read;
// Region POIs (`--facade`, `--region` with `--spacing`) on `svf` and `lod`.
mod region;
// `reproject` agrees with pyproj on every coordinate, keeps heights, round-trips (feature `proj`).
#[cfg(feature = "proj")]
mod reproject;
// The rewrite behind `reproject` in passes writes the whole rewrite's bytes; its CRS rules.
mod reproject_passes;
// Without the feature `proj`, `reproject` is a usage error naming the feature.
#[cfg(not(feature = "proj"))]
mod reproject_without_proj;
// Plane generalisation of the walls of a real LoD3 building.
mod rough;
// Issue 21: whole-building assets keep courtyards and inner corners open.
mod rough_forms;
// Shards (`--shard`, scheduler variables, GNU parallel) give together one serial run's bytes.
mod shard;
// Soak (ignored by default): `lod` over a generated 1 GB city with memory sampled.
mod soak;
// The solar commands on the command line, and SVF, sky exposure and sun hours against closed forms.
mod solar;
// Models from memory and standard input written as from their file; `<stdin>` and `-` names.
mod sources;
// Issue 22: the bytes of one large file move while it is read; the model stays the same.
mod stream;
// `sun_position` agrees with pvlib's SPA.
mod sun_pvlib;
// The synthetic district generator: schema-valid, deterministic, counts and envelope right.
mod synth;
// 3D Tiles 1.1 from real files: the tileset's rules, pyproj, glTF Validator, CesiumJS.
mod tiles;
// Inputs that would give a confidently wrong answer are refused or flagged.
mod trust;
// Issue 21 item 3: inside a building judged on the full geometry, far below, normal into
// the surface, latitude and longitude swapped.
mod truth;
mod upgrade;
