#!/usr/bin/env python3
"""Measures sinew-core playback on the emulated microcontrollers and writes the tables into
docs/BENCHMARKS.md (between the `firmware-costs` markers).

Runs the Cortex-M4F and RISC-V firmware under QEMU with `-icount shift=0` (instruction counts
repeat exactly), reads the per-phase costs they print for one frame of each golden actor, of
the S2D decoder and of the generated sequence (its curve, one frame), the per-frame totals of
every golden replay, the Cortex-M stack high-water mark, and the flash and RAM footprint of the Cortex-M image from its ELF section headers (readelf).

Usage: python3 scripts/firmware_costs.py [--check]
  --check  fail instead of rewriting when docs/BENCHMARKS.md differs from the measurement.
Needs what firmware-sim/run.sh installs (run that once first on a fresh machine).
"""

import os
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
FW = ROOT / "firmware-sim"
TARGET = Path(os.environ.get("CARGO_TARGET_DIR", FW / "target"))
DOC = ROOT / "docs" / "BENCHMARKS.md"
START, END = "<!-- firmware-costs:start -->", "<!-- firmware-costs:end -->"

COST = re.compile(r"^cost (\S+) frame (\d+) \(instructions\): (.*)$")
S2D_COST = re.compile(r"^s2d cost (\S+) frame (\d+) \(instructions\): (.*)$")
HEADER = re.compile(r"^sinew-firmware-sim(?:-riscv)?: [^,]+, (\S+): (\d+) vertices, (\d+) shapes")
S2D_HEADER = re.compile(
    r"^sinew-firmware-sim(?:-riscv)?: [^,]+, (\S+): (\d+) vertices, (\d+) inputs, \d+ frames, (\d+) buffer values"
)
FRAME = re.compile(r"^frame +\d+ [0-9a-f]{16} ok +~?(\d+) instructions")
MOTION_COST = re.compile(r"^motion cost (\S+) frame (\d+) \(instructions\): (.*)$")
MOTION_HEADER = re.compile(
    r"^sinew-firmware-sim(?:-riscv)?: [^,]+, (\S+): (\d+) vertices, (\d+) landmarks, \d+ frames, (\d+) buffer values"
)
# The firmware's shared frame arena (firmware-sim/common/src/lib.rs, `ARENA`), in f32 values.
ARENA = 6 * 5120 + 2560
DRIVER_COST = re.compile(r"^driver cost (\S+) frame (\d+) \(instructions\): (.*)$")
DRIVER_HEADER = re.compile(
    r"^sinew-firmware-sim(?:-riscv)?: [^,]+, (\S+): (\d+) vertices, (\d+) shapes, (\d+) landmarks, (\d+) frames"
)
LIVE_COST = re.compile(r"^live cost (\S+) frame (\d+) \(instructions\): (.*)$")
LIVE_HEADER = re.compile(
    r"^sinew-firmware-sim(?:-riscv)?: [^,]+, (\S+): (\d+) vertices, (\d+) shapes, (\d+) frames, calibrating on (\d+)"
)
STACK = re.compile(r"^stack high-water (\d+) bytes")


def run(crate: str) -> str:
    env = dict(os.environ, CARGO_TARGET_DIR=str(TARGET))
    out = subprocess.run(
        ["cargo", "run", "--quiet", "--locked", "--release"],
        cwd=FW / crate,
        env=env,
        capture_output=True,
        text=True,
    )
    if out.returncode != 0:
        sys.exit(f"firmware_costs: {crate} failed (exit {out.returncode}):\n{out.stdout}\n{out.stderr}")
    return out.stdout


