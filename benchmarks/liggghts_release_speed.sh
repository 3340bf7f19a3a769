#!/usr/bin/env bash
# Stepping time of two LIGGGHTS binaries on the same scenes, alternated round by round so that both see the
# same machine load (docs/liggghts.md, "Releases compared"). Prints "LABEL SCENE ROUND LOOP_SECONDS" (the sum
# of the log's 'Loop time of T' blocks) and the median ratio B/A per scene.
#   bash benchmarks/liggghts_release_speed.sh BIN_A BIN_B SCENES_DIR [ROUNDS]
# SCENES_DIR holds one folder per scene with an in.* script (e.g. copies without their 'dump' lines).
set -euo pipefail
a=$1; b=$2; scenes=$3; rounds=${4:-3}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
for round in $(seq "$rounds"); do
  for label in A B; do
    binary=$a; [ "$label" = B ] && binary=$b
    for scene in "$scenes"/*/; do
      name=$(basename "$scene"); run="$work/$label-$name-$round"
      cp -r "$scene" "$run"; mkdir -p "$run/post"
      (cd "$run" && "$binary" -in "$(ls in.* | head -1)" -log log.liggghts > /dev/null 2>&1)
      echo "$label $name $round $(awk '/^Loop time/ {s += $4} END {print s}' "$run/log.liggghts")"
    done
  done
done | tee "$work/times"
python3 - "$work/times" <<'PY'
import collections, statistics, sys
times = collections.defaultdict(list)
for line in open(sys.argv[1]):
    label, scene, _round, seconds = line.split()
    times[(label, scene)].append(float(seconds))
for scene in sorted({s for _, s in times}):
    a, b = statistics.median(times[("A", scene)]), statistics.median(times[("B", scene)])
    print(f"{scene}: median A {a:.2f} s, B {b:.2f} s, B/A {b / a:.3f}")
PY
