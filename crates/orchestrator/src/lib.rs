//! orchestrator: the generic pipeline engine of saddleflow. No physics lives here.
//!
//! - A **stage** is (kind, parameters, named inputs = other stages). Kinds implement
//!   [`StageKind`] and are collected in a [`Registry`] by the caller (`stages::registry()`).
//! - **Declarative files** ([`config`]): `pipeline/*.toml` declares settings, scenes and stages;
//!   `params/*.toml` sets the settings (fidelity). Errors name file, line, key and what is
//!   allowed.
//! - A [`Plan`] validates everything (kinds, parameters, inputs, cycles) and computes each
//!   stage's **key**: BLAKE3 over the kind, its code version, its code identity (hashes of the
//!   sources it depends on, set on the [`Registry`] by the caller), the canonical parameters with
//!   every default filled in, and the input keys ([`plan::stage_key`]). Constraints across
//!   stages ([`StageKind::check_inputs`]) are checked here too, before anything runs.
//! - The **cache** ([`Workspace`]) holds `results/cache/<kind>/<key>.h5`; every read verifies
//!   the complete mark, the stored key and the content digest, and a truncated, unreadable,
//!   unfinished, damaged or foreign entry counts as missing (recomputed, with a warning naming
//!   the file). `results/manifest.json` records which stage, key and params file wrote each
//!   published output. `results/cache/index.json` remembers the last key of
//!   each stage to explain *why* a stage runs ([`Reason`]).
//! - The **runner** ([`run`]) runs stages in topological order, independent ones in parallel,
//!   publishes atomically, keeps independent results when a stage fails, logs events
//!   (`results/runs/*.jsonl`) and holds a lock on `results/` ([`lock`]).
//! - **Executors**: stages run in this process ([`Executor::Local`]) or as SLURM batch jobs
//!   ([`slurm`]), the controller keeping the DAG and counting a stage done when its artefact is
//!   published.
//! - [`run_stage`], [`ops::status`], [`ops::gc`], [`ops::graph`] back the CLI commands.

pub mod config;
pub mod events;
pub mod kind;
pub mod lock;
pub mod memory;
pub mod ops;
pub mod plan;
pub mod progress;
pub mod runner;
pub mod schema;
pub mod slurm;
pub mod util;
pub mod workspace;

pub use config::{ConfigError, ConfigErrors, Origin, ParamsFile, PipelineFile};
pub use events::{Event, EventLog, What};
pub use kind::{
    CodeIdentity, InputSpec, Inputs, Params, ProgressSink, Registry, StageContext, StageKind,
    StageReport, Typed, TypedKind, UPSTREAM, parse_params, upstream_max,
};
pub use plan::{Plan, PlannedStage};
pub use progress::ProgressMode;
pub use runner::{
    Action, Decision, Executor, RunOptions, RunSummary, decide, restore_side_outputs, run,
    run_stage,
};
pub use schema::{ParamIssue, ParamSpec, ParamType};
pub use workspace::{EntryState, Index, Manifest, Reason, Workspace};
