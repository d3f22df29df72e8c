#!/usr/bin/env bash
# Viewer frame rates for the README: each case runs the release viewer for 150 frames at
# 1280x720 under Xvfb on the software adapter and keeps the summary line it prints at exit.
# Writes docs/viewer_speed.md (quoted by the README). Usage: scripts/viewer-speed.sh [OUT.md]
set -euo pipefail
cd "$(dirname "$0")/.."
out="${1:-docs/viewer_speed.md}"
cargo build --release --quiet
cases=(
  "assets/scenes/gust.ron"
  "assets/scenes/bob.ron"
  "assets/scenes/gust.ron --set lod=1"
  "assets/scenes/gust.ron --set lod=1 --set msaa=1"
  "assets/scenes/gust.ron --set lod=1 --set strands=compute"
  "assets/scenes/gust.ron --set lod=1 --set msaa=1 --set strands=compute"
  "assets/scenes/gust.ron --set lod=0.01 --set msaa=1"
  "assets/scenes/fur.ron"
  "assets/scenes/fur.ron --set lod=1"
)
cpu=$(grep -m1 "model name" /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//')
{
  echo "### Viewer speed"
  echo
  echo "Written by \`scripts/viewer-speed.sh\` on $cpu ($(nproc) threads): \`kami view SCENE --software --size 1280x720 --exit-after-frames 150\` under Xvfb, one run per row; each row is the line the viewer prints when it closes (fps from the mean frame time; the per-part figures are moving averages)."
  echo
  echo "| arguments | what the viewer printed |"
  echo "|---|---|"
  for c in "${cases[@]}"; do
    # shellcheck disable=SC2086
    line=$(scripts/view-under-xvfb.sh $c --size 1280x720 --exit-after-frames 150 | grep '^viewer:')
    echo "| \`$c\` | ${line#viewer: } |"
  done
} > "$out.partial"
mv "$out.partial" "$out"
echo "wrote $out"
