# Sourced by the cross scripts: Debian's toolchain for the no_std targets (DEVELOPERS.md).
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
export RUSTC=/usr/bin/rustc RUSTC_BOOTSTRAP=1
CARGO=/usr/bin/cargo
QEMU_ARM="$root/.vm/qemu-arm/root/usr/bin/qemu-system-arm"
# The images hold source paths (panic locations): remapped to fixed prefixes, so an image's
# flash size and bytes do not depend on where the repository or cargo's registry sits (a
# clone at a longer path once pushed the CAN node image over its budget).
#   remap_paths TARGET    prints a `--config` value that cargo merges into the target's rustflags
remap_paths() {
    local home=${CARGO_HOME:-$HOME/.cargo}
    echo "target.$1.rustflags=[\"--remap-path-prefix=$src=/trn\", \"--remap-path-prefix=$home=/cargo\"]"
}
# Cargo hashes a path dependency outside the building workspace (the controller, the node,
# the store: outside firmware/ and firmware/boards/) by its absolute path, and the hash names
# symbols: two clones at different paths built images a few bytes apart (the G474's 8 B).
# So every image builds through one fixed path, a symbolic link to this checkout
# ($TRN_CROSS_SRC, default /tmp/trn-cross-src), held under a lock for the build (builds
# from other checkouts wait): the same sources give the same bytes wherever they sit.
#   with_fixed_src COMMAND...    runs COMMAND with $src the fixed path to this checkout
src=$root
with_fixed_src() {
    local link=${TRN_CROSS_SRC:-/tmp/trn-cross-src}
    if [ -e "$link" ] && [ ! -L "$link" ]; then
        echo "cross: $link exists and is not a symbolic link: set TRN_CROSS_SRC to a free path" >&2
        return 1
    fi
    (
        flock -x 9 || exit 1
        ln -sfn "$root" "$link"
        src=$link
        "$@"
    ) 9>"$link.lock"
}
# Every firmware variant builds in the one target directory `firmware/target` (shared core,
# nalgebra and build scripts: one directory per variant cost 0.5 GB of disk each); cargo
# keeps each feature set's artifacts apart but writes the linked binary to one path, so each
# variant's ELF is copied to `firmware/target/elf/trn-firmware-VARIANT` right after its build.
#   build_firmware VARIANT TARGET [FEATURES [--no-default-features]]    prints the ELF's path
# (the compact variants build without the default features: no Broyden servo, firmware/Cargo.toml)
build_firmware() {
    local variant=$1 target=$2 features=${3:-} defaults=${4:-}
    # shellcheck disable=SC2086 # $defaults is one flag or none
    with_fixed_src cargo_at firmware firmware/target "$target" build --quiet --release --target "$target" \
        ${features:+--features "$features"} $defaults >&2 || return 1
    mkdir -p "$root/firmware/target/elf"
    cp "$root/firmware/target/$target/release/trn-firmware" "$root/firmware/target/elf/trn-firmware-$variant"
    echo "$root/firmware/target/elf/trn-firmware-$variant"
}
# The board images (firmware/boards, their own workspace): each built from its directory, so
# that its .cargo/config.toml (probe-rs runner, defmt buffer) applies, all in the one target
# directory firmware/boards/target; each program's ELF is copied to
# firmware/boards/target/elf/BOARD-PROGRAM (every board names its node program alike).
#   build_board BOARD [PROGRAM]    prints the ELF's path
build_board() {
    local board=$1 program=${2:-trn-controller}
    with_fixed_src cargo_at "firmware/boards/$board" firmware/boards/target thumbv7em-none-eabihf \
        build --quiet --release --bin "$program" >&2 || return 1
    mkdir -p "$root/firmware/boards/target/elf"
    cp "$root/firmware/boards/target/thumbv7em-none-eabihf/release/$program" "$root/firmware/boards/target/elf/$board-$program"
    echo "$root/firmware/boards/target/elf/$board-$program"
}
# The build itself, run by with_fixed_src: the manifest in $src/DIR (from its directory, so
# that its .cargo/config.toml applies), into $src/TARGET-DIR (the checkout's target
# directory named through $src, so build scripts' output paths are remapped too), with
# TRIPLE's source paths remapped.
#   cargo_at DIR TARGET-DIR TRIPLE CARGO-ARGS...
cargo_at() {
    local dir=$1 target_dir=$2 triple=$3
    shift 3
    (cd "$src/$dir" && CARGO_TARGET_DIR="$src/$target_dir" $CARGO "$@" \
        --manifest-path "$src/$dir/Cargo.toml" --config "$(remap_paths "$triple")")
}
