#!/usr/bin/env bash
# Run the viewer in a virtual X display (no monitor needed) and keep its screenshots.
# Usage: scripts/view-under-xvfb.sh [kami view arguments...]
# e.g.   scripts/view-under-xvfb.sh --exit-after-frames 60 --screenshot viewer.png
# Needs Xvfb (apt-get install -y xvfb) and Mesa's software drivers.
set -euo pipefail
cd "$(dirname "$0")/.."
command -v Xvfb >/dev/null || { echo "Xvfb not found: apt-get install -y xvfb" >&2; exit 1; }
display=""
for n in $(seq 90 140); do
    if [ ! -e "/tmp/.X11-unix/X$n" ] && [ ! -e "/tmp/.X$n-lock" ]; then display=":$n"; break; fi
done
[ -n "$display" ] || { echo "no free X display number" >&2; exit 1; }
Xvfb "$display" -screen 0 1600x900x24 -nolisten tcp >/dev/null 2>&1 &
xvfb=$!
trap 'kill $xvfb 2>/dev/null || true' EXIT
for _ in $(seq 50); do [ -e "/tmp/.X11-unix/X${display#:}" ] && break; sleep 0.1; done
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-$(mktemp -d)}"
DISPLAY="$display" cargo run --release --quiet -- view --software "$@"
