#!/usr/bin/env bash
# Host-in-the-loop over real vcan: builds static test executables and the `trn` and
# `controller-node` binaries, boots a small Linux VM (QEMU TCG, Debian's kernel with the CAN
# modules, a busybox initramfs), runs scripts/vcan/tests.sh inside over vcan0, copies the
# results out and checks them on the host (scripts/vcan/compare.py). On a Linux whose kernel
# has vcan, the same tests run directly. Installs what it needs. Exit status: 0 = all passed.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../.." && pwd)"
cache="$root/.vm"
out="${TRN_VCAN_OUT:-$root/out/vcan}"
timeout_s="${TRN_VM_TIMEOUT:-900}"
start=$SECONDS
mkdir -p "$cache" "$out"
rm -f "$out"/*.json "$out"/*.log

need_apt=()
command -v qemu-system-x86_64 >/dev/null || need_apt+=(qemu-system-x86)
[ -x /bin/busybox ] || need_apt+=(busybox-static)
if [ ${#need_apt[@]} -gt 0 ]; then
    echo "vcan: installing ${need_apt[*]}"
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${need_apt[@]}" >/dev/null
fi

# cantools for the DBC check (the same venv as protocol/tools/check_dbc.sh)
venv="${TRN_VENV:-$root/target/trn-venv}"
if ! "$venv/bin/python" -c 'import cantools' 2>/dev/null; then
    python3 -m venv "$venv"
    "$venv/bin/pip" install --quiet --disable-pip-version-check 'cantools>=39,<46'
fi

echo "vcan: building static executables"
export CARGO_TARGET_DIR="$root/target/static"
export RUSTFLAGS='-C target-feature=+crt-static'
triple=x86_64-unknown-linux-gnu
cargo build --quiet --release --target $triple -p trn-sim -p trn-transport --no-default-features --bin trn --bin controller-node
bin="$CARGO_TARGET_DIR/$triple/release"
vcan_test=$(cargo test --quiet --release --target $triple -p trn-protocol --features socketcan --test vcan \
    --no-run --message-format=json 2>/dev/null \
    | python3 -c 'import json,sys
for l in sys.stdin:
    m = json.loads(l)
    if m.get("reason") == "compiler-artifact" and m.get("executable") and m["target"]["name"] == "vcan":
        print(m["executable"])' | tail -1)
[ -x "$vcan_test" ] || { echo "vcan: FAIL: could not build the protocol vcan test executable" >&2; exit 1; }
unset RUSTFLAGS CARGO_TARGET_DIR

native_vcan() {
    ip link show vcan0 >/dev/null 2>&1 && return 0
    { modprobe vcan 2>/dev/null || true; } && ip link add dev vcan0 type vcan 2>/dev/null \
        && ip link set vcan0 mtu 72 && ip link set up vcan0
}

if native_vcan; then
    echo "vcan: this kernel has vcan: running the tests directly"
    stage="$(mktemp -d)"
    cp "$bin/trn" "$bin/controller-node" "$stage/"
    cp "$vcan_test" "$stage/protocol_vcan"
    fail=""
    run() {
        name=$1
        shift
        echo "VM-BEGIN $name"
        if "$@"; then echo "VM-END $name rc=0"; else echo "VM-END $name rc=$?"; fail="$fail $name"; fi
    }
    BIN="$stage" OUT="$out"
    # shellcheck source=scripts/vcan/tests.sh
    BIN="$stage"; OUT="$out"; . "$here/tests.sh"
    [ -z "$fail" ] || { echo "vcan: FAIL:$fail"; exit 1; }
else
    echo "vcan: no vcan in this kernel: booting the test VM"
    deb_pkg=$(apt-cache depends linux-image-amd64 2>/dev/null | awk '/Depends: linux-image-[0-9]/{print $2; exit}')
    if [ -z "$deb_pkg" ]; then
        apt-get update -qq
        deb_pkg=$(apt-cache depends linux-image-amd64 | awk '/Depends: linux-image-[0-9]/{print $2; exit}')
    fi
    kdir="$cache/kernel-$deb_pkg"
    if [ ! -d "$kdir/boot" ]; then
        echo "vcan: downloading $deb_pkg"
        (cd "$cache" && rm -f linux-image-*.deb && apt-get download "$deb_pkg" 2>/dev/null)
        rm -rf "$kdir" && mkdir -p "$kdir" && dpkg -x "$cache"/linux-image-*.deb "$kdir"
    fi
    vmlinuz=$(ls "$kdir"/boot/vmlinuz-*)
    mods=$(ls -d "$kdir"/lib/modules/*/kernel)
    rootfs="$cache/rootfs"
    rm -rf "$rootfs" && mkdir -p "$rootfs"/{bin,modules,proc,sys,dev,tmp}
    cp /bin/busybox "$rootfs/bin/busybox"
    ln -s busybox "$rootfs/bin/sh"
    for m in net/can/can.ko net/can/can-raw.ko drivers/net/can/dev/can-dev.ko drivers/net/can/vcan.ko; do
        f="$mods/$m"
        [ -f "$f" ] || { [ -f "$f.xz" ] && xz -dc "$f.xz" > "$rootfs/modules/$(basename "$m")"; continue; }
        cp "$f" "$rootfs/modules/"
    done
    cp "$bin/trn" "$bin/controller-node" "$rootfs/bin/"
    cp "$vcan_test" "$rootfs/bin/protocol_vcan"
    cp "$here/init.sh" "$rootfs/init" && chmod +x "$rootfs/init"
    cp "$here/tests.sh" "$rootfs/tests.sh"
    python3 "$here/mkcpio.py" "$rootfs" "$cache/initrd.cpio.gz"
    console="$out/console.log"
    echo "vcan: booting (timeout ${timeout_s}s), console in $console"
    set +e
    timeout "$timeout_s" qemu-system-x86_64 -accel tcg -m 1536 -smp 2 -nographic -no-reboot \
        -kernel "$vmlinuz" -initrd "$cache/initrd.cpio.gz" \
        -append "console=ttyS0 quiet panic=-1 loglevel=3" > "$console" 2>&1
    qrc=$?
    set -e
    grep -E '^(VM-BEGIN|VM-END|VM-RESULT|VM: |test |running|test result)' "$console" | tr -d '\r' || true
    [ $qrc -eq 124 ] && { echo "vcan: FAIL: the VM did not finish within ${timeout_s}s" >&2; exit 1; }
    python3 - "$console" "$out" <<'PY'
import base64, sys
lines = open(sys.argv[1], errors="replace").read().replace("\r", "").split("\n")
name = None
for line in lines:
    if line.startswith("VM-FILE-END"):
        open(f"{sys.argv[2]}/{name}", "wb").write(base64.b64decode("".join(buf)))
        name = None
    elif line.startswith("VM-FILE "):
        name, buf = line.split(" ", 1)[1].strip(), []
    elif name is not None:
        buf.append(line.strip())
PY
    grep -q '^VM-RESULT: PASS' <(tr -d '\r' < "$console") || { echo "vcan: FAIL: $(tr -d '\r' < "$console" | grep '^VM-RESULT' || echo 'no result line from the VM')" >&2; exit 1; }
fi
"$venv/bin/python" "$here/compare.py" "$out" "$root/protocol/trn.dbc"
echo "vcan: all passed in $((SECONDS - start)) s"
