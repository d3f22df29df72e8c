#!/usr/bin/env bash
# The toon wisps in the viewer under Xvfb at 1280x720 on the software adapter (issue 23's
# goal): `scripts/wisps-viewer.sh [FRAMES]` writes docs/wisps_viewer.txt with each run's exit
# line (fps, per-pass times). FRAMES defaults to 4: at about 10 s a frame there, 60 frames
# would take ten minutes a scene.
set -euo pipefail
cd "$(dirname "$0")/.."
frames="${1:-4}"
bin="${KAMI_BIN:-target/release/kami}"
[ -x "$bin" ] || cargo build --release
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-$(mktemp -d)}"
out=docs/wisps_viewer.txt
{
    echo "# Written by scripts/wisps-viewer.sh on $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs) ($(nproc) threads), $(date -u +%Y-%m-%d)"
    for s in toon toon_shake; do
        echo "\$ xvfb-run -a kami view assets/scenes/$s.ron --software --size 1280x720 --exit-after-frames $frames"
        xvfb-run -a -s "-screen 0 1280x800x24" "$bin" view "assets/scenes/$s.ron" --software \
            --size 1280x720 --exit-after-frames "$frames" 2>&1 | grep '^viewer:'
    done
} > "$out"
cat "$out"
