# Sourced by the scripts that measure experiments living on commits of their own
# (precision_experiments.sh, precision_fine_move.sh): `experiment_worktree REV` checks REV out
# into a temporary worktree, removed with the rest of $tmp when the script exits, builds its
# `trn` into target/experiments ($trn) and enters the worktree, so that the experiment's own
# studies/precision.toml is the one read. $root is the checkout the script was started in.
experiment_worktree() {
    root=$PWD
    tmp=$(mktemp -d)
    # shellcheck disable=SC2064 # $root and $tmp expanded now, as the trap's paths
    trap "git -C '$root' worktree remove --force '$tmp/src' >/dev/null 2>&1 || true; rm -rf '$tmp'" EXIT
    git worktree add --detach "$tmp/src" "$1" >/dev/null
    cd "$tmp/src"
    CARGO_TARGET_DIR="$root/target/experiments" cargo build --release --quiet -p trn-sim --bins
    trn="$root/target/experiments/release/trn"
}
