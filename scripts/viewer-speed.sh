#!/usr/bin/env bash
# The viewer's frame rate on every shipped scene but the toon ones, before and after: the
# build of BASE (default: origin/main if there is one, else HEAD~1) and this work tree,
# side by side on this machine (scripts/speed-compare.sh --rows all), into
# docs/viewer_speed.md, which docs/viewer.md quotes. Usage: scripts/viewer-speed.sh [BASE]
set -euo pipefail
cd "$(dirname "$0")/.."
base=${1:-$(git rev-parse --verify -q origin/main || git rev-parse HEAD~1)}
exec scripts/speed-compare.sh --rows all --runs 1 --frames 90 --out docs/viewer_speed.md "$base"
