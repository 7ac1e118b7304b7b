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
    echo "target.$1.rustflags=[\"--remap-path-prefix=$root=/trn\", \"--remap-path-prefix=$home=/cargo\"]"
}
# Every firmware variant builds in the one target directory `firmware/target` (shared core,
# nalgebra and build scripts: one directory per variant cost 0.5 GB of disk each); cargo
# keeps each feature set's artifacts apart but writes the linked binary to one path, so each
# variant's ELF is copied to `firmware/target/elf/trn-firmware-VARIANT` right after its build.
#   build_firmware VARIANT TARGET [FEATURES [--no-default-features]]    prints the ELF's path
# (the compact variants build without the default features: no Broyden servo, firmware/Cargo.toml)
build_firmware() {
    local variant=$1 target=$2 features=${3:-} defaults=${4:-}
    (cd "$root/firmware" && CARGO_TARGET_DIR="$root/firmware/target" $CARGO build --quiet --release --target "$target" \
        --config "$(remap_paths "$target")" ${features:+--features "$features"} $defaults) >&2 || return 1
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
    (cd "$root/firmware/boards/$board" && CARGO_TARGET_DIR="$root/firmware/boards/target" $CARGO build --quiet --release \
        --config "$(remap_paths thumbv7em-none-eabihf)" --bin "$program") >&2 || return 1
    mkdir -p "$root/firmware/boards/target/elf"
    cp "$root/firmware/boards/target/thumbv7em-none-eabihf/release/$program" "$root/firmware/boards/target/elf/$board-$program"
    echo "$root/firmware/boards/target/elf/$board-$program"
}
