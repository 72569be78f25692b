"""image_compare.py: what the Python benchmarks share to compare images (imported by
rt_gpu_accuracy.py, noise_modes.py and docs/notebooks/thick_oracle.py): an EXR's RGB (or RGBA)
read by oiiotool, and the errors over RGB
(PSNR with the reference's largest value as the peak; relative RMSE = sqrt(sum d^2 / sum
ref^2))."""
import math
import re
import subprocess

import numpy as np


def exr(path, channels=3):
    out = subprocess.run(["oiiotool", "--dumpdata", path], capture_output=True, text=True,
                         check=True).stdout
    w, h, n = map(int, re.search(r":\s+(\d+) x\s+(\d+), (\d+) channel", out).groups())
    v = [line.split(":", 1)[1].split() for line in out.splitlines() if "Pixel (" in line]
    return np.array(v, dtype=np.float64).reshape(h, w, n)[:, :, :channels]


def errors(image, ref):
    se = float(np.sum((image - ref) ** 2))
    psnr = math.inf if se == 0 else 10 * math.log10(float(ref.max()) ** 2 / (se / ref.size))
    return psnr, math.sqrt(se / float(np.sum(ref ** 2)))
