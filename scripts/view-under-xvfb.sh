#!/usr/bin/env bash
# Run the viewer in a virtual X display (no monitor needed) and keep its screenshots.
# Usage: scripts/view-under-xvfb.sh [kami view arguments...]
# e.g.   scripts/view-under-xvfb.sh --exit-after-frames 60 --screenshot viewer.png
# Needs Xvfb (apt-get install -y xvfb) and Mesa's software drivers.
set -euo pipefail
cd "$(dirname "$0")/.."
command -v Xvfb >/dev/null || { echo "Xvfb not found: apt-get install -y xvfb" >&2; exit 1; }
# Xvfb picks a free display itself (-displayfd) and writes its number when it is ready.
numfile=$(mktemp)
Xvfb -displayfd 3 -screen 0 1600x900x24 -nolisten tcp 3>"$numfile" >/dev/null 2>&1 &
xvfb=$!
trap 'kill $xvfb 2>/dev/null || true; rm -f "$numfile"' EXIT
for _ in $(seq 100); do [ -s "$numfile" ] && break; sleep 0.1; done
[ -s "$numfile" ] || { echo "Xvfb did not start" >&2; exit 1; }
display=":$(tr -d '[:space:]' <"$numfile")"
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-$(mktemp -d)}"
DISPLAY="$display" cargo run --release --quiet -- view --software "$@"
