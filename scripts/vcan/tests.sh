# The tests run inside the VM (sourced by init.sh; `run NAME COMMAND...`).
# Add a test: put its static executable in the initramfs (run.sh) and a `run` line here.
TRAIN="--seed 3 --trials 40 --eval-targets 5 --grasps 3 --quiet"
run protocol-vcan $BIN/protocol_vcan --include-ignored --test-threads=1
run hil-inproc $BIN/trn train --bus inproc $TRAIN --report $OUT/inproc.json
run hil-vcan $BIN/trn train --bus socketcan:vcan0 $TRAIN --report $OUT/vcan.json --candump $OUT/vcan.log
run hil-inproc-fd $BIN/trn train --bus inproc --fd $TRAIN --report $OUT/inproc-fd.json
run hil-vcan-fd $BIN/trn train --bus socketcan:vcan0 --fd $TRAIN --report $OUT/vcan-fd.json
run conformance-vcan $BIN/trn conformance --bus socketcan:vcan0 --seed 100
run conformance-vcan-fd $BIN/trn conformance --bus socketcan:vcan0 --fd --seed 101 --preset paper
# The learned tables over vcan0 (protocol/SPEC.md 3.4, 3.5): a checkpoint written into a
# controller-node that keeps its tables in a file, read back bit-identical; the node
# restarted: the tables restored from its file, evaluated and read out again, identical; a
# training run that would erase them refused (nothing changes), allowed with --reset-tables.
# Sizes and times in $OUT/tables.json (compare.py).
tables_over_vcan() {
    ext="--bus socketcan:vcan0 --external-controller --quiet"
    only_read="--eval-targets 0 --grasps 0"
    $BIN/trn train --bus inproc --seed 5 --trials 10 --eval-targets 2 --grasps 0 --snapshot-every 0 --quiet \
        --checkpoint-out $OUT/t.ckpt > /dev/null || return 1
    rm -f /tmp/board.bin
    $BIN/controller-node --iface vcan0 --tables /tmp/board.bin & node=$!
    sleep 1
    t0=$(date +%s)
    $BIN/trn eval $ext $only_read --checkpoint-in $OUT/t.ckpt --checkpoint-out $OUT/t-back.ckpt > /dev/null || { kill $node; return 1; }
    t1=$(date +%s)
    cmp $OUT/t.ckpt $OUT/t-back.ckpt || { echo "VM: tables written in and read out differ"; kill $node; return 1; }
    kill $node; wait $node
    $BIN/controller-node --iface vcan0 --tables /tmp/board.bin & node=$!
    sleep 1
    t2=$(date +%s)
    $BIN/trn eval $ext --eval-targets 2 --grasps 0 --checkpoint-out $OUT/t-restart.ckpt > /dev/null || { kill $node; return 1; }
    t3=$(date +%s)
    cmp $OUT/t.ckpt $OUT/t-restart.ckpt || { echo "VM: the tables did not survive the restart"; kill $node; return 1; }
    if $BIN/trn train $ext --trials 2 --eval-targets 0 --grasps 0 --snapshot-every 0 2> /tmp/refused.txt; then
        echo "VM: a training run erased learned tables without --reset-tables"; kill $node; return 1
    fi
    grep -q -- "--reset-tables" /tmp/refused.txt || { cat /tmp/refused.txt; kill $node; return 1; }
    $BIN/trn eval $ext $only_read --checkpoint-out $OUT/t-kept.ckpt > /dev/null || { kill $node; return 1; }
    cmp $OUT/t.ckpt $OUT/t-kept.ckpt || { echo "VM: the refused run changed the tables"; kill $node; return 1; }
    $BIN/trn train $ext --reset-tables --seed 6 --trials 2 --eval-targets 0 --grasps 0 --snapshot-every 0 \
        2> /tmp/reset.txt > /dev/null || { cat /tmp/reset.txt; kill $node; return 1; }
    grep -q "erasing the controller's learned tables" /tmp/reset.txt || { cat /tmp/reset.txt; kill $node; return 1; }
    kill $node; wait $node
    printf '{"bytes": %s, "write_and_read_s": %s, "restored_eval_and_read_s": %s, "refusal": "%s"}\n' \
        "$(wc -c < $OUT/t.ckpt)" $((t1 - t0)) $((t3 - t2)) "$(head -c 200 /tmp/refused.txt | tr -d '"\n')" \
        > $OUT/tables.json
    rm -f $OUT/*.ckpt $OUT/*.ckpt.sim
}
run tables-vcan tables_over_vcan
