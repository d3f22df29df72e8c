#!/usr/bin/env bash
# Viewer frame rate of two commits side by side, on this machine, in one run: the guard to
# run before landing any change to shared shaders, the stage's passes or the resolve
# (docs/performance.md). A cost measured inside one build cannot see what a change added;
# a ratio against the build before it can.
#
# Usage: scripts/speed-compare.sh [--rows quick|all] [--frames N] [--runs R] [--out FILE.md]
#                                  [--goal FPS] BASE [NEW]
#   BASE, NEW  commits (NEW defaults to the work tree as it is, uncommitted edits included)
#   --frames   frames per viewer run (default 60)
#   --runs     runs per row and build, alternating A B A B; the best is kept (default 2)
#   --out      the report (default docs/viewer_speed_compare.md)
#   --rows     quick (default): bob, fur, strips and gust with default settings and at a fixed
#              share of hairs; all: every shipped scene but the toon ones (whose march is
#              another issue's), default settings
#   --goal     the frame rate B's rows are checked against in the report (default 15)
#   KAMI_COMPARE_CASES  newline-separated rows ("scene.ron --set k=v ..."), replacing the
#                       default rows below; in a row, what follows " +B " is given to B
#                       alone (a setting A does not know, such as "+B --set shadows=off")
#
# Each commit is built in its own worktree under target/compare/ into the project's target
# directory (CARGO_TARGET_DIR if set), so the dependencies build once; the binaries are
# copied out before the next build. The viewer runs under Xvfb on the software adapter at 1280x720 (`kami view --software
# --exit-after-frames N`, the line it prints at exit). Rows whose flags a build does not know
# are reported as such, not dropped.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
invocation="$*"
frames=60
runs=2
rows=quick
goal=15
out=docs/viewer_speed_compare.md
while [ $# -gt 0 ]; do
  case "$1" in
    --frames) frames=$2; shift 2 ;;
    --runs) runs=$2; shift 2 ;;
    --out) out=$2; shift 2 ;;
    --rows) rows=$2; shift 2 ;;
    --goal) goal=$2; shift 2 ;;
    -h|--help) sed -n 2,20p "$0"; exit 0 ;;
    -*) echo "speed-compare: unknown option $1" >&2; exit 2 ;;
    *) break ;;
  esac
done
[ $# -ge 1 ] || { echo "usage: scripts/speed-compare.sh [--frames N] [--runs R] [--out F] BASE [NEW]" >&2; exit 2; }
base=$1
new=${2:-}
command -v Xvfb >/dev/null || { echo "speed-compare: Xvfb not found: apt-get install -y xvfb" >&2; exit 1; }

work="$root/target/compare"
mkdir -p "$work/bin"
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$root/target}"

# build REV NAME: the release binary of commit REV (or the work tree for "") as $work/bin/NAME.
build() {
  local rev=$1 name=$2 src
  if [ -z "$rev" ]; then
    src=$root
  else
    src="$work/tree-$name"
    git worktree remove --force "$src" 2>/dev/null || rm -rf "$src"
    git worktree prune
    git worktree add --detach --quiet "$src" "$rev"
  fi
  echo "speed-compare: building ${rev:-the work tree} ..." >&2
  (cd "$src" && cargo build --release --quiet --bin kami)
  cp "$CARGO_TARGET_DIR/release/kami" "$work/bin/$name"
  if [ -n "$rev" ]; then
    git worktree remove --force "$src"
  fi
}

base_id=$(git rev-parse --short "$base")
if [ -n "$new" ]; then
  new_id=$(git rev-parse --short "$new")
else
  new_id="$(git rev-parse --short HEAD)$(git diff --quiet HEAD -- src shaders Cargo.toml Cargo.lock || echo '+edits')"
fi
build "$base" A
build "$new" B

