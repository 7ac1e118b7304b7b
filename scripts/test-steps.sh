# Steps of the test suite beyond fmt, clippy and cargo test; sourced by scripts/test.sh.
# Each is a script of the project that installs what it needs.

# The main job as a user runs it (README): train with defaults, print the paper's figures.
main_job() {
    cargo run --release --bin trn -- train --quiet --report "$LOG_DIR/train.json" --plot "$LOG_DIR/train.png"
}

step main-job main_job
# No crate's files import each other in a circle (each file a module; a parent and its own
# children excepted): the layering docs/ARCHITECTURE.md describes, kept.
step import-circles python3 scripts/import_circles.py --self-test .
# The headline figures (docs/results.md): 3 seeds, each within mean +- 4 sd of the recorded 10 seeds.
step results-bands bash scripts/results.sh --check
# The docs' generated sections hold the result files of docs/results/ (a second, no build).
step docs-sections python3 scripts/readme_sections.py --check
# Studies beyond one machine, against the unsharded study on a tiny comparison: the SLURM
# job array's shard arithmetic and its tasks merged (~15 s); cluster/ray_study.py's shards
# as Ray tasks on a local Ray (installs Ray 2.60.0 into out/ray-venv on first use: about
# 70 MB downloaded, 285 MB installed, 2 minutes; then about a minute).
step cluster-slurm bash scripts/cluster-test.sh slurm
step cluster-ray bash scripts/cluster-test.sh ray
step dbc-interop bash protocol/tools/check_dbc.sh
# A lossy serial SLCAN line (5 % of the frames dropped both ways by the host's fault layer,
# the line paced at 500 kbit/s): within 3x the clean run's wall time, the same scores (~1 min).
step lossy-slcan bash scripts/lossy_slcan.sh --check
# The Python package's abi3 wheel (maturin) installed in a fresh venv with no Rust toolchain
# on PATH: check_env and 200 random steps, the controllers from Python, the decoder on a
# training log (0 undecoded), a rerun recording of a training read back, pytest python/tests
# (scripts/python-package.sh prints its time/disk).
step python-package bash scripts/python-package.sh
step fuzz-60s bash protocol/fuzz/run.sh 60
prune_if_low protocol/fuzz/target
# Host-in-the-loop over real vcan: in a QEMU VM unless this kernel has vcan.
step vcan-hil bash scripts/vcan/run.sh
prune_if_low target/static
# Cortex-M: the no_std crates cross-build (thumbv7em, thumbv6m); the firmware's budgets.
step cross-build bash scripts/cross/check-controller.sh
prune_if_low target/cross
# ... and the board images (firmware/boards: built by budget.sh, one line each), linted with
# the cross toolchain's clippy.
step firmware-budget bash scripts/cross/budget.sh
step board-lint bash scripts/cross/lint-boards.sh
prune_if_low firmware/boards/target
# The compact build (i16 tables): its unit tests as the compact firmware builds it (no Broyden
# servo), and its error within 5 % of the f32 build's.
step compact-tables cargo test --release -p trn-controller --no-default-features --features compact
step compact-accuracy bash scripts/compact.sh --check
prune_if_low target/compact
# Processor-in-the-loop: the simulator trains the firmware in QEMU; curves match the host build.
step firmware-pil bash scripts/cross/pil.sh 30
