#!/usr/bin/python3
"""noise_modes.py: the cumulus noise evaluated per sample ("direct"), read from baked float tiles
("baked") and from baked RGBA8 tiles in Olajos' channel layout ("rgba"): error against run time,
on the CPU (`nimbus render`) and on the GPU path (`nimbus rt`), runs interleaved.

usage: noise_modes.py NIMBUS [WIDTHxHEIGHT] [ROUNDS] [FRAME]

The default scene with multiple scattering off (the noise is the only thing that differs),
frame FRAME (default 1), WIDTHxHEIGHT (default 320x180), ROUNDS rounds (default 3) of
direct, baked, rgba for each renderer. Error: each mode's image against the "direct" image of
the same renderer (the same step, jitter and seed: the difference is the field's), over RGB in
the working space (ACEScg); PSNR with the reference's largest value as the peak; relative
RMSE = sqrt(sum d^2 / sum ref^2). Parity: `nimbus rt`'s image against `nimbus render`'s in the
same mode. Times: `nimbus render`'s bake and march seconds of the frame (its stderr line); the
march on the GPU's clock as `nimbus rt` prints it (its shader compile, context and the CPU's
bake apart). Medians over the rounds, min-max in brackets. Pixels read by oiiotool.
"""
import os
import re
import statistics
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from image_compare import errors, exr  # noqa: E402

NIMBUS = sys.argv[1]
W, H = (sys.argv[2] if len(sys.argv) > 2 else "320x180").split("x")
ROUNDS = int(sys.argv[3]) if len(sys.argv) > 3 else 3
FRAME = sys.argv[4] if len(sys.argv) > 4 else "1"
HERE = os.path.dirname(os.path.abspath(__file__))
SCENE = os.path.join(HERE, "..", "..", "examples", "scenes", "cumulus.toml")
SCRATCH = tempfile.mkdtemp()
MODES = ("direct", "baked", "rgba")
SETS = [f"camera.width={W}", f"camera.height={H}", 'render.multiple_scattering="none"',
        'output.preview=""']


def run(command, mode):
    out = os.path.join(SCRATCH, f"{command}_{mode}.####.exr")
    args = [NIMBUS, command, SCENE, "--frames", FRAME, "-o", out]
    for s in SETS + [f'field.evaluation="{mode}"']:
        args += ["--set", s]
    p = subprocess.run(args, capture_output=True, text=True, check=True)
    text = p.stdout + p.stderr
    if command == "render":
        m = re.search(r"bake ([0-9.]+) s, majorant [0-9.]+ s.*?march ([0-9.]+) s", text)
        times = (float(m.group(1)), float(m.group(2)))
    else:
        m = re.search(r"the march ([0-9.]+) ms on its clock", text)
        times = (float(m.group(1)) / 1e3,)
    return times, out.replace("####", f"{int(FRAME):04d}")


times = {(c, m): [] for c in ("render", "rt") for m in MODES}
files = {}
for r in range(ROUNDS):
    for command in ("render", "rt"):
        for mode in MODES:
            t, f = run(command, mode)
            times[(command, mode)].append(t)
            files[(command, mode)] = f


def med(xs, scale=1.0):
    xs = [scale * x for x in xs]
    return f"{statistics.median(xs):.3f} [{min(xs):.3f}-{max(xs):.3f}]"


images = {k: exr(f) for k, f in files.items()}
print(f"default scene, frame {FRAME}, {W}x{H}, multiple scattering off, {ROUNDS} rounds")
print()
print("| mode | CPU bake (s) | CPU march (s) | CPU: against direct, PSNR (dB) / rel. RMSE | "
      "GPU march (s, its clock) | GPU: against its direct | GPU against CPU, same mode |")
print("| --- | --- | --- | --- | --- | --- | --- |")
for mode in MODES:
    cpu = times[("render", mode)]
    gpu = times[("rt", mode)]
    pc, rc = errors(images[("render", mode)], images[("render", "direct")])
    pg, rg = errors(images[("rt", mode)], images[("rt", "direct")])
    pp, rp = errors(images[("rt", mode)], images[("render", mode)])
    print(f"| {mode} | {med([t[0] for t in cpu])} | {med([t[1] for t in cpu])} | "
          f"{pc:.2f} / {rc:.4f} | {med([t[0] for t in gpu])} | {pg:.2f} / {rg:.4f} | "
          f"{pp:.2f} / {rp:.4f} |")
