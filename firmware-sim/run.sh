#!/usr/bin/env bash
# Proves on emulated targets that sinew-core plays the golden AIM actors, the golden S2D decoder, the
# golden fitted performance and the golden generated sequence back bit-identically to the x86_64
# host: installs what is missing, then for each crate checks formatting, runs clippy with warnings
# as errors, builds in release and runs the replays, and checks that neither microcontroller image
# links core's float formatting. Exits non-zero if any target fails.
#
# Usage: bash firmware-sim/run.sh   (from anywhere)
# Environment: CARGO_TARGET_DIR (default firmware-sim/target, shared by the four crates so that
# host-side build scripts and proc macros are compiled once).
set -uo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$here/target}"
# The machine is shared: build at low priority.
export CARGO_BUILD_JOBS="${CARGO_BUILD_JOBS:-2}"
NICE=(nice -n 10)
start_all=$SECONDS

say() { printf '\n== %s\n' "$*"; }

# --- install what is missing -------------------------------------------------------------------
as_root() {
  if [ "$(id -u)" -eq 0 ]; then "$@"; else sudo "$@"; fi
}

install_tools() {
  local targets=(thumbv7em-none-eabihf riscv32imac-unknown-none-elf wasm32-unknown-unknown)
  local installed missing=()
  installed="$(rustup target list --installed)" || return 1
  for t in "${targets[@]}"; do
    grep -qx "$t" <<<"$installed" || missing+=("$t")
  done
  if [ "${#missing[@]}" -gt 0 ]; then
    say "rustup target add ${missing[*]}"
    rustup target add "${missing[@]}" || return 1
  fi
  local components
  components="$(rustup component list --installed)" || return 1
  for c in rustfmt clippy; do
    grep -q "^$c" <<<"$components" || rustup component add "$c" || return 1
  done

  local pkgs=()
  command -v qemu-system-arm >/dev/null || pkgs+=(qemu-system-arm)
  command -v qemu-system-riscv32 >/dev/null || pkgs+=(qemu-system-misc)
  command -v node >/dev/null || pkgs+=(nodejs)
  command -v readelf >/dev/null || pkgs+=(binutils)
  if [ "${#pkgs[@]}" -gt 0 ]; then
    say "apt-get install ${pkgs[*]}"
    as_root apt-get update -qq || return 1
    DEBIAN_FRONTEND=noninteractive as_root apt-get install -y --no-install-recommends "${pkgs[@]}" \
      || return 1
  fi
}

# --- per-crate checks --------------------------------------------------------------------------
results=()
failed=0

# check NAME DIR RUN...: fmt, clippy, release build, then RUN (a command run in DIR).
check() {
  local name="$1" dir="$2"
  shift 2
  local t0=$SECONDS status=PASS step
  say "$name ($dir)"
  for step in fmt clippy build run; do
    case "$step" in
      fmt) (cd "$here/$dir" && cargo fmt --check) ;;
      clippy) (cd "$here/$dir" && "${NICE[@]}" cargo clippy --locked --all-targets -- -D warnings) ;;
      build) (cd "$here/$dir" && "${NICE[@]}" cargo build --locked --release) ;;
      run) (cd "$here/$dir" && "$@") ;;
    esac
    if [ $? -ne 0 ]; then
      status="FAIL ($step)"
      break
    fi
  done
  results+=("$(printf '%-10s %-32s %s, %ds' "$name" "$dir" "$status" $((SECONDS - t0)))")
  [ "$status" = PASS ] || failed=1
}

# no_float_printer NAME ELF: fails when the image links core's float formatting (`core::fmt::float`,
# some 19 KiB of code on the Cortex-M4F): the core writes its numbers with integers so that no
# firmware carries it, and a `{}` of an f32 anywhere on the playback path would bring it back.
no_float_printer() {
  local name="$1" elf="$2" t0=$SECONDS status=PASS found
  say "$name: no float formatting linked ($elf)"
  if ! found="$(readelf -s -W "$elf")"; then
    status="FAIL (readelf)"
  elif ! grep -q '10sinew_core' <<<"$found"; then
    # A stripped image would pass for want of symbols.
    status="FAIL (no sinew_core symbols to check)"
  else
    found="$(grep -c '4core3fmt5float' <<<"$found")"
    if [ "$found" -ne 0 ]; then
      echo "$elf links core::fmt::float ($found symbols): an f32 or f64 is formatted on the playback path" >&2
      status="FAIL ($found float-formatting symbols)"
    fi
  fi
  results+=("$(printf '%-10s %-32s %s, %ds' "$name" "float formatting" "$status" $((SECONDS - t0)))")
  [ "$status" = PASS ] || failed=1
}

if ! install_tools; then
  echo "firmware-sim: could not install the targets or emulators" >&2
  exit 1
fi

# x86_64: the firmware code path (common's duplicated pose sequence) against the pinned hashes.
check host common "${NICE[@]}" cargo test
# Cortex-M4F, hardware f32, under QEMU mps2-an386 (the runner is in cortex-m/.cargo/config.toml).
check cortex-m cortex-m "${NICE[@]}" cargo run --release
# rv32imac, software f32, under QEMU virt.
check riscv riscv "${NICE[@]}" cargo run --release
no_float_printer cortex-m "$CARGO_TARGET_DIR/thumbv7em-none-eabihf/release/sinew-firmware-sim"
no_float_printer riscv "$CARGO_TARGET_DIR/riscv32imac-unknown-none-elf/release/sinew-firmware-sim-riscv"
# wasm32 under node.
check wasm wasm node run.mjs "$CARGO_TARGET_DIR/wasm32-unknown-unknown/release/sinew_firmware_wasm.wasm"

say "summary"
printf '%s\n' "${results[@]}"
echo "total $((SECONDS - start_all))s"
if [ "$failed" -ne 0 ]; then
  echo "firmware-sim: FAILED" >&2
  exit 1
fi
echo "firmware-sim: every target bit-identical to the host"
