#!/usr/bin/env bash
# Regenerates reports/: the paper reproduced (gear Fig 8a/8b spectra and Fig 13-like zooms, press Figs 3-4),
# stability maps, diagnosis reports and the speed-against-error benchmark.
# Usage: scripts/make-reports.sh   (from the repository root; about half a minute)
set -euo pipefail
cd "$(dirname "$0")/.."
rm -rf reports/diagnose reports/diagnose-real reports/identify
cargo build --release --quiet
g=./target/release/gearvib
for s in paper-gear-fig8a paper-gear-fig8b paper-press-case1 paper-press-case2; do
  $g simulate "data/scenes/$s.json" --report "reports/$s" > /dev/null
done
$g sweep data/scenes/hard-gear-light-damping.json --param speed --from 1000 --to 9000 --steps 2000 \
  --report reports/stability-maps > /dev/null
$g diagnose data/recordings/gear-z14z39-fs10kHz-cracked-pinion-tooth3.wav --tacho-channel 2 --channel 1 \
  --baseline data/recordings/gear-z14z39-fs10kHz-healthy.wav --scene data/scenes/gear-z14z39-healthy.json \
  --report reports/diagnose > /dev/null
$g diagnose data/realdata/b30hz90.csv --fs-unknown --baseline data/realdata/h30hz90.csv --channel 3 \
  --report reports/diagnose-real > /dev/null
$g identify data/recordings/gear-z14z39-fs10kHz-cracked-pinion-tooth3.wav \
  --scene data/scenes/gear-z14z39-healthy.json --faults crack,pit --report reports/identify > reports/identify.txt
$g bench --report reports > reports/bench.txt
ls -R reports | head -50
