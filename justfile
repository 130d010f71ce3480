# saddleflow tasks. `./bootstrap` installs just and the HDF5 library first.

bin := env_var_or_default("CARGO_TARGET_DIR", "target") / "release/saddleflow"
# Stages run in parallel on every core by default; each stage gets a thread pool of its own,
# the free cores shared among the stages that start together (two stages on two cores: one
# thread each, no thread hand-offs on small grids; a stage that starts alone: every core).
jobs := env_var_or_default("SADDLEFLOW_JOBS", num_cpus())
# The scenes that report headline numbers (see `saddleflow tradeoff`).
headline_scenes := "--only critical_table --only fig3 --only fig6 --only near_critical"
# The reference preset's share: every headline number but Figure 3's γ thresholds (one level
# finer would take about two hours per model; paper is their finest).
reference_scenes := "--only critical_table --only near_critical --only fig6_square_hardwall_flow"

# List the recipes.
default:
    @just --list

# Build the command-line tool (release: numerics are ~200x slower in debug builds).
build:
    cargo build --release -p saddleflow

# After the run's own summary (stages run/cached, summed stage time, the most expensive), `draft`
# and `paper` print the preset's five costliest stages, its critical path and per-scene costs
# (`saddleflow status --params ...` shows every stage's cache state).

# Main job: every scene at draft fidelity (minutes on 2 cores).
draft *ARGS: build
    {{bin}} run --params params/draft.toml -j {{jobs}} {{ARGS}}
    {{bin}} status --params params/draft.toml --costs --top 5

# Every scene at the paper's fidelity.
paper *ARGS: build
    {{bin}} run --params params/paper.toml -j {{jobs}} {{ARGS}}
    {{bin}} status --params params/paper.toml --costs --top 5

# params/deep.toml: the paper preset with the deep ladders at k = 4, 5 (square, triangular) and
# 5, 6 (hexagonal) down to |l| = 1e-5; tables and figures as `just paper` writes them.
# The near-critical scenes with the deep ladders one level deeper (1 h on two cores, 7 GB).
deep *ARGS: build
    {{bin}} run --params params/deep.toml -j {{jobs}} --only near_critical {{ARGS}}
    {{bin}} status --params params/deep.toml --costs --top 5

# params/deeper.toml (docs/near-critical.md §5p): the square stage 1.5 h on one core, 4 GB per D(6);
# the triangular stage (tol_gap 1e-10 since session #19: at 1e-11 its D(6) solves ran into their
# rounding floor, §5q) 1 h 28 min on two threads, 4.5 GB (session #20, §5r).
# The near-critical scenes with the square and triangular deep ladders at k = 5, 6 down to |l| = 2e-6.
deeper *ARGS: build
    {{bin}} run --params params/deeper.toml -j {{jobs}} --only near_critical {{ARGS}}
    {{bin}} status --params params/deeper.toml --costs --top 5

# The random-surface ensembles at 32 seeds per spectrum (params/ensemble.toml): about 1–3 h on two
# cores, minutes on a cluster (ARGS e.g. `--executor slurm -j 64 --slurm-partition compute`).
ensembles *ARGS: build
    {{bin}} run --params params/ensemble.toml -j {{jobs}} --only random_constrictions --only surface_ensemble {{ARGS}}

# Tiny grids: checks that every stage runs, not that numbers match the paper.
smoke *ARGS: build
    {{bin}} run --params params/smoke.toml {{ARGS}}

# Error against cost of every headline number across the presets (runs them first: smoke and
# draft in full, paper for the scenes with headline numbers, the finer reference for those but
# Figure 3; about 1.5 h on two cores), README table.
tradeoff: build
    {{bin}} run --params params/smoke.toml -j 2
    {{bin}} run --params params/draft.toml -j 2
    {{bin}} run --params params/paper.toml -j 2 {{headline_scenes}}
    {{bin}} run --params params/reference.toml -j 2 {{reference_scenes}}
    {{bin}} tradeoff --readme README.md

# The test suite (release mode; includes the smoke pipeline and checks its outputs).
test *ARGS:
    cargo test --release --workspace {{ARGS}}

# One contact solve written to HDF5, summary printed as JSON.
demo: build
    mkdir -p results/demo
    {{bin}} solve --lattice square --n 9 --pressure 0.3 --relative --out results/demo/square-n9.h5

# Benchmarks (timings, iterations, peak memory) of the contact and flow solvers.
bench:
    cargo bench -p contact --bench hardwall
    cargo bench -p contact --bench adhesive
    REFINE_METHOD=blockwise REFINE_MARGIN=12 REFINE_BASE=10 REFINE_LEVELS=${REFINE_LEVELS:-3} REFINE_WINDOWS=32 REFINE_SKIP_REFERENCE=1 REFINE_MAX_ITER=${REFINE_MAX_ITER:-20} cargo bench -p contact --bench refinement
    cargo bench -p reynolds --bench flow

# Side-by-side benchmarks against tamaas, ContactMechanics and PyAMG in a Python venv.
bench-peers: build
    bench/peers/setup-venv.sh
    bench/peers/contact.sh
    bench/peers/adhesive.sh
    bench/peers/flow.sh
    bench/peers/random.sh

# Formatting and lints as CI would want them.
lint:
    cargo fmt --all -- --check
    cargo clippy --release --workspace --all-targets -- -D warnings

# Remove cached results, figures and tables (not the code's build).
clean:
    rm -rf results/cache results/runs results/demo
    find figures -maxdepth 1 -type f \( -name '*.png' -o -name '*.svg' \) -delete
    find results/tables -maxdepth 1 -type f -name '*.csv' -delete

# Start a single-node SLURM cluster on this machine (Debian's munge, slurmctld, slurmd; root).
slurm-up:
    scripts/slurm-up

# Cancel every job and stop the single-node cluster.
slurm-down:
    scripts/slurm-down
