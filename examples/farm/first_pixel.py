#!/usr/bin/env python3
"""Time to first pixel of farm tasks, with and without chunking (docs/farm.md).

Runs FRAMES frames of a scene as farm tasks would, one process per task, one after the other:
once as tasks of one frame and once as tasks of CHUNK frames. For each task it reads
`nimbus render --progress plain` as it runs and records when the first tile of its first frame
was done (the scene, its VDB grids and the per-sequence noise bake are loaded by then) and when
the task ended. Prints per-task means and the totals.

    first_pixel.py NIMBUS SCENE FRAMES CHUNK OUTDIR [nimbus render options...]
"""
import os
import re
import statistics
import subprocess
import sys
import time


def run_task(nimbus, scene, first, last, outdir, extra):
    cmd = [nimbus, "render", scene, "--frames", f"{first}-{last}", "--progress", "plain",
           "-o", os.path.join(outdir, "f.####.exr")] + extra
    start = time.monotonic()
    first_pixel = None
    proc = subprocess.Popen(cmd, stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True)
    for line in proc.stderr:
        # "frame 1/3 10% (frame 4)": the first progress past 0% is the first finished tile
        m = re.match(r"frame \d+/\d+ (\d+)%", line)
        if first_pixel is None and m and int(m.group(1)) > 0:
            first_pixel = time.monotonic() - start
    rc = proc.wait()
    if rc != 0:
        sys.exit(f"first_pixel.py: {' '.join(cmd)} exited {rc}")
    return first_pixel, time.monotonic() - start


def main():
    if len(sys.argv) < 6:
        sys.exit(__doc__)
    nimbus, scene, frames, chunk, outdir = sys.argv[1:6]
    extra = sys.argv[6:]
    frames, chunk = int(frames), int(chunk)
    for size in (1, chunk):
        d = os.path.join(outdir, f"chunk{size}")
        os.makedirs(d, exist_ok=True)
        firsts, walls = [], []
        for f in range(1, frames + 1, size):
            fp, wall = run_task(nimbus, scene, f, min(f + size - 1, frames), d, extra)
            firsts.append(fp)
            walls.append(wall)
        print(f"{len(walls)} tasks of {size} frame(s): first pixel {statistics.mean(firsts):.2f} s "
              f"per task (min {min(firsts):.2f}, max {max(firsts):.2f}), task {statistics.mean(walls):.2f} s, "
              f"all tasks {sum(walls):.1f} s, {sum(walls) / frames:.2f} s per frame")


if __name__ == "__main__":
    main()
