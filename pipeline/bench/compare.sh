#!/usr/bin/env bash
# The whole pipeline (`cellsar run`, separate processes) against the same stages in one process
# (`cellsar-radar-sim closed-loop`), on the same mission and scene, alternately, with a check
# that both wrote the same detections, metrics, report and images.
#
#   pipeline/bench/compare.sh [MISSION] [SCENE] [REPETITIONS] [extra cellsar run flags...]
#   defaults: missions/default-30m.toml radar-sim/scenes/default.toml 1
#
# Output: one line per run (wall time, exit code) and the verdict of the comparison;
# work files under ${OUT:-target/pipeline-bench}; binaries from ${CARGO_TARGET_DIR:-target}/release.
set -uo pipefail
cd "$(dirname "$0")/../.."
M=${1:-missions/default-30m.toml}
S=${2:-radar-sim/scenes/default.toml}
R=${3:-1}
shift $(( $# < 3 ? $# : 3 ))
OUT=${OUT:-target/pipeline-bench}
BIN=${CARGO_TARGET_DIR:-target}/release
cargo build --release -q -p pipeline -p radar-sim || exit 1
mkdir -p "$OUT"
for i in $(seq 1 "$R"); do
  rm -rf "$OUT/closed-loop" "$OUT/pipeline"
  # wall, user and system CPU seconds (the launcher's include its reaped children)
  /usr/bin/time -f "%e %U %S" -o "$OUT/closed-loop.time" \
    "$BIN"/cellsar-radar-sim closed-loop "$M" --scene "$S" --out "$OUT/closed-loop" \
    > "$OUT/closed-loop.log" 2>&1
  rc1=$?
  /usr/bin/time -f "%e %U %S" -o "$OUT/pipeline.time" \
    "$BIN"/cellsar run "$M" --scene "$S" --out "$OUT/pipeline" "$@" \
    > "$OUT/pipeline.log" 2>&1
  rc2=$?
  read -r w1 u1 s1 < <(tail -1 "$OUT/closed-loop.time")
  read -r w2 u2 s2 < <(tail -1 "$OUT/pipeline.time")
  printf 'rep %d  closed-loop %6.1f s wall %6.1f s CPU (exit %d)   cellsar run %6.1f s wall %6.1f s CPU (exit %d)   load %s\n' \
    "$i" "$w1" "$(echo "$u1 + $s1" | bc)" "$rc1" "$w2" "$(echo "$u2 + $s2" | bc)" "$rc2" \
    "$(cut -d' ' -f1-3 /proc/loadavg)"
  same=yes
  for f in detections.csv detections.json metrics.json; do
    cmp -s "$OUT/closed-loop/processed/$f" "$OUT/pipeline/$f" || { same=no; echo "  $f differs"; }
  done
  cmp -s "$OUT/closed-loop/report.json" "$OUT/pipeline/report.json" || { same=no; echo "  report.json differs"; }
  for img in "$OUT"/closed-loop/processed/images/*.npy; do
    cmp -s "$img" "$OUT/pipeline/images/$(basename "$img")" || { same=no; echo "  $(basename "$img") differs"; }
  done
  echo "  same outputs: $same"
  python3 - "$OUT/pipeline/pipeline.json" <<'PY' 2>/dev/null || true
import json, sys
p = json.load(open(sys.argv[1]))
print("  pipeline: plan %.1f s, imaging %.1f s, %d apertures, %d frames of %d pulses, restarts %s"
      % (p["plan_s"], p["imaging_s"], p["apertures"], p["frames"], p["frame_pulses"], p["restarts"]))
PY
done
