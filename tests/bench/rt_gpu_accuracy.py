#!/usr/bin/python3
"""rt_gpu_accuracy.py: the accuracy of the GPU images that tests/bench/rt_gpu_run.sh wrote (PFM,
the 480x270 accuracy set), against the CPU renderer here.

usage: rt_gpu_accuracy.py NIMBUS GPU_PFM_DIR [SCRATCH]

References (`nimbus render`, the CPU `march`), 480x270, frame 1:
  - acc_m<m>_n<N>: the default scene, multiple scattering off, noise evaluated per sample, one
    sample per pixel, step schedule x m, N accumulated passes; reference: the same at m = 0.25,
    the mean of render.seed 1-4 (as tests/bench/rt_accumulate.sh);
  - acc_volume_m<m>_n<N>: the default scene as it ships (diffusion grid, baked noise) with
    render.shadow = "volume" and render.light_volume_cell = 0.234375 (the m = 1 plan's voxel,
    which the diffusion grid shares), one sample per pixel; reference: the same at m = 0.25,
    mean of 4 seeds;
  - cumulus_480x270, smoke1_480x270 and their _volume variants: the CPU image at equal settings;
  - rt_cumulus.0001.exr, rt_smoke1.0001.exr, rt_cumulus_rgba.0001.exr (`nimbus rt` itself,
    tests/bench/rt_gpu_nimbus.sh's machine): the CPU image at equal settings;
  - goal_<baked|rgba>_n<N>.0001.exr (`nimbus rt` itself: the light volume at step x1.5, N
    passes): the acc_volume reference, and the same reference with field.evaluation = "rgba".
Errors over RGB (ACEScg, the working space); PSNR with the reference's largest value as the
peak; relative RMSE = sqrt(sum d^2 / sum ref^2). Pixels of EXR files are read by oiiotool.
"""
import os
import subprocess
import sys
import tempfile

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from image_compare import errors, exr  # noqa: E402

NIMBUS, GPU = sys.argv[1], sys.argv[2]
SCRATCH = sys.argv[3] if len(sys.argv) > 3 else tempfile.mkdtemp()
HERE = os.path.dirname(os.path.abspath(__file__))
CUMULUS = os.path.join(HERE, "..", "..", "examples", "scenes", "cumulus.toml")
SMOKE1 = os.path.join(HERE, "..", "..", "examples", "scenes", "smoke1.toml")
SIZE = ["camera.width=480", "camera.height=270", 'output.preview=""']
MARCH_SET = ['render.multiple_scattering="none"', 'field.evaluation="direct"',
             "render.pixel_samples=1"]
VOLUME_SET = ['render.shadow="volume"', "render.pixel_samples=1",
              "render.light_volume_cell=0.234375"]


def steps(m):
    return [f"render.step={0.04 * m:.9g}", f"render.step_growth={0.004 * m:.9g}",
            f"render.shadow_step={0.05 * m:.9g}"]


def render(scene, name, sets):
    out = os.path.join(SCRATCH, name + ".####.exr")
    path = out.replace("####", "0001")
    if not os.path.exists(path):
        args = [NIMBUS, "render", scene, "--frames", "1", "-q", "-o", out]
        for s in SIZE + sets:
            args += ["--set", s]
        subprocess.run(args, check=True, stderr=subprocess.DEVNULL)
    return exr(path)


def pfm(path):
    with open(path, "rb") as f:
        assert f.readline().strip() == b"PF"
        w, h = map(int, f.readline().split())
        f.readline()
        a = np.frombuffer(f.read(), dtype="<f4").reshape(h, w, 3)[::-1]
    return a.astype(np.float64)


def mean_ref(name, scene, sets):
    return sum(render(scene, f"{name}_seed{s}", sets + [f"render.seed={s}"])
               for s in range(1, 5)) / 4.0


rows = []
refs = {"acc": mean_ref("ref_march", CUMULUS, MARCH_SET + steps(0.25)),
        "acc_volume": mean_ref("ref_volume", CUMULUS, VOLUME_SET + steps(0.25))}
print("| GPU image | reference | PSNR (dB) | relative RMSE |")
print("| --- | --- | --- | --- |")
for kind in ("acc", "acc_volume"):
    for m in (1, 1.5, 1.75, 2, 4):
        for n in (1, 4, 16):
            name = f"{kind}_m{m}_n{n}"
            p = os.path.join(GPU, name + ".pfm")
            if not os.path.exists(p):
                continue
            psnr, rel = errors(pfm(p), refs[kind])
            print(f"| {name} | CPU m = 0.25, 4 seeds | {psnr:.2f} | {rel:.4f} |")
equal = {"cumulus_480x270": (CUMULUS, []), "smoke1_480x270": (SMOKE1, []),
         "cumulus_volume_480x270": (CUMULUS, ['render.shadow="volume"']),
         "smoke1_volume_480x270": (SMOKE1, ['render.shadow="volume"'])}
for name, (scene, sets) in equal.items():
    p = os.path.join(GPU, name + ".pfm")
    if not os.path.exists(p):
        continue
    psnr, rel = errors(pfm(p), render(scene, "cpu_" + name, sets))
    print(f"| {name} | CPU, equal settings | {psnr:.2f} | {rel:.4f} |")
# `nimbus rt` itself on the GPU machine (tests/bench/rt_gpu_nimbus.sh's set: rt_<scene>.0001.exr,
# 480x270, frame 1, as the scene ships) against `nimbus render` here
for name, scene, sets in (("rt_cumulus", CUMULUS, []), ("rt_smoke1", SMOKE1, []),
                          ("rt_cumulus_rgba", CUMULUS, ['field.evaluation="rgba"'])):
    p = os.path.join(GPU, name + ".0001.exr")
    if not os.path.exists(p):
        continue
    psnr, rel = errors(exr(p), render(scene, "cpu_" + name[3:] + "_480x270", sets))
    print(f"| {name} (`nimbus rt` EXR) | CPU, equal settings | {psnr:.2f} | {rel:.4f} |")
# the goal configuration through `nimbus rt` itself (goal_<baked|rgba>_n<N>.0001.exr:
# 480x270, the light volume at step x1.5, N accumulated passes) against the converged CPU
# image of the scene (float tiles) and of the "rgba" field
goal_refs = {"baked": refs["acc_volume"],
             "rgba": mean_ref("ref_volume_rgba", CUMULUS,
                              VOLUME_SET + steps(0.25) + ['field.evaluation="rgba"'])}
for mode in ("baked", "rgba"):
    for n in (4, 16):
        p = os.path.join(GPU, f"goal_{mode}_n{n}.0001.exr")
        if not os.path.exists(p):
            continue
        image = exr(p)
        for ref_mode, ref in goal_refs.items():
            psnr, rel = errors(image, ref)
            print(f"| goal_{mode}_n{n} (`nimbus rt` EXR) | CPU m = 0.25, 4 seeds, {ref_mode} | "
                  f"{psnr:.2f} | {rel:.4f} |")
# what the light volume changes against the shadow marches (CPU only, equal settings)
for name in ("cumulus", "smoke1"):
    a = render(CUMULUS if name == "cumulus" else SMOKE1, f"cpu_{name}_volume_480x270",
               ['render.shadow="volume"'])
    b = render(CUMULUS if name == "cumulus" else SMOKE1, f"cpu_{name}_480x270", [])
    psnr, rel = errors(a, b)
    print(f"| (CPU {name}, shadow volume) | CPU {name}, shadow marches | {psnr:.2f} | {rel:.4f} |")
