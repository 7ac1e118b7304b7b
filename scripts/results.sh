#!/usr/bin/env bash
# Regenerates every measured table and picture of the user docs from the code, on seeds from
# 100 up (tuning uses seeds 1-99 only): the files of docs/results/ and the pictures, then the
# generated sections of README.md and docs/*.md (scripts/readme_sections.py) in place.
#   bash scripts/results.sh          the full set (about 35 minutes on 2 cores)
#   bash scripts/results.sh --resume the same, keeping the runs an interrupted call finished
#   bash scripts/results.sh --check  the test suite's shortened check: 3 seeds of the project
#                                    preset; fails when a headline figure leaves the band
#                                    (mean +- 4 sd over 10 seeds) in docs/results/bands.json
# Every study runs its runs on all cores (`--jobs`, default: the number of cores; the results
# do not depend on it) and writes each finished run to out/runs/STUDY/ at once.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet -p trn-sim --bins
trn=./target/release/trn
res=docs/results
runs=out/runs
mkdir -p "$res" out
resume=()
case "${1:-}" in
--check)
    "$trn" compare --seeds 3 --project-only --runs "$runs/band-check" \
        --report out/band-check.json > out/band-check.md
    exec python3 scripts/bands.py check "$res/bands.json" out/band-check.json
    ;;
--resume) resume=(--resume) ;;
"") ;;
*) echo "usage: $0 [--check | --resume]" >&2; exit 2 ;;
esac
# the main job's run and figure (seed 100)
"$trn" train --seed 100 --quiet --report "$res/train-seed100.json" --plot docs/train-seed100.png \
    > "$res/train-seed100.txt"
{ echo '```'; sed '/^wall time/d; /^$/d' "$res/train-seed100.txt"; echo '```'; } > "$res/train-seed100.md"
# presets and ablations, 10 seeds from 100
"$trn" compare --seeds 10 --runs "$runs/compare" "${resume[@]}" --report "$res/compare.json" > "$res/compare.md"
python3 scripts/bands.py record "$res/compare.json" "$res/bands.json"
# the plant variants, 3 seeds from 100 (docs/plant.md)
"$trn" sweep --seeds 3 --out "$res/sweep" --runs "$runs/sweep" "${resume[@]}" > "$res/sweep.md"
# the compact build (i16 tables) against the f32 build, seeds 100-109 (docs/performance.md)
bash scripts/compact.sh "${resume[@]}"
# life-long learning under drift and wear, seed 100 (docs/results.md)
"$trn" lifelong --seed 100 --out "$res/lifelong" --runs "$runs/lifelong" "${resume[@]}" > "$res/lifelong.md"
mv "$res/lifelong/lifelong.png" docs/lifelong-seed100.png
# the same on the realistic plant with drift and wear, 3,000 trials (docs/results.md)
"$trn" lifelong --seed 100 --config realistic-aging --trials 3000 --only project,lifelong,broyden \
    --out "$res/lifelong-realistic-aging" --runs "$runs/lifelong-realistic-aging" "${resume[@]}" \
    > "$res/lifelong-realistic-aging.md"
mv "$res/lifelong-realistic-aging/lifelong.png" docs/lifelong-realistic-aging-seed100.png
# where the coarse move's error comes from: the realistic plant against copies without
# hysteresis and with noise-free cameras, 3 seeds from 100 (docs/diagnosis.md)
"$trn" study studies/diagnosis.toml --runs "$runs/diagnosis" "${resume[@]}" \
    --report out/diagnosis.json > out/diagnosis.md
python3 scripts/diagnosis_table.py "$runs/diagnosis" > "$res/diagnosis.md"
bash scripts/diagnosis_map.sh > "$res/diagnosis-map.md"
# the candidates for fewer fine moves, on tuning seeds, and the best of them again on the
# reporting seeds (docs/diagnosis.md)
bash scripts/precision.sh "${resume[@]}"
python3 scripts/readme_sections.py --results "$res"
echo "results: $res/, the pictures and the generated sections of README.md and docs/*.md regenerated"
