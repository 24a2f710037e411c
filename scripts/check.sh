#!/usr/bin/env bash
# Sinew's whole test command: formatting, lints, the test suite and the no_std proof build.
# Safe to run on a fresh machine: it adds the Rust components and targets it needs.
set -euo pipefail
cd "$(dirname "$0")/.."

# Each step's heading says how far into the run it starts.
step() { echo "== $* (${SECONDS}s)"; }

rustup component add rustfmt clippy >/dev/null 2>&1 || true
rustup target add thumbv7em-none-eabihf wasm32-unknown-unknown >/dev/null

step "fmt"
cargo fmt --all --check
(cd core/fuzz && cargo fmt --check)
(cd host/fuzz && cargo fmt --check)

step "clippy"
# The ndarray backend is linted here (once), so its narrow deprecation allowance stays checked.
cargo clippy --workspace --all-targets --locked --features sinew-host/ndarray -- -D warnings

step "docs (rustdoc, warnings are errors)"
RUSTDOCFLAGS="-D warnings" cargo doc --no-deps --workspace --locked

step "no_std core for thumbv7em-none-eabihf"
cargo build -p sinew-core --target thumbv7em-none-eabihf --locked

step "gltfpack for the rig tests (npm, host/tests/gltfpack)"
if ! command -v npm >/dev/null; then
  apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq nodejs npm >/dev/null
fi
(cd host/tests/gltfpack && npm ci --no-audit --no-fund --silent)

step "tests"
cargo test --workspace --locked

# The steps below run the `sinew` binary that `cargo test --workspace` built. A `cargo build -p
# sinew-host` here would resolve features without the workspace's dev-dependencies and recompile
# burn and everything under it a second time.
sinew="$(cd "${CARGO_TARGET_DIR:-target}" && pwd)/debug/sinew"

step "glTF: the golden ICT actor and a rig actor exported, Khronos validator, and posed by three.js and Blender as sinew play poses them"
if ! command -v npm >/dev/null; then
  apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq nodejs npm >/dev/null
fi
gltf_dir=$(mktemp -d)
# Each export is checked against sinew play's frames of the same poses (host/tests/three/check.mjs):
# FRAMES GLB OBJ-UNIT TOLERANCE-MM per line (docs/ENGINES.md gives the tolerances).
three_checks=()
"$sinew" play --model tests/data/aim-ict.sinew \
  --poses host/tests/gltf/poses.json --out "$gltf_dir/poses" >/dev/null
"$sinew" export gltf --model tests/data/aim-ict.sinew --poses host/tests/gltf/poses.json \
  --names arkit --loop --out "$gltf_dir/poses.glb" >/dev/null
"$sinew" play --model tests/data/aim-ict.sinew \
  --arkit tests/data/arkit-sample.csv --out "$gltf_dir/arkit" >/dev/null 2>&1
"$sinew" export gltf --model tests/data/aim-ict.sinew \
  --arkit tests/data/arkit-sample.csv --bones --out "$gltf_dir/arkit.glb" >/dev/null 2>&1
# Every ARKit channel alone at 1, each shape with the jaw it learned (docs/ENGINES.md, "The jaw
# of a pose given by coefficients").
"$sinew" play --model tests/data/aim-ict.sinew \
  --arkit tests/data/arkit-each.csv --out "$gltf_dir/each" >/dev/null 2>&1
"$sinew" export gltf --model tests/data/aim-ict.sinew --arkit tests/data/arkit-each.csv \
  --names arkit --out "$gltf_dir/each.glb" >/dev/null 2>&1
# The same capture compressed for the web (--compress: EXT_meshopt_compression, lossless),
# decoded by three.js's own meshopt decoder.
"$sinew" export gltf --model tests/data/aim-ict.sinew \
  --arkit tests/data/arkit-sample.csv --compress --out "$gltf_dir/arkit-compressed.glb" >/dev/null 2>&1
glbs=("$gltf_dir/poses.glb" "$gltf_dir/arkit.glb" "$gltf_dir/each.glb" "$gltf_dir/arkit-compressed.glb")
three_checks+=("poses poses.glb 0.01 0.01" "arkit arkit.glb 0.01 0.01" "each each.glb 0.01 0.01"
  "arkit arkit-compressed.glb 0.01 0.01")
