#!/bin/sh
# /init of the test VM: load the CAN modules, create vcan0 (CAN FD MTU), run the tests,
# print their output and result files on the console, power off.
/bin/busybox --install -s /bin
mount -t proc proc /proc
mount -t sysfs sys /sys
mount -t devtmpfs dev /dev
mount -t tmpfs tmp /tmp
for m in can can-raw can-dev vcan; do
    insmod /modules/$m.ko || echo "VM: insmod $m failed"
done
ip link add dev vcan0 type vcan && ip link set vcan0 mtu 72 && ip link set up vcan0 \
    || echo "VM: cannot create vcan0"
fail=""
run() {
    name=$1
    shift
    echo "VM-BEGIN $name"
    "$@"
    rc=$?
    echo "VM-END $name rc=$rc"
    [ $rc -eq 0 ] || fail="$fail $name"
}
cd /tmp
BIN=/bin
OUT=/tmp
. /tests.sh
for f in /tmp/*.json /tmp/*.log; do
    [ -f "$f" ] || continue
    echo "VM-FILE $(basename "$f")"
    base64 "$f"
    echo "VM-FILE-END"
done
if [ -z "$fail" ]; then echo "VM-RESULT: PASS"; else echo "VM-RESULT: FAIL$fail"; fi
poweroff -f
