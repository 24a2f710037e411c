#!/usr/bin/env bash
# Measures the live driver on tracks that real trackers would give (docs/FIT.md, "Drivers on
# other trackers' conventions"): drivers of the golden actor trained alike but for the tracker's
# convention drawn for each sample (`--convention-amplitude`: 0, none, as before; 2 and 4 mm on
# the contour), each evaluated against the truth on one held-out performance
# (seed 2, 90 frames, the first 30 at rest, 1 px of landmark noise) as Sinew projects it (clean),
# carrying conventions neither driver saw (seeds 101-103, 4 mm on the contour) raw and
# calibrated on the rest, and carrying a convention and the four tracker failures. Prints a
# Markdown table of `sinew eval driver`'s reports.
#
# Usage: bash scripts/driver_conventions.sh [OUT]   (OUT default: target/driver-conventions; a
# driver or performance already there is reused)
# Environment: SINEW (the binary, default target/debug/sinew under CARGO_TARGET_DIR), SINEW_DATA
# (the licensed data, default ../shared/data), STEPS (training steps, default the trainer's),
# AMPLITUDES (the training conventions, default "0 0.2 0.4"). Prints, after the table, each
# driver's mean head depth raw and calibrated (where a calibration moves the head).
set -euo pipefail
cd "$(dirname "$0")/.."

target="${CARGO_TARGET_DIR:-target}"
sinew="${SINEW:-$target/debug/sinew}"
data="${SINEW_DATA:-../shared/data}/ict-facekit"
out="${1:-$target/driver-conventions}"
actor=tests/data/aim-ict.sinew
steps=(${STEPS:+--steps "$STEPS"})
# The training conventions' contour amplitudes, in the actor's unit (cm): 0 is today's driver.
read -r -a amplitudes <<<"${AMPLITUDES:-0 0.2 0.4}"
[ -x "$sinew" ] || { echo "no sinew binary at $sinew (cargo build -p sinew-host)" >&2; exit 1; }
[ -d "$data" ] || { echo "no ICT-FaceKit data at $data (set SINEW_DATA)" >&2; exit 1; }
mkdir -p "$out"

# The held-out performances: clean, three unseen conventions, a convention with failures.
perf() {
  local name="$1"
  shift
  [ -f "$out/$name/performance.json" ] && return
  "$sinew" data performance --data "$data" --actor "$actor" --seed 2 --frames 90 \
    --rest-frames 30 --landmark-noise-px 1 --out "$out/$name" "$@" >/dev/null
}
perf clean
for c in 101 102 103; do perf "convention-$c" --convention "$c"; done
perf failures --convention 101 --failures 4

for amplitude in "${amplitudes[@]}"; do
  d="$amplitude"
  if [ ! -f "$out/driver-$d.sinew" ]; then
    "$sinew" train driver --model "$actor" --out "$out/driver-$d.sinew" \
      --report "$out/driver-$d.json" --convention-amplitude "$amplitude" --quiet "${steps[@]}"
  fi
  for p in clean convention-101 convention-102 convention-103 failures; do
    for k in 0 30; do
      "$sinew" eval driver --model "$actor" --driver "$out/driver-$d.sinew" \
        --target "$out/$p" --calibrate-frames "$k" --report "$out/eval-$d-$p-$k.json" >/dev/null
    done
  done
done

python3 - "$out" "${amplitudes[@]}" <<'EOF'
import json, sys
out, amplitudes = sys.argv[1], sys.argv[2:]
def r(d, p, k):
    return json.load(open(f"{out}/eval-{d}-{p}-{k}.json"))
def mean(d, k):
    return sum(r(d, f"convention-{c}", k)["performing_error_mm"] for c in (101, 102, 103)) / 3
print("| convention drawn in training (contour) | clean, raw | clean, calibrated | unseen convention, raw | unseen convention, calibrated | calibrated / clean raw | failures: worst frame, calibrated | failures: worst frame, raw |")
print("|---|---|---|---|---|---|---|---|")
for d in amplitudes:
    label = f"{float(d) * 10:g} mm" if float(d) > 0 else "none"
    clean = r(d, "clean", 0)["performing_error_mm"]
    cal = mean(d, 30)
    print(f"| {label} | {clean:.2f} | {r(d, 'clean', 30)['performing_error_mm']:.2f} | "
          f"{mean(d, 0):.2f} | {cal:.2f} | {cal / clean:.2f} | "
          f"{r(d, 'failures', 30)['worst_frame_error_mm']:.2f} | {r(d, 'failures', 0)['worst_frame_error_mm']:.2f} |")
for d in amplitudes:
    f = r(d, "failures", 30)
    print(f"{d}: failures calibrated: lost {f['lost_frames']}, missing {f['missing_frames']}, "
          f"performing {f['performing_error_mm']:.2f} mm")
EOF
python3 - "$out" "${amplitudes[@]}" <<'EOF2'
import json, sys
out, amplitudes = sys.argv[1], sys.argv[2:]
# The head's mean depth (its translation's z, the actor's unit; negative: away from the camera)
# over the frames after the rest, raw / calibrated: where a calibration moves the head.
for d in amplitudes:
    cells = []
    for p in ("clean", "convention-101", "convention-102", "convention-103"):
        z = []
        for k in (0, 30):
            poses = json.load(open(f"{out}/eval-{d}-{p}-{k}.json"))["poses"][30:]
            z.append(sum(q[8] for q in poses) / len(poses))
        cells.append(f"{p} {z[0]:.2f} / {z[1]:.2f}")
    print(f"{d}: head depth raw / calibrated: " + "; ".join(cells))
EOF2
