#!/usr/bin/env bash
# Every Kami bench that measures an adapter, run on a hardware GPU in one go: each writes its
# report into docs/gpu/<bench>/ (its own .md/.csv/.png files, its log.txt, and run.txt: the
# command, time, status and device), and docs/gpu/DEVICE.md names the GPU, its driver and
# the adapter Kami picked for every report in the folder. The README's GPU figures are
# quoted from these files. Refuses to run on a software adapter (llvmpipe, lavapipe).
# Not run: `bench backends` (it compares the two software adapters) and `bench sdf` (CPU
# only). docs/gpu/README.md says how to run it on the device machine (no cargo there).
#
# Usage: scripts/gpu-report.sh [--only a,b] [--quick] [--out DIR] [--bin PATH]
#                              [--timeout S] [--deadline S] [--list]
set -euo pipefail
cd "$(dirname "$0")/.."

# Run order: the short benches first, the big sweep last.
all=(groom dynamics guides lod raster fur wisps strips scale)
declare -A full=(
  [groom]="--frames 10"
  [dynamics]=""
  [guides]=""
  [lod]=""
  [raster]="--runs 21"
  [fur]="--frames 20"
  [wisps]="--frames 10"
  [strips]="--frames 30"
  [scale]="--frames 10"
)
# --quick: the fewest frames each bench takes, and a smaller scale sweep. dynamics, guides
# and lod take no frame count and run as in the full set.
declare -A quick=(
  [groom]="--frames 2"
  [dynamics]=""
  [guides]=""
  [lod]=""
  [raster]="--runs 1"
  [fur]="--frames 1"
  [wisps]="--frames 1"
  [strips]="--frames 3"
  [scale]="--strands 1000,100000 --segments 16,64 --frames 2"
)

usage() {
  cat <<EOF
Usage: scripts/gpu-report.sh [options]
  --only a,b     run these benches only (of: ${all[*]})
  --quick        fewer frames (smoke test); writes to bench_out/gpu-quick unless --out
  --out DIR      report folder (default docs/gpu); each bench writes DIR/<bench>/
  --bin PATH     the kami binary (default \$KAMI_BIN; else cargo build --release where
                 cargo exists; else target/release/kami, then .gpu-bin/kami)
  --timeout S    stop one bench after S seconds (default 540; 0: no limit)
  --deadline S   start no bench after S seconds, and cut the running one off there
                 (default 0: none); the ones not run are reported and fail the run
  --list         print the commands and exit
Exit status: 0 all ran, 1 a bench failed or was skipped, 2 bad usage, 3 no hardware adapter.
EOF
}

die() { echo "gpu-report: $1" >&2; exit "${2:-1}"; }

only="" mode=full out="" bin="${KAMI_BIN:-}" timeout_s=540 deadline=0 list=0
while (($#)); do
  case $1 in
    --only) only=${2:?--only needs a list}; shift 2 ;;
    --only=*) only=${1#*=}; shift ;;
    --quick) mode=quick; shift ;;
    --out) out=${2:?--out needs a folder}; shift 2 ;;
    --out=*) out=${1#*=}; shift ;;
    --bin) bin=${2:?--bin needs a path}; shift 2 ;;
    --bin=*) bin=${1#*=}; shift ;;
    --timeout) timeout_s=${2:?--timeout needs seconds}; shift 2 ;;
    --timeout=*) timeout_s=${1#*=}; shift ;;
    --deadline) deadline=${2:?--deadline needs seconds}; shift 2 ;;
    --deadline=*) deadline=${1#*=}; shift ;;
    --list) list=1; shift ;;
    -h | --help) usage; exit 0 ;;
    *) usage >&2; die "unknown argument: $1" 2 ;;
  esac
done
[[ $timeout_s =~ ^[0-9]+$ ]] || die "--timeout $timeout_s: whole seconds, please" 2
[[ $deadline =~ ^[0-9]+$ ]] || die "--deadline $deadline: whole seconds, please" 2
if [[ -z $out ]]; then
  if [[ $mode == quick ]]; then out=bench_out/gpu-quick; else out=docs/gpu; fi
fi
out=${out%/}
[[ -n $out ]] || die "--out /: name a folder" 2

