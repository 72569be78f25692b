#!/usr/bin/env python3
"""Interleaved overhead of one `nimbus` build against another (docs/farm_cli.md): the same
frames of examples/scenes/cumulus.toml rendered alternately by OLD and NEW (old/new, then
new/old, ...), per run the wall time, the child's CPU time (user + sys, getrusage) and the sum
of the `frame N: X s` render times it logs; prints medians and the paired differences.

usage: cli_overhead.py OLD_NIMBUS NEW_NIMBUS ROUNDS WIDTH HEIGHT FRAMES THREADS
       cli_overhead.py OLD_NIMBUS NEW_NIMBUS ROUNDS --startup   (--explain and --version)
"""
import os
import re
import resource
import shutil
import statistics as st
import subprocess
import sys
import tempfile
import time

SCENE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "examples",
                     "scenes", "cumulus.toml")


def measure(binaries, rounds, args_for):
    res = {"old": [], "new": []}
    for i in range(rounds):
        for which in (("old", "new") if i % 2 == 0 else ("new", "old")):
            out = tempfile.mkdtemp(prefix="nimbus_overhead_")
            c0 = resource.getrusage(resource.RUSAGE_CHILDREN)
            t0 = time.monotonic()
            p = subprocess.run([binaries[which]] + args_for(out), stdout=subprocess.DEVNULL,
                               stderr=subprocess.PIPE)
            t1 = time.monotonic()
            c1 = resource.getrusage(resource.RUSAGE_CHILDREN)
            shutil.rmtree(out, ignore_errors=True)
            if p.returncode != 0:
                sys.exit("%s failed: %s" % (which, p.stderr.decode()))
            cpu = (c1.ru_utime - c0.ru_utime) + (c1.ru_stime - c0.ru_stime)
            rend = sum(float(x) for x in
                       re.findall(r"^frame \d+: ([0-9.]+) s", p.stderr.decode(), re.M))
            res[which].append((t1 - t0, cpu, rend))
    return res


def report(label, res, names):
    for k, name in enumerate(names):
        o = [r[k] for r in res["old"]]
        n = [r[k] for r in res["new"]]
        d = [b[k] - a[k] for a, b in zip(res["old"], res["new"])]
        se = st.stdev(d) / len(d) ** 0.5 if len(d) > 1 else float("nan")
        print("%s %-6s old median %.4f s | new median %.4f s | new/old %.4f | paired new-old "
              "%+.1f ms +- %.1f (s.e., n=%d)" % (label, name, st.median(o), st.median(n),
                                                st.median(n) / st.median(o), st.mean(d) * 1e3,
                                                se * 1e3, len(d)))


def main():
    if len(sys.argv) < 5:
        sys.exit(__doc__)
    binaries = {"old": sys.argv[1], "new": sys.argv[2]}
    rounds = int(sys.argv[3])
    if sys.argv[4] == "--startup":
        res = measure(binaries, rounds, lambda out: ["render", SCENE, "--frames", "1-3",
                                                     "--explain"])
        report("explain", res, ("wall", "cpu"))
        res = measure(binaries, rounds, lambda out: ["--version"])
        report("version", res, ("wall", "cpu"))
        return
    w, h, frames, threads = sys.argv[4:8]
    res = measure(binaries, rounds, lambda out: [
        "render", SCENE, "--frames", frames, "--set", "camera.width=" + w, "--set",
        "camera.height=" + h, "--threads", threads, "-o", out + "/f.####.exr",
        "--progress", "none"])
    report("%sx%s frames %s threads %s" % (w, h, frames, threads), res,
           ("wall", "cpu", "render"))


main()
