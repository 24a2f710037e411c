#!/usr/bin/env bash
# Builds the C API as a static library (release), compiles examples/replay.c against it with
# strict warnings, plays every golden artefact from C (the AIM and S2D replays, the fitted
# performance fit-ict on aim-ict, the generated sequence motion-ict through s2d-ict) and diffs
# the printed hash lists against tests/data/*.hashes. Exits non-zero on a build error, a
# warning, a failed call, a frame that differs from its recording, or any line that differs from
# the golden list; then drives the golden actor from the golden OpenFace track with the golden
# landmark driver (examples/drive.c) and diffs its hashes, unfiltered and filtered, and live from
# the golden live track with the calibration and the lost-frame rules (examples/live.c).
set -euo pipefail
cd "$(dirname "$0")/../.."

: "${CARGO_TARGET_DIR:=target}"
CC="${CC:-cc}"
out="$CARGO_TARGET_DIR/ffi-example"
mkdir -p "$out"

cargo build -p sinew-ffi --release --locked
"$CC" -std=c11 -Wall -Wextra -Werror -pedantic -O2 -Icore/ffi/include \
  core/ffi/examples/replay.c "$CARGO_TARGET_DIR/release/libsinew.a" \
  -lm -lpthread -ldl -o "$out/replay"
"$CC" -std=c11 -Wall -Wextra -Werror -pedantic -O2 -Icore/ffi/include \
  core/ffi/examples/drive.c "$CARGO_TARGET_DIR/release/libsinew.a" \
  -lm -lpthread -ldl -o "$out/drive"
"$CC" -std=c11 -Wall -Wextra -Werror -pedantic -O2 -Icore/ffi/include \
  core/ffi/examples/live.c "$CARGO_TARGET_DIR/release/libsinew.a" \
  -lm -lpthread -ldl -o "$out/live"

for name in aim-procedural aim-ict s2d-ict; do
  "$out/replay" tests/data "$name" >"$out/$name.hashes"
  diff -u "tests/data/$name.hashes" "$out/$name.hashes"
  echo "$name: $(grep -vc '^#' "$out/$name.hashes") frames match tests/data/$name.hashes"
done

# A performance played on its actor, a sequence generated on its decoder: the lists' hash lines
# (their comments describe the files and are not compared).
for pair in "fit-ict aim-ict" "motion-ict s2d-ict"; do
  read -r name model <<<"$pair"
  "$out/replay" tests/data "$name" "$model" >"$out/$name.hashes"
  diff -u <(grep -v '^#' "tests/data/$name.hashes") <(grep -v '^#' "$out/$name.hashes")
  echo "$name on $model: $(grep -vc '^#' "$out/$name.hashes") lines match tests/data/$name.hashes"
done

# The live driver: the track and the filter its hash list names, every pose and frame hash.
"$out/drive" tests/data driver-ict aim-ict >"$out/driver-ict.hashes"
diff -u <(grep -v '^#' tests/data/driver-ict.hashes) "$out/driver-ict.hashes"
echo "driver-ict on aim-ict: $(grep -vc '^#' "$out/driver-ict.hashes") lines match tests/data/driver-ict.hashes"

# Live driving: the track and the settings its hash list names, every outcome, pose and frame.
"$out/live" tests/data driver-ict-live driver-ict aim-ict >"$out/driver-ict-live.hashes"
diff -u <(grep -v '^#' tests/data/driver-ict-live.hashes) "$out/driver-ict-live.hashes"
echo "driver-ict live on aim-ict: $(grep -vc '^#' "$out/driver-ict-live.hashes") lines match tests/data/driver-ict-live.hashes"
