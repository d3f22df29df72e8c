#!/usr/bin/env bash
# The toon wisps in the viewer under Xvfb at 1280x720 on the software adapter (issue 34's
# goal, 10 fps): `scripts/wisps-viewer.sh [FRAMES]` writes docs/wisps_viewer.txt with each
# run's exit line (fps, per-pass times): toon.ron and toon_shake.ron drawn with the mesh
# under the viewer's adaptive quality (what an artist sees), with the mesh at full quality
# (`--set lod=1`: every hair, full resolution, the mesh's own cell), and with the march;
# toon_shake.ron also meshed on the GPU (`--set wisps.mesh.on=gpu`: lavapipe's compute).
# FRAMES (default 60) is for the mesh; the march gets 4 (seconds a frame there).
set -euo pipefail
cd "$(dirname "$0")/.."
frames="${1:-60}"
bin="${KAMI_BIN:-target/release/kami}"
[ -x "$bin" ] || cargo build --release
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-$(mktemp -d)}"
out=docs/wisps_viewer.txt
run() {
    local scene=$1 n=$2
    shift 2
    echo "\$ xvfb-run -a kami view assets/scenes/$scene.ron --software --size 1280x720 --exit-after-frames $n $*"
    xvfb-run -a -s "-screen 0 1280x800x24" "$bin" view "assets/scenes/$scene.ron" --software \
        --size 1280x720 --exit-after-frames "$n" "$@" 2>&1 | grep '^viewer:'
}
{
    echo "# Written by scripts/wisps-viewer.sh on $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs) ($(nproc) threads), $(date -u +%Y-%m-%d)"
    for s in toon toon_shake; do
        run "$s" "$frames" --set wisps.draw=mesh
        run "$s" "$frames" --set wisps.draw=mesh --set lod=1
        run "$s" 4 --set wisps.draw=march
    done
    run toon_shake "$frames" --set wisps.draw=mesh --set wisps.mesh.on=gpu
} > "$out"
cat "$out"
