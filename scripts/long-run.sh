#!/usr/bin/env bash
# The long-run leak check: the release viewer draws 10,000 frames of hair_and_fur.ron under
# Xvfb on the software adapter, reloading the scene from scratch every 100 frames (99
# reloads), and logs its resident memory every 50 frames. Writes docs/long_run/memory.csv
# and docs/long_run/summary.txt (quoted by the README). About 16 minutes on 2 cores.
set -euo pipefail
cd "$(dirname "$0")/.."
out="${1:-docs/long_run}"
mkdir -p "$out"
cpu=$(grep -m1 "model name" /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//')
lines=$(scripts/view-under-xvfb.sh assets/scenes/hair_and_fur.ron --size 640x400 \
    --exit-after-frames 10000 --reload-every 100 --memory-log "$out/memory.csv")
{
  echo "Written by \`scripts/long-run.sh\` on $cpu ($(nproc) threads): \`kami view assets/scenes/hair_and_fur.ron --software --size 640x400 --exit-after-frames 10000 --reload-every 100 --memory-log $out/memory.csv\` under Xvfb; the lines the viewer printed when it closed:"
  echo
  echo "$lines" | grep -E '^(viewer|memory):'
} > "$out/summary.txt"
echo "wrote $out/summary.txt and $out/memory.csv"