def parse(text: str):
    costs, frames, sizes, stack = {}, {}, {}, None
    current = None
    for line in text.splitlines():
        if m := LIVE_HEADER.match(line):
            # Three checks a row (outcome, pose, frame): the step's cost is measured apart
            # (live_costs), and its checks are kept out of the whole-frame table.
            current = "live:" + m.group(1)
            sizes[current] = (int(m.group(2)), int(m.group(3)), int(m.group(4)), int(m.group(5)))
            frames[current] = []
        elif m := LIVE_COST.match(line):
            costs["live:" + m.group(1).rsplit(".", 1)[0]] = dict(
                kv.split("=") for kv in m.group(3).split()
            )
        elif m := DRIVER_HEADER.match(line):
            # Four checks a row of two kinds: its phases are measured apart (driver_costs), and
            # its checks are kept out of the whole-frame table.
            current = "driver:" + m.group(1)
            sizes[current] = (int(m.group(2)), int(m.group(3)), int(m.group(4)), int(m.group(5)))
            frames[current] = []
        elif m := DRIVER_COST.match(line):
            costs["driver:" + m.group(1).rsplit(".", 1)[0]] = dict(
                kv.split("=") for kv in m.group(3).split()
            )
        elif m := S2D_HEADER.match(line):
            current = m.group(1)
            sizes[current] = (int(m.group(2)), int(m.group(3)), int(m.group(4)))
            frames[current] = []
        elif m := MOTION_HEADER.match(line):
            current = m.group(1)
            sizes[current] = ("motion", int(m.group(2)), int(m.group(3)), int(m.group(4)))
            frames[current] = []
        elif m := MOTION_COST.match(line):
            costs["motion:" + m.group(1).rsplit(".", 1)[0]] = dict(
                kv.split("=") for kv in m.group(3).split()
            )
        elif m := S2D_COST.match(line):
            costs["s2d:" + m.group(1).rsplit(".", 1)[0]] = dict(
                kv.split("=") for kv in m.group(3).split()
            )
        elif m := HEADER.match(line):
            current = m.group(1)
            sizes[current] = (int(m.group(2)), int(m.group(3)))
            frames[current] = []
        elif m := FRAME.match(line):
            frames[current].append(int(m.group(1)))
        elif m := COST.match(line):
            costs[m.group(1).rsplit(".", 1)[0]] = dict(
                kv.split("=") for kv in m.group(3).split()
            )
        elif m := STACK.match(line):
            stack = int(m.group(1))
    return costs, frames, sizes, stack


def footprint(elf: Path):
    out = subprocess.run(["readelf", "-S", "-W", str(elf)], capture_output=True, text=True, check=True)
    sec = {}
    for line in out.stdout.splitlines():
        m = re.match(r"^\s*\[\s*\d+\]\s+(\S+)\s+\S+\s+[0-9a-f]+\s+[0-9a-f]+\s+([0-9a-f]+)", line)
        if m:
            sec[m.group(1)] = int(m.group(2), 16)
    flash = sum(sec.get(s, 0) for s in (".vector_table", ".text", ".rodata", ".data"))
    ram = sum(sec.get(s, 0) for s in (".data", ".bss", ".uninit"))
    return sec, flash, ram


def kib(n: int) -> str:
    return f"{n / 1024:,.1f} KiB"


def mil(n: float) -> str:
    return f"{n / 1e6:.2f} M"


