//! Batch work: which files a run reads and where it writes them, which part of the work a
//! shard does, the levels files shards write and their reduce, and which neighbouring tiles
//! a scene needs.
//!
//! * `inputs`: arguments (files, directories, globs, `-`) → the input files, with the
//!   relative path each mirrors under `-o DIR`.
//! * `convert`: one input of `stats` and `convert`, streamed where it is large.
//! * `edit`: `subset`, `filter-lods`, `upgrade` of one input, CityGML or CityJSON.
//! * [`convert_all`]: every input of a `convert` batch, with progress.
//! * `outputs`: an output name → one output per input, a mirrored tree, or a merge.
//! * `rough`: one input of `rough`, generalised and written.
//! * `run`: a batch that writes per input: its outputs planned, its inputs' results
//!   gathered and merged, what to tell the user returned (never printed).
//! * `shard`: `--shard I/N` or a scheduler's array index → this run's files or POIs.
//! * `shard_levels`: the levels files `lod` shards write and `--reduce` combines.
//! * `reduce`: the levels files of every shard → the levels one serial run selects.
//! * `scene_radius`: file envelopes → the inputs within `--scene-radius` of the POIs.
//! * `stats`: `stats` of several inputs, their total and what to say.
//! * `synth`: the files of `synth`, the model and its POIs.

pub(crate) mod convert;
pub(crate) mod convert_all;
pub(crate) mod edit;
pub(crate) mod inputs;
pub(crate) mod outputs;
pub(crate) mod reduce;
pub(crate) mod rough;
pub(crate) mod run;
pub(crate) mod scene_radius;
pub(crate) mod shard;
pub(crate) mod shard_levels;
pub(crate) mod stats;
pub(crate) mod synth;
pub use convert::{chunk_for, convert_file, file_stats, ConvertError, ConvertOptions};
pub use convert_all::convert_all;
pub use edit::Transform;
pub use inputs::{expand, expand_spooled, is_citygml_name, is_cityjson_name, Input, Spool};
pub use outputs::{create_parent, per_poi, plan, Plan, PlanError, Staging, Targets};
pub use reduce::{lod_result, Reduce};
pub use rough::{rough_file, RoughFile};
pub use run::{merge_parts, Batch, Done, Said};
pub use scene_radius::{keep_within, Extent};
pub use shard::{Setting, Shard, ShardError, ENV_VARS};
pub use shard_levels::{check_levels_target, write_shard, LevelsError, LevelsTargetError};
pub use stats::{stats_files, StatsFiles};
pub use synth::{write_synth, SynthFilesError};