benches=()
if [[ -n $only ]]; then
  IFS=, read -ra wanted <<<"$only"
  for b in "${wanted[@]}"; do
    b=${b// /}
    [[ -n $b ]] || continue
    case $b in
      backends) die "bench backends compares the software adapters: it makes no GPU report" 2 ;;
      sdf) die "bench sdf runs on the CPU only: it makes no GPU report" 2 ;;
    esac
    [[ " ${all[*]} " == *" $b "* ]] || die "no bench '$b' (benches: ${all[*]})" 2
    benches+=("$b")
  done
  ((${#benches[@]})) || die "--only named no bench" 2
else
  benches=("${all[@]}")
fi

flags_of() { # bench -> the flags of this mode
  if [[ $mode == quick ]]; then echo "${quick[$1]}"; else echo "${full[$1]}"; fi
}

if ((list)); then
  for b in "${benches[@]}"; do
    read -ra f <<<"$(flags_of "$b")"
    echo "kami bench $b ${f[*]}${f[*]:+ }--out $out/$b"
  done
  exit 0
fi

# --- the binary ------------------------------------------------------------------------
if [[ -z $bin ]]; then
  if command -v cargo >/dev/null; then
    echo "gpu-report: cargo build --release"
    cargo build --release --quiet
    bin=target/release/kami
  elif [[ -x target/release/kami ]]; then
    bin=target/release/kami
  elif [[ -x .gpu-bin/kami ]]; then
    bin=.gpu-bin/kami
  else
    die "no kami binary: no cargo here, and neither target/release/kami nor .gpu-bin/kami exists; build one elsewhere and pass --bin (docs/gpu/README.md)"
  fi
fi
[[ -x $bin ]] || die "$bin is not an executable"
[[ $bin == */* ]] || bin=./$bin
version=$("$bin" --version 2>/dev/null) || die "$bin --version failed: is it a kami binary for this machine?"

# --- Vulkan loader and driver (the device machine's notes) ------------------------------
# A machine without libvulkan gets the loaders from .gl/*.deb, as the device notes say: the
# packages are fetched beforehand on the development machine and unpacked here into /
# (root only). Nothing is downloaded or installed from a registry.
if ! ldconfig -p 2>/dev/null | grep 'libvulkan\.so\.1' >/dev/null; then
  shopt -s nullglob
  debs=(.gl/*.deb)
  shopt -u nullglob
  if ((${#debs[@]})) && [[ $(id -u) -eq 0 ]] && command -v dpkg >/dev/null; then
    echo "gpu-report: no libvulkan.so.1; unpacking ${#debs[@]} packages from .gl/ into /"
    for f in "${debs[@]}"; do dpkg -x "$f" /; done
    ldconfig
  else
    echo "gpu-report: warning: no libvulkan.so.1 found (and no .gl/*.deb to unpack as root); Kami may find no GPU" >&2
  fi
fi

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-$tmp}"

# Kami's own adapter line: `kami render` logs "adapter: NAME (BACKEND, TYPE)" at info level.
adapter="" adapter_type="" adapter_name=""
probe() {
  adapter="" adapter_type="" adapter_name=""
  RUST_LOG="warn,wgpu_hal::gles::egl=off,kami::gpu=info" \
    "$bin" render assets/scenes/gust.ron --out "$tmp/probe.png" --size 64x64 \
    >"$tmp/probe.log" 2>&1 || return 1
  adapter=$(grep -m1 'adapter: ' "$tmp/probe.log" | sed 's/.*adapter: //') || return 1
  [[ -n $adapter ]] || return 1
  adapter_type=${adapter##*, }
  adapter_type=${adapter_type%)}
  adapter_name=${adapter% (*}
  [[ $adapter_type == DiscreteGpu || $adapter_type == IntegratedGpu ]] || return 1
  ! grep -qiE 'llvmpipe|lavapipe|softpipe|swiftshader' <<<"$adapter_name"
}
driver_note="the system's Vulkan drivers"
if ! probe; then
  nv_icd=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
  nv_egl=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
  if [[ -z ${VK_DRIVER_FILES:-}${VK_ICD_FILENAMES:-} && -f $nv_icd ]]; then
    # The device notes: "If no driver is found, add" these.
    echo "gpu-report: no hardware adapter with the default drivers; trying $nv_icd"
    export VK_DRIVER_FILES=$nv_icd VK_ICD_FILENAMES=$nv_icd
    [[ -f $nv_egl ]] && export __EGL_VENDOR_LIBRARY_FILENAMES=$nv_egl
    driver_note="VK_DRIVER_FILES=$nv_icd"
    probe || true
  fi
fi
if [[ -z $adapter_type || $adapter_type != @(DiscreteGpu|IntegratedGpu) ]] ||
  grep -qiE 'llvmpipe|lavapipe|softpipe|swiftshader' <<<"$adapter_name"; then
  echo "gpu-report: the probe (kami render assets/scenes/gust.ron --size 64x64) said:" >&2
  tail -n 20 "$tmp/probe.log" >&2
  die "no hardware adapter: Kami picked '${adapter:-nothing}'. A software adapter's figures are not a GPU report; nothing was written." 3
fi
if [[ $driver_note != VK_* && -n ${VK_DRIVER_FILES:-}${VK_ICD_FILENAMES:-} ]]; then
  driver_note="VK_DRIVER_FILES=${VK_DRIVER_FILES:-} VK_ICD_FILENAMES=${VK_ICD_FILENAMES:-} (set by the caller)"
fi

gpu="(nvidia-smi not found)"
if command -v nvidia-smi >/dev/null; then
  gpu=$(nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader 2>/dev/null |
    paste -sd ';' - | sed 's/;/; /g') || true
  [[ -n $gpu ]] || gpu="(nvidia-smi found no GPU)"
fi
cpu=$(grep -m1 "model name" /proc/cpuinfo 2>/dev/null | cut -d: -f2 | sed 's/^ *//') || true
cpu="${cpu:-unknown CPU} ($(nproc 2>/dev/null || echo '?') threads)"
source_rev="unknown (no git checkout)"
if rev=$(git rev-parse --short HEAD 2>/dev/null); then
  source_rev=$rev
  [[ -z $(git status --porcelain --untracked-files=no -- src shaders Cargo.toml Cargo.lock 2>/dev/null) ]] ||
    source_rev="$rev with uncommitted changes to src/, shaders/ or Cargo files"
fi
bin_id=$( (sha256sum "$bin" 2>/dev/null || shasum -a 256 "$bin") | cut -c1-16)
bin_date=$(date -u -r "$bin" +%Y-%m-%dT%H:%MZ 2>/dev/null || echo unknown)
run_id=$(date -u +%Y-%m-%dT%H:%M:%SZ)
echo "gpu-report: $adapter; GPU: $gpu"
echo "gpu-report: $mode run of ${benches[*]} into $out/"

# --- the benches ---------------------------------------------------------------------------
mkdir -p "$out"
now_ms() { echo $(($(date +%s%N) / 1000000)); }
t0=$(now_ms)
failed=() skipped=() summary=()
for b in "${benches[@]}"; do
  read -ra f <<<"$(flags_of "$b")"
  dir=$out/$b
  limit=$timeout_s
  if ((deadline)); then
    left=$((deadline - ($(now_ms) - t0) / 1000))
    if ((left < 10)); then
      skipped+=("$b")
      summary+=("$(printf '%-9s %-46s' "$b" "skipped (--deadline)")")
      continue
    fi
    ((limit == 0 || left < limit)) && limit=$left
  fi
  rm -rf "$dir"
  mkdir -p "$dir"
  cmd=("$bin" bench "$b" "${f[@]}" --out "$dir")
  shown="kami bench $b ${f[*]}${f[*]:+ }--out $dir"
  echo "gpu-report: [$b] $shown"
  runner=()
  ((limit > 0)) && command -v timeout >/dev/null && runner=(timeout --kill-after=10 "$limit")
  start=$(now_ms)
  if "${runner[@]}" "${cmd[@]}" >"$dir/log.txt" 2>&1; then rc=0; else rc=$?; fi
  ms=$(($(now_ms) - start))
  secs=$((ms / 1000)).$(((ms % 1000) / 100))
  status=ok
  if ((rc == 124 || rc == 137)) && ((${#runner[@]})); then
    status="timed out after $limit s"
  elif ((rc != 0)); then
    status="failed (exit $rc)"
  elif [[ ! -s $dir/$b.md ]]; then
    status="failed (wrote no $b.md)"
  elif grep -qiE 'adapter.*(llvmpipe|lavapipe|softpipe|swiftshader)' "$dir"/*.md; then
    status="failed (its report names a software adapter)"
  fi
  cat >"$dir/run.txt" <<EOF
bench: $b
status: $status
seconds: $secs
command: $shown
mode: $mode
run: $run_id
adapter: $adapter
gpu: $gpu
drivers: $driver_note
cpu: $cpu
kami: $version, binary sha256 $bin_id..., built $bin_date
source: $source_rev
EOF
  summary+=("$(printf '%-9s %-46s %7s s' "$b" "$status" "$secs")")
  if [[ $status == ok ]]; then
    echo "gpu-report: [$b] ok, $secs s"
  else
    failed+=("$b")
    echo "gpu-report: [$b] $status ($secs s); the end of $dir/log.txt:" >&2
    tail -n 15 "$dir/log.txt" >&2
  fi
done
total_ms=$(($(now_ms) - t0))
total="$((total_ms / 1000)).$(((total_ms % 1000) / 100))"

# --- DEVICE.md: every report in the folder, with its device ---------------------------------
field() { sed -n "s/^$2: //p" "$1" | head -n 1; }
{
  echo "# The device behind these reports"
  echo
  echo "Written by \`scripts/gpu-report.sh\`, which rewrites this file after every run from the"
  echo "\`run.txt\` each bench leaves in its folder: do not edit it by hand. docs/gpu/README.md"
  echo "says how the reports are made."
  echo
  echo "## Last run ($run_id)"
  echo
  echo "- Benches: ${benches[*]} (${mode}); ${total} s in all."
  ((${#failed[@]})) && echo "- **Failed:** ${failed[*]}."
  ((${#skipped[@]})) && echo "- **Not run (deadline):** ${skipped[*]}."
  echo "- GPU (nvidia-smi: name, driver, memory): $gpu"
  echo "- Adapter Kami picked: $adapter"
  echo "- Drivers: $driver_note"
  echo "- CPU: $cpu; kernel $(uname -sr)"
  echo "- Kami: $version, binary \`$bin\` (sha256 $bin_id..., built $bin_date); source $source_rev"
  echo
  echo "## Every report in this folder"
  echo
  echo "| bench | status | seconds | run | adapter | GPU (nvidia-smi) | command |"
  echo "|---|---|---:|---|---|---|---|"
  adapters=() runs=() states=()
  for b in "${all[@]}"; do
    r=$out/$b/run.txt
    [[ -f $r ]] || continue
    a=$(field "$r" adapter) g=$(field "$r" gpu) u=$(field "$r" run) s=$(field "$r" status)
    m=$(field "$r" mode)
    [[ $m == quick ]] && s="$s (quick)"
    echo "| $(field "$r" bench) | $s | $(field "$r" seconds) | $u | $a | $g | \`$(field "$r" command)\` |"
    adapters+=("$a / $g") runs+=("$u") states+=("$s")
  done
  echo
  n_dev=$(printf '%s\n' "${adapters[@]}" | sort -u | grep -c .) || true
  n_run=$(printf '%s\n' "${runs[@]}" | sort -u | grep -c .) || true
  if ((n_dev > 1)); then
    echo "**These reports come from $n_dev different devices or drivers:** run the script again"
    echo "without --only before quoting them side by side."
  elif ((n_run > 1)); then
    echo "All on one device ($adapter), but from $n_run runs of the script (--only)."
  else
    echo "All from one run on one device: $adapter."
  fi
  if ((${#states[@]})) && printf '%s\n' "${states[@]}" | grep -qv '^ok$'; then
    echo "Some reports above are not \"ok\": a failed bench's folder holds only what it wrote"
    echo "before it stopped (see its log.txt); a quick run's figures are a smoke test."
  fi
} >"$out/DEVICE.md"

echo
echo "gpu-report: $adapter; $total s; reports in $out/, device in $out/DEVICE.md"
printf '  %s\n' "${summary[@]}"
if ((${#failed[@]} + ${#skipped[@]})); then
  rest=("${failed[@]}" "${skipped[@]}")
  echo "gpu-report: failed: ${failed[*]:-none}; not run: ${skipped[*]:-none}" >&2
  again="scripts/gpu-report.sh"
  [[ $mode == quick ]] && again+=" --quick"
  [[ $out == docs/gpu || ($mode == quick && $out == bench_out/gpu-quick) ]] || again+=" --out $out"
  echo "gpu-report: rerun them with: $again --only $(IFS=,; echo "${rest[*]}")" >&2
  exit 1
fi
