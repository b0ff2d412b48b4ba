//! Batch work: which files a run reads and where it writes them, which part of the work a
//! shard does, the levels files shards write and their reduce, and which neighbouring tiles
//! a scene needs.
//!
//! * [`inputs`]: arguments (files, directories, globs, `-`) → the input files, with the
//!   relative path each mirrors under `-o DIR`.
//! * [`convert`]: one input of `stats` and `convert`, streamed where it is large.
//! * [`edit`]: `subset`, `filter-lods`, `upgrade` of one input, CityGML or CityJSON.
//! * [`convert_all`]: every input of a `convert` batch, with progress.
//! * [`outputs`]: an output name → one output per input, a mirrored tree, or a merge.
//! * [`rough`]: one input of `rough`, generalised and written.
//! * [`run`]: a batch that writes per input: its outputs planned, its inputs' results
//!   gathered and merged, what to tell the user returned (never printed).
//! * [`shard`]: `--shard I/N` or a scheduler's array index → this run's files or POIs.
//! * [`shard_levels`]: the levels files `lod` shards write and `--reduce` combines.
//! * [`reduce`]: the levels files of every shard → the levels one serial run selects.
//! * [`scene_radius`]: file envelopes → the inputs within `--scene-radius` of the POIs.
//! * [`stats`]: `stats` of several inputs, their total and what to say.
//! * [`synth`]: the files of `synth`, the model and its POIs.

pub mod convert;
pub mod convert_all;
pub mod edit;
pub mod inputs;
pub mod outputs;
pub mod reduce;
pub mod rough;
pub mod run;
pub mod scene_radius;
pub mod shard;
pub mod shard_levels;
pub mod stats;
pub mod synth;