def main() -> None:
    check = "--check" in sys.argv[1:]
    arm = run("cortex-m")
    rv = run("riscv")
    arm_costs, arm_frames, sizes, stack = parse(arm)
    rv_costs, rv_frames, _, _ = parse(rv)
    s2d_values = max((s[2] for s in sizes.values() if len(s) == 3), default=0)
    motion_values = max((s[3] for s in sizes.values() if len(s) == 4 and s[0] == "motion"), default=0)
    sec, flash, ram = footprint(TARGET / "thumbv7em-none-eabihf/release/sinew-firmware-sim")
    lines = [START, ""]
    lines += [
        "Per-phase cost of frame 8 of the golden sequence, in instructions (Cortex-M4F: SysTick",
        "ticks × 40 under `-icount shift=0`, resolution 40; RISC-V: `minstret`, exact):",
        "",
        "| actor | phase | Cortex-M4F (FPU) | RISC-V rv32imac (soft float) |",
        "|---|---|---|---|",
    ]
    names = {
        "pose_f32": "pose, f32 (eq. 17: jaw LBS + correctives + head)",
        "pose_q16": "pose, Q16.16",
        "normals_f32": "vertex normals, f32 (libm)",
        "normals_fast": "vertex normals, fast (micromath)",
        "hash": "frame hash (replay check only)",
    }
    for actor in (a for a in arm_costs if ":" not in a):
        v, m = sizes[f"{actor}.f32"]
        for key, label in names.items():
            lines.append(
                f"| {actor} ({v:,} vertices, {m} correctives) | {label} | "
                f"{mil(int(arm_costs[actor][key]))} | {mil(int(rv_costs[actor][key]))} |"
            )
    s2d_names = {
        "decode": "decode (FC, up-samplings, spiral convolutions, + neutral)",
        "hash": "frame hash (replay check only)",
    }
    for key in (a for a in arm_costs if a.startswith("s2d:")):
        decoder = key.removeprefix("s2d:")
        v, i, _ = sizes[f"{decoder}.f32"]
        for phase, label in s2d_names.items():
            lines.append(
                f"| {decoder} (S2D decoder, {v:,} vertices, {i} inputs) | {label} | "
                f"{mil(int(arm_costs[key][phase]))} | {mil(int(rv_costs[key][phase]))} |"
            )
    motion_names = {
        "curve": "landmark curve, once per sequence (noise, generator MLP, exp map, eq. 5 decoding)",
        "decode": "decode one frame (decoder input from the curve, S2D-Dec, + template neutral)",
        "hash": "frame hash (replay check only)",
    }
    for key in (a for a in arm_costs if a.startswith("motion:")):
        name = key.removeprefix("motion:")
        _, v, k, _ = sizes[f"{name}.f32"]
        for phase, label in motion_names.items():
            lines.append(
                f"| {name} (generated sequence, {k} landmarks → {v:,} vertices) | {label} | "
                f"{mil(int(arm_costs[key][phase]))} | {mil(int(rv_costs[key][phase]))} |"
            )
    driver_names = {
        "drive": "one driver evaluation: pixels through the camera, features, MLP, pose made whole",
        "filter": "One Euro filter step on the pose (optional)",
        "pose": "pose the actor with it, f32 (eq. 17)",
        "normals": "vertex normals, f32 (libm)",
        "hash": "frame hash (golden check only)",
    }
    for key in (a for a in arm_costs if a.startswith("driver:")):
        name = key.removeprefix("driver:")
        v, m, k, _ = sizes[f"driver:{name}.f32"]
        for phase, label in driver_names.items():
            lines.append(
                f"| {name} (live driver, {k} landmarks → {v:,} vertices, {m} correctives) | {label} | "
                f"{mil(int(arm_costs[key][phase]))} | {mil(int(rv_costs[key][phase]))} |"
            )
    live_names = {
        "calibrate": "one calibration step: the driver on the raw landmarks, the head on the steady landmarks, the offsets taken in",
        "step": "one live step after the calibration: the driver twice (raw, then calibrated), the head, the offsets taken off, the residual, the jump check",
    }
    for key in (a for a in arm_costs if a.startswith("live:")):
        name = key.removeprefix("live:")
        v, m, _, n = sizes[f"live:{name}.f32"]
        for phase, label in live_names.items():
            lines.append(
                f"| {name} (live track, calibrating on {n} frames; {v:,} vertices, {m} correctives) | {label} | "
                f"{mil(int(arm_costs[key][phase]))} | {mil(int(rv_costs[key][phase]))} |"
            )
    lines += [
        "",
        "Whole frames as the replays run them (f32 and fast: pose + normals + hash; q16: pose +",
        "hash; S2D: decode + hash; fit-ict, the golden fitted performance: F_W at every vertex +",
        "pose + normals + hash; motion-ict, the golden generated sequence: decoder input + decode +",
        "hash, its curve generated before the first frame), mean over each replay's frames (16;",
        "fit-ict 4; motion-ict 30):",
        "",
        "| replay | Cortex-M4F | RISC-V |",
        "|---|---|---|",
    ]
    for name in (n for n in arm_frames if not n.startswith(("driver:", "live:"))):
        a, r = arm_frames[name], rv_frames.get(name, [])
        lines.append(f"| {name} | {mil(sum(a) / len(a))} | {mil(sum(r) / len(r))} |")
    lines += [
        "",
        "Cortex-M4F image (`firmware-sim/cortex-m`, release; both golden actors in flash, the ICT one",
        "with its Q16.16 cache, the golden S2D decoder, the golden motion generator and the golden",
        "landmark driver with its track and its live track; the S2D replay",
        f"decodes in the shared frame arena, {s2d_values:,} of its {ARENA:,} values, the generated",
        f"sequence uses {motion_values:,} of them):",
        "",
        "| | bytes |",
        "|---|---|",
        f"| flash: .vector_table + .text + .rodata + .data | {flash:,} ({kib(flash)}) |",
        f"| of which code (.text) | {sec.get('.text', 0):,} ({kib(sec.get('.text', 0))}) |",
        f"| RAM: .data + .bss (frame arena, Q16.16 buffers for 5,120 vertices, kernel-suite buffers) | {ram:,} ({kib(ram)}) |",
        f"| stack high-water mark | {stack:,} ({kib(stack)}) |",
        f"| RAM in all | {ram + stack:,} ({kib(ram + stack)}) |",
        "",
        END,
    ]
    block = "\n".join(lines)
    doc = DOC.read_text()
    if START not in doc or END not in doc:
        sys.exit(f"firmware_costs: {DOC} lacks the {START} … {END} markers")
    new = doc[: doc.index(START)] + block + doc[doc.index(END) + len(END):]
    if check:
        if new != doc:
            sys.exit("firmware_costs: docs/BENCHMARKS.md differs from this measurement")
        print("firmware_costs: docs/BENCHMARKS.md matches")
        return
    DOC.write_text(new)
    print(block)


if __name__ == "__main__":
    main()
