#!/usr/bin/env bash
# Regenerates data/recordings/*.wav (and their .wav.json sidecars) from the example fault scenes.
# Usage: scripts/make-recordings.sh   (from the repository root)
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet
for fault in healthy pitted-pinion-tooth3 cracked-pinion-tooth3 wheel-eccentricity rectangular-stiffness; do
  ./target/release/gearvib simulate "data/scenes/gear-z14z39-$fault.json" \
    -o "data/recordings/gear-z14z39-fs10kHz-$fault.wav" --json > /dev/null
done
ls -l data/recordings