# A studio rig as `sinew data rig` writes it (morph targets, UVs split at a seam, a node transform),
# and an actor learned briefly from the same rig as an OBJ folder (texture coordinates per corner),
# exported in the rig's frame.
data="${SINEW_DATA:-../shared/data}"
kit="$data/ict-facekit"
if [ -d "$kit" ]; then
  "$sinew" data rig --data "$kit" --out "$gltf_dir/rig.glb" --scene --vertices 3000 >/dev/null
  "$sinew" data rig --data "$kit" --out "$gltf_dir/rig" --vertices 3000 >/dev/null
  "$sinew" train aim --rig "$gltf_dir/rig" --units cm --templates "$data" \
    --shapes jawOpen,mouthSmile_L,browInnerUp_L,browInnerUp_R --iterations 20 --quiet \
    --out "$gltf_dir/rig-actor.sinew" --report "$gltf_dir/rig-actor.json" >/dev/null
  "$sinew" play --model "$gltf_dir/rig-actor.sinew" \
    --poses host/tests/three/rig-poses.json --out "$gltf_dir/rig-actor" >/dev/null
  "$sinew" export gltf --model "$gltf_dir/rig-actor.sinew" --poses host/tests/three/rig-poses.json \
    --names arkit --loop --out "$gltf_dir/rig-actor.glb" >/dev/null
  # The sample capture opens the jaw, whose clamped weights and turned correctives the export
  # compensates.
  "$sinew" play --model "$gltf_dir/rig-actor.sinew" \
    --arkit tests/data/arkit-sample.csv --out "$gltf_dir/rig-arkit" >/dev/null 2>&1
  "$sinew" export gltf --model "$gltf_dir/rig-actor.sinew" --arkit tests/data/arkit-sample.csv \
    --out "$gltf_dir/rig-arkit.glb" >/dev/null 2>&1
  # A character: the sample rig with a textured eye mesh and lower teeth
  # (host/tests/three/character.mjs), an actor learned from it, and its export carrying the eyes,
  # material and texture, and the teeth on the jaw joint (--rig); three.js and Blender also check
  # that the carried meshes stand where the character has them.
  node host/tests/three/character.mjs "$gltf_dir/rig.glb" "$gltf_dir/character.glb"
  "$sinew" train aim --rig "$gltf_dir/character.glb" --templates "$data" \
    --shapes jawOpen,mouthSmile_L --iterations 20 --quiet \
    --out "$gltf_dir/character.sinew" --report "$gltf_dir/character.json" >/dev/null
  "$sinew" play --model "$gltf_dir/character.sinew" \
    --arkit tests/data/arkit-sample.csv --out "$gltf_dir/character" >/dev/null 2>&1
  "$sinew" export gltf --model "$gltf_dir/character.sinew" --rig "$gltf_dir/character.glb" \
    --arkit tests/data/arkit-sample.csv --out "$gltf_dir/character-export.glb" \
    2>/dev/null >"$gltf_dir/character-export.json"
  python3 -c 'import json, sys; s = json.load(open(sys.argv[1]))
assert s["carried_meshes"] == 2 and s["carried_on_jaw"] == ["teethLower"], s' "$gltf_dir/character-export.json"
  glbs+=("$gltf_dir/rig.glb" "$gltf_dir/rig-actor.glb" "$gltf_dir/rig-arkit.glb"
    "$gltf_dir/character-export.glb")
  three_checks+=("rig-actor rig-actor.glb 0.01 0.01" "rig-arkit rig-arkit.glb 0.01 0.01"
    "character character-export.glb 1 0.01 character.glb")
elif [ "${SINEW_REQUIRE_DATA:-}" = 1 ]; then
  echo "no ICT-FaceKit at $kit (SINEW_REQUIRE_DATA=1)" >&2
  exit 1
else
  echo "no ICT-FaceKit at $kit: the sample rig and the rig actor's glTF are not checked"
fi
(cd host/tests/gltf && npm ci --no-audit --no-fund --silent && node validate.mjs "${glbs[@]}")
(cd host/tests/three && npm ci --no-audit --no-fund --silent)
# Each check: frames, export, OBJ unit, tolerance and, for a character, the rig it carried from.
for check in "${three_checks[@]}"; do
  read -r frames glb unit tolerance original <<<"$check"
  node host/tests/three/check.mjs --frames "$gltf_dir/$frames" --glb "$gltf_dir/$glb" \
    --obj-unit "$unit" --tolerance-mm "$tolerance" ${original:+--original "$gltf_dir/$original"}
done
# Blender 5 as a Python module (PyPI bpy, pinned in host/tests/blender/requirements.txt: a 357 MiB
# wheel for CPython 3.11) poses the same exports through its own glTF importer, shape keys
# clamped to their sliders, as sinew play does (host/tests/blender/check.py). Blender has no
# meshopt decoder, so the compressed export is left out. SINEW_BPY_VENV names a venv to reuse.
if ! command -v python3.11 >/dev/null; then
  apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq python3.11 python3.11-venv >/dev/null
fi
bpy_venv="${SINEW_BPY_VENV:-$gltf_dir/bpy}"
[ -x "$bpy_venv/bin/python" ] || python3.11 -m venv "$bpy_venv"
"$bpy_venv/bin/pip" install --quiet --disable-pip-version-check -r host/tests/blender/requirements.txt
for check in "${three_checks[@]}"; do
  read -r frames glb unit tolerance original <<<"$check"
  case "$glb" in *compressed*) continue ;; esac
  "$bpy_venv/bin/python" host/tests/blender/check.py --frames "$gltf_dir/$frames" \
    --glb "$gltf_dir/$glb" --obj-unit "$unit" --tolerance-mm "$tolerance" \
    ${original:+--original "$gltf_dir/$original"} 2>&1 | grep -v '| INFO:'
done
rm -rf "$gltf_dir"

step "C API: the golden replays from C (core/ffi/examples/replay.c)"
if ! command -v cc >/dev/null; then
  apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq gcc >/dev/null
fi
bash core/ffi/run-example.sh

step "wasm package: build, then the golden replays through the JavaScript API (node)"
if ! command -v node >/dev/null; then
  apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends nodejs
fi
bash core/wasm/build.sh
node --test core/wasm/test/*.test.mjs

step "sinew view: the page in headless chromium plays the golden replay, performance, live driver and S2D track (host/tests/view/e2e.mjs), and drives the actor from a fake webcam through MediaPipe (webcam.mjs)"
for tool in chromium npm; do
  if ! command -v "$tool" >/dev/null; then
    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "$tool" >/dev/null
  fi
done
(cd host/tests/view && npm ci --no-audit --no-fund)
SINEW_BIN="$sinew" node host/tests/view/e2e.mjs
# The webcam page on a rendered performance as chromium's fake camera, MediaPipe Face Mesh (npm)
# tracking it in the page, the driven faces against the truth and against `sinew drive`.
SINEW_BIN="$sinew" node host/tests/view/webcam.mjs

step "firmware-sim: golden replays on Cortex-M4F, RISC-V (QEMU) and wasm (node)"
bash firmware-sim/run.sh

step "all checks passed"
