#!/usr/bin/env python3
"""`nimbus render --progress json` (docs/farm_cli.md): every line the command writes to stderr
parses as one JSON object with the documented fields, for a sequence, a --resume run and an
error. Usage: farm_json_check.py <nimbus> <scratch dir>."""
import json
import os
import shutil
import subprocess
import sys

NIMBUS, SCRATCH = sys.argv[1], sys.argv[2]

# the fields each event must carry, with their types (docs/farm_cli.md)
NUM = (int, float)
FIELDS = {
    "frame_start": {"frame": int, "index": int, "frames": int, "output": str},
    "progress": {"frame": int, "index": int, "frames": int, "percent": int,
                 "overall_percent": int, "elapsed": NUM},
    "frame_done": {"frame": int, "output": str, "seconds": NUM, "peak_rss_mb": NUM,
                   "lookups": NUM},
    "frame_skipped": {"frame": int, "output": str, "reason": str},
    "frame_rerender": {"frame": int, "output": str, "reason": str},
    "warning": {"message": str},
    "note": {"message": str},
    "error": {"exit_code": int, "status": str, "message": str},
    "done": {"frames_rendered": int, "frames_skipped": int, "seconds": NUM, "peak_rss_mb": NUM},
}

failures = []


def check(cond, what):
    if not cond:
        failures.append(what)


def run(args):
    """Runs nimbus; returns (exit code, events); every stderr line must be a JSON object."""
    p = subprocess.run([NIMBUS] + args, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    events = []
    for line in p.stderr.decode("utf-8").splitlines():
        try:
            ev = json.loads(line)
        except ValueError as e:
            failures.append("not JSON: %r (%s)" % (line, e))
            continue
        if not isinstance(ev, dict) or ev.get("event") not in FIELDS:
            failures.append("not a documented event: %r" % line)
            continue
        for key, typ in FIELDS[ev["event"]].items():
            check(key in ev and isinstance(ev[key], typ) and not isinstance(ev[key], bool),
                  "%s: field %s missing or not %s: %r" % (ev["event"], key, typ, line))
        events.append(ev)
    return p.returncode, events


shutil.rmtree(SCRATCH, ignore_errors=True)
os.makedirs(SCRATCH)
scene = os.path.join(SCRATCH, "s.toml")
out = os.path.join(SCRATCH, "f.####.exr")
src = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "examples", "scenes",
                   "cumulus.toml")
shutil.copy(src, scene)
# tiny frames and a coarse light-volume grid (voxel 0.5 instead of 0.117: at 32x18 the grid is
# nearly all of a frame's time); the events are what is checked
small = ["--set", "camera.width=32", "--set", "camera.height=18",
         "--set", "render.light_volume_cell=0.5", "-o", out]

# a sequence of two frames
rc, ev = run(["render", scene, "--frames", "1-2", "--progress", "json"] + small)
check(rc == 0, "render exit %d" % rc)
kinds = [e["event"] for e in ev]
check(kinds.count("frame_start") == 2 and kinds.count("frame_done") == 2,
      "two frame_start and two frame_done: %s" % kinds)
check(kinds[-1] == "done" and ev[-1]["frames_rendered"] == 2, "ends with done: %s" % kinds)
for e in ev:
    if e["event"] == "frame_done":
        check(os.path.exists(e["output"]), "frame_done output exists: %s" % e["output"])
        check(e["seconds"] > 0 and e["peak_rss_mb"] > 1, "positive time and memory: %r" % e)
    if e["event"] == "progress":
        check(0 <= e["percent"] <= 100, "percent in [0, 100]: %r" % e)
check(any(e["event"] == "progress" and e["percent"] == 100 for e in ev), "a 100% progress line")
# frame_start comes before its progress and frame_done
first = [e for e in ev if e.get("frame") == 1]
check(first and first[0]["event"] == "frame_start", "frame 1 starts with frame_start")

# --resume: both skipped; after an edit of the scene, both rendered again, saying why
rc, ev = run(["render", scene, "--frames", "1-2", "--progress", "json", "--resume"] + small)
check(rc == 0 and [e["event"] for e in ev].count("frame_skipped") == 2,
      "resume skips both: %r" % ev)
with open(scene, "a") as f:
    f.write("\n# an edit\n")
rc, ev = run(["render", scene, "--frames", "1-2", "--progress", "json", "--resume"] + small)
re = [e for e in ev if e["event"] == "frame_rerender"]
check(rc == 0 and len(re) == 2, "edited scene: both rendered again: %r" % ev)
check(all("scene hash" in e["reason"] for e in re), "the reason names the scene hash: %r" % re)

# errors: a typo in the scene (file and line), a bad override
with open(os.path.join(SCRATCH, "bad.toml"), "w") as f:
    f.write("[camera]\nfov = 45.0\nwidht = 64\n")
rc, ev = run(["render", os.path.join(SCRATCH, "bad.toml"), "--progress", "json"])
check(rc == 2 and ev and ev[-1]["event"] == "error", "typo: exit 2, error event: %r" % ev)
if ev and ev[-1]["event"] == "error":
    check(ev[-1]["exit_code"] == 2 and ev[-1].get("line") == 3 and
          ev[-1].get("file", "").endswith("bad.toml"), "error names file and line: %r" % ev[-1])
rc, ev = run(["render", scene, "--progress", "json", "--set", "camera.widht=3"])
check(rc == 2 and any(e["event"] == "error" and "widht" in e["message"] for e in ev),
      "bad override: %r" % ev)

if failures:
    print("\n".join(failures))
    sys.exit(1)
print("every stderr line parsed as a documented JSON event")
shutil.rmtree(SCRATCH, ignore_errors=True)