default_cases="assets/scenes/bob.ron
assets/scenes/fur.ron
assets/scenes/strips.ron
assets/scenes/gust.ron
assets/scenes/bob.ron --set lod=0.1
assets/scenes/fur.ron --set lod=0.1
assets/scenes/strips.ron --set lod=0.1"
if [ "$rows" = all ]; then
  default_cases=$(ls assets/scenes/*.ron | grep -v '/toon' | sort)
elif [ "$rows" != quick ]; then
  echo "speed-compare: --rows is quick or all, not $rows" >&2
  exit 2
fi
cases=${KAMI_COMPARE_CASES:-$default_cases}

# view BIN ARGS...: the viewer's closing line, or why there is none.
view() {
  local bin=$1 numfile xvfb line
  shift
  numfile=$(mktemp)
  Xvfb -displayfd 3 -screen 0 1600x900x24 -nolisten tcp 3>"$numfile" >/dev/null 2>&1 &
  xvfb=$!
  for _ in $(seq 100); do [ -s "$numfile" ] && break; sleep 0.1; done
  line=$(DISPLAY=":$(tr -d '[:space:]' <"$numfile")" XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}" \
    "$bin" view --software --size 1280x720 --exit-after-frames "$frames" "$@" 2>&1 \
    | grep -m1 -E '^viewer:|^error|^Error' || true)
  kill "$xvfb" 2>/dev/null || true
  wait "$xvfb" 2>/dev/null || true
  rm -f "$numfile"
  echo "${line:-no closing line}"
}
fps_of() { sed -n 's/.*, \([0-9.]*\) fps;.*/\1/p' <<<"$1"; }
# The share of hairs drawn and what else the budget dropped ("40 %, MSAA off").
share_of() { sed -n 's/.*; \([0-9]*\) % of hairs drawn\(.*\), [0-9]*x[0-9]* on .*/\1 %\2/p' <<<"$1"; }

cpu=$(grep -m1 "model name" /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//')
adapter=""
lines=()
total=0
met=0
while IFS= read -r c; do
  [ -n "$c" ] || continue
  best_a=""; best_b=""; line_a=""; line_b=""
  for _ in $(seq "$runs"); do
    for which in A B; do
      args=${c%% +B *}
      [ "$which" = B ] && [ "$c" != "$args" ] && args="$args ${c#* +B }"
      # shellcheck disable=SC2086
      l=$(view "$work/bin/$which" $args)
      f=$(fps_of "$l")
      if [ "$which" = A ]; then
        if [ -n "$f" ] && { [ -z "$best_a" ] || awk "BEGIN{exit !($f > $best_a)}"; }; then best_a=$f; line_a=$l; fi
        [ -n "$line_a" ] || line_a=$l
      else
        if [ -n "$f" ] && { [ -z "$best_b" ] || awk "BEGIN{exit !($f > $best_b)}"; }; then best_b=$f; line_b=$l; fi
        [ -n "$line_b" ] || line_b=$l
      fi
    done
  done
  [ -n "$adapter" ] || adapter=$(sed -n 's/.* on \(.*\)$/\1/p' <<<"$line_b")
  if [ -n "$best_b" ]; then
    total=$((total + 1))
    awk "BEGIN{exit !($best_b >= $goal)}" && met=$((met + 1))
  fi
  if [ -n "$best_a" ] && [ -n "$best_b" ]; then
    ratio=$(awk "BEGIN{printf \"%.2f\", $best_b / $best_a}")
  else
    ratio="–"
  fi
  row="| \`$c\` | ${best_a:-–} | $(share_of "$line_a") | ${best_b:-–} | $(share_of "$line_b") | **$ratio** |"
  [ -n "$best_a" ] || row="$row A: ${line_a#viewer: } |"
  [ -n "$best_b" ] || row="$row B: ${line_b#viewer: } |"
  echo "$row" >&2
  lines+=("$row")
done <<<"$cases"

mkdir -p "$(dirname "$out")"
{
  echo "### Viewer speed, side by side"
  echo
  echo "Written by \`scripts/speed-compare.sh $invocation\` on $cpu ($(nproc) threads), ${adapter:-the software adapter}: A is $base_id, B is $new_id, each built here in one run. Each row is \`kami view ROW --software --size 1280x720 --exit-after-frames $frames\` under Xvfb, best of $runs runs per build, the builds taking turns. The ratio is B's fps over A's: below 1, B is slower. "drew" is the share of hairs the adaptive level of detail drew and what else it dropped to keep up."
  echo
  echo "| row | A fps | A drew | B fps | B drew | B / A |"
  echo "|---|---:|---:|---:|---:|---:|"
  printf '%s\n' "${lines[@]}"
  echo
  echo "**This build (B) at $goal fps or more: $met of $total rows.**"
} >"$out.partial"
mv "$out.partial" "$out"
echo "wrote $out" >&2
