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
