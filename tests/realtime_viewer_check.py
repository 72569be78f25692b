#!/usr/bin/python3
"""Smoke test of examples/realtime_viewer (nimbus_viewer) under Xvfb.

usage: realtime_viewer_check.py NIMBUS NIMBUS_VIEWER XVFB SCENE SCRATCH_DIR [NIMBUS_HEADLESS]

One Xvfb server (XVFB: the Xvfb binary) serves every viewer run of the script: it picks a free
display number itself (-displayfd), so nothing races for one, and it is started and stopped once.

1. `nimbus export-glsl` of the default scene at 96x54 (render.multiple_scattering = "none",
   frame 1; it skips empty space, RT_SKIP, so majorant.bin is among its data files), then
   `nimbus_viewer --frames 3 --screenshot view.pfm` on it under Xvfb (GLX on Mesa llvmpipe):
   the resolved linear RGB of the displayed frame.
2. The same view from `nimbus rt` (the headless EGL renderer, EXR in ACEScg = the working space):
   PSNR over RGB (peak: the reference's largest value) must be >= 45 dB.
3. The camera edited through params.json's offsets: `--move 0,0,3` (3 km forward) and
   `--turn 20,5` (degrees) against `nimbus rt` with camera.position / camera.look_at set to the
   same view: >= 45 dB each; and the moved view against the unmoved reference must be far below
   (< 30 dB), so the comparison can tell views apart. Then a 4-pass export (4 pixel samples, no
   sun, transparent background, 64x36) against `nimbus rt`: >= 45 dB. Temporal accumulation:
   6 frames with --accumulate 4 against `nimbus rt --accumulate 4` (>= 45 dB) and far from one
   pass (< 60 dB); --accumulate 0 and --frames 3x exit 2. Then an export with data buffers
   (the diffusion grid, the Mie table) and one with 3D textures (field.evaluation = "rgba"),
   64x36, each against `nimbus rt` (>= 45 dB).
4. Bad export folders (a missing file, broken JSON, a missing member, a short params.bin): exit 2
   and a message naming the file and the problem; a march.comp that does not compile: exit 3 and
   the compiler's log.
5. With NIMBUS_HEADLESS (nimbus_headless: the same export without a window, EGL): its image of
   the export against `nimbus rt` (>= 45 dB), with --accumulate 4 against `nimbus rt
   --accumulate 4` (>= 45 dB: the same pass keys) and far from the single pass (< 60 dB); its
   timing lines (one GPU time per accumulation pass); a bad count exits 2, a missing export 2
   with the file named, a shader that does not compile 3.
Pixels are read from both files by oiiotool --dumpdata (OpenImageIO), not by this script.
"""
import atexit
import math
import os
import re
import select
import shutil
import subprocess
import sys
import tempfile

import numpy as np

NIMBUS, VIEWER, XVFB, SCENE, SCRATCH = sys.argv[1:6]
HEADLESS = sys.argv[6] if len(sys.argv) > 6 else None
SIZE = ["camera.width=96", "camera.height=54"]
SETS = ['render.multiple_scattering="none"', 'output.preview=""'] + SIZE
ENV = {k: v for k, v in os.environ.items() if k != "OCIO"}  # the working space is ACEScg
failures = []


def run(args, **kw):
    p = subprocess.run(args, capture_output=True, text=True, env=ENV, timeout=280, **kw)
    return p.returncode, p.stdout + p.stderr


def check(ok, what):
    print(("ok: " if ok else "FAIL: ") + what, flush=True)
    if not ok:
        failures.append(what)


def pixels(path):
    """RGB of an image file (row 0 = top), read by OpenImageIO's oiiotool."""
    rc, out = run(["oiiotool", "--dumpdata", path])
    if rc != 0:
        raise RuntimeError(out)
    m = re.search(r":\s+(\d+) x\s+(\d+), (\d+) channel", out)
    w, h, n = int(m.group(1)), int(m.group(2)), int(m.group(3))
    values = [line.split(":", 1)[1].split() for line in out.splitlines() if "Pixel (" in line]
    a = np.array(values, dtype=np.float64).reshape(h, w, n)
    return a[:, :, :3]


def psnr(image, reference):
    mse = float(np.mean((image - reference) ** 2))
    peak = float(reference.max())
    return math.inf if mse == 0.0 else 10.0 * math.log10(peak * peak / mse)


def start_xvfb():
    """Start one Xvfb for the whole script; return the environment that reaches it."""
    read_end, write_end = os.pipe()
    log = tempfile.TemporaryFile(mode="w+")
    server = subprocess.Popen([XVFB, "-displayfd", str(write_end), "-screen", "0", "1024x768x24",
                               "-nolisten", "tcp"], pass_fds=(write_end,),
                              stdout=log, stderr=subprocess.STDOUT)
    os.close(write_end)
    atexit.register(lambda: (server.terminate(), server.wait(timeout=30)))
    number = b""
    while not number.endswith(b"\n"):  # Xvfb writes the display number once it accepts clients
        if not select.select([read_end], [], [], 60)[0]:
            sys.exit("Xvfb gave no display number within 60 s")
        chunk = os.read(read_end, 16)
        if not chunk:
            server.wait()
            log.seek(0)
            sys.exit(f"Xvfb exited ({server.returncode}) before it was ready:\n" + log.read())
        number += chunk
    os.close(read_end)
    env = dict(ENV, DISPLAY=":" + number.decode().strip())
    env.pop("XAUTHORITY", None)
    print(f"Xvfb on display {env['DISPLAY']}", flush=True)
    return env


XENV = start_xvfb()


def xvfb(args):
    p = subprocess.run([VIEWER] + args, capture_output=True, text=True, env=XENV, timeout=280)
    return p.returncode, p.stdout + p.stderr


def rt_reference(name, sets, extra=()):
    out = os.path.join(SCRATCH, name + ".####.exr")
    args = [NIMBUS, "rt", SCENE, "--frames", "1", "-o", out] + list(extra)
    for s in SETS + sets:
        args += ["--set", s]
    rc, text = run(args)
    if rc != 0:
        raise RuntimeError("nimbus rt failed:\n" + text)
    return pixels(out.replace("####", "0001"))


def view(tag, export, extra):
    shot = os.path.join(SCRATCH, tag + ".pfm")
    rc, out = xvfb([export, "--frames", "3", "--screenshot", shot] + extra)
    print(out.rstrip())
    check(rc == 0, f"{tag}: the viewer exits 0 (exit {rc})")
    check(re.search(r"^GL: .*; 4\.[3-9] \(Core Profile\)", out, re.M) is not None,
          f"{tag}: a 4.3+ core profile context under Xvfb")
    return pixels(shot) if rc == 0 else None


shutil.rmtree(SCRATCH, ignore_errors=True)
os.makedirs(SCRATCH)
export = os.path.join(SCRATCH, "export")
args = [NIMBUS, "export-glsl", SCENE, "-o", export, "--frame", "1"]
for s in SETS:
    args += ["--set", s]
rc, out = run(args)
check(rc == 0, "nimbus export-glsl exits 0: " + out.strip())
# the frame skips empty space (RT_SKIP): the viewer uploads majorant.bin like the other data
check("RT_SKIP" in out and "majorant.bin" in out,
      "the export skips empty space and writes majorant.bin: " + out.strip())

# 1-2. the scene's own camera
reference = rt_reference("rt", [])
spread = float(np.std(reference))
check(spread > 0.01, f"the reference is not flat (std {spread:.3f})")
image = view("scene_camera", export, [])
if image is not None:
    p = psnr(image, reference)
    print(f"PSNR scene camera: {p:.2f} dB, largest difference "
          f"{float(np.abs(image - reference).max()):.3g}")
    check(p >= 45.0, f"scene camera: PSNR {p:.2f} dB >= 45")

# 3. the camera moved and turned by the viewer, against nimbus rt with the same view set
position = np.array([0.0, 0.3, -24.0])  # examples/scenes/cumulus.toml [camera]
look_at = np.array([0.0, 5.5, 0.0])
forward = (look_at - position) / np.linalg.norm(look_at - position)


def vec(v):
    return "[" + ", ".join(f"{x:.9g}" for x in v) + "]"


moved = position + 3.0 * forward
yaw = math.atan2(forward[0], forward[2]) + math.radians(20.0)
pitch = math.asin(forward[1]) + math.radians(5.0)
turned = np.array([math.cos(pitch) * math.sin(yaw), math.sin(pitch),
                   math.cos(pitch) * math.cos(yaw)])
cases = [("moved", ["--move", "0,0,3"],
          [f"camera.position={vec(moved)}", f"camera.look_at={vec(look_at + 3.0 * forward)}"]),
         ("turned", ["--turn", "20,5"], [f"camera.look_at={vec(position + turned * 24.0)}"])]
for tag, viewer_args, sets in cases:
    image = view(tag, export, viewer_args)
    if image is None:
        continue
    p = psnr(image, rt_reference("rt_" + tag, sets))
    print(f"PSNR {tag}: {p:.2f} dB")
    check(p >= 45.0, f"{tag}: PSNR {p:.2f} dB >= 45")
    if tag == "moved":
        q = psnr(image, reference)
        print(f"PSNR moved view against the unmoved reference: {q:.2f} dB")
        check(q < 30.0, f"the moved view differs from the unmoved one ({q:.2f} dB < 30)")

# 3a. temporal accumulation over displayed frames: 6 frames of a still camera with
# --accumulate 4 hold the sums of 4 passes keyed as `nimbus rt --accumulate 4` keys them
acc_reference = rt_reference("rt_acc4", [], ["--accumulate", "4"])
shot = os.path.join(SCRATCH, "accumulated.pfm")
rc, out = xvfb([export, "--frames", "6", "--accumulate", "4", "--screenshot", shot])
print(out.rstrip())
check(rc == 0 and "4/4 passes accumulated" in out,
      f"accumulated: the viewer exits 0 and reports 4/4 passes (exit {rc})")
if rc == 0:
    image = pixels(shot)
    p = psnr(image, acc_reference)
    q = psnr(image, reference)
    print(f"PSNR 6 frames accumulating 4 passes against nimbus rt --accumulate 4: {p:.2f} dB; "
          f"against one pass: {q:.2f} dB")
    check(p >= 45.0, f"accumulated: PSNR {p:.2f} dB >= 45")
    check(q < 60.0, f"accumulated: differs from one pass ({q:.2f} dB < 60)")
rc, out = xvfb([export, "--frames", "1", "--accumulate", "0"])
check(rc == 2 and "--accumulate wants a count" in out, f"viewer --accumulate 0: exit {rc}")
rc, out = xvfb([export, "--frames", "3x"])  # a count with trailing characters
check(rc == 2 and "--frames wants a count" in out, f"viewer --frames 3x: exit {rc}")

# 3b. a multi-pass export (4 pixel samples: one dispatch per sample, sampleIndex at its offset),
# no sun, transparent background, 64x36
ms_sets = ["camera.width=64", "camera.height=36", "sun.enabled=false", "render.pixel_samples=4",
           'render.background="transparent"']
ms_export = os.path.join(SCRATCH, "export_4spp")
args = [NIMBUS, "export-glsl", SCENE, "-o", ms_export, "--frame", "1"]
for s in SETS + ms_sets:
    args += ["--set", s]
rc, out = run(args)
check(rc == 0, "nimbus export-glsl (4 spp) exits 0: " + out.strip())
image = view("4spp", ms_export, [])
if image is not None:
    p = psnr(image, rt_reference("rt_4spp", ms_sets))
    print(f"PSNR 4 spp, no sun, transparent: {p:.2f} dB")
    check(p >= 45.0, f"4 spp: PSNR {p:.2f} dB >= 45")

def data_export_against_rt(tag, what, sets, files):
    """An export of the scene with `sets` writes `files`; the viewer's image of it against
    `nimbus rt`'s at the same settings: >= 45 dB. Returns the export's folder."""
    export = os.path.join(SCRATCH, "export_" + tag)
    args = [NIMBUS, "export-glsl", SCENE, "-o", export, "--frame", "1"]
    for s in SETS + sets:
        args += ["--set", s]
    rc, out = run(args)
    check(rc == 0 and all(f in out for f in files),
          f"nimbus export-glsl ({what}) exits 0 and writes {files}: " + out.strip())
    image = view(tag, export, [])
    if image is not None:
        p = psnr(image, rt_reference("rt_" + tag, sets))
        print(f"PSNR {what}: {p:.2f} dB")
        check(p >= 45.0, f"{what}: PSNR {p:.2f} dB >= 45")
    return export


# 3c. an export with data buffers: the scene as it ships (the diffusion grid of the frame) with
# the Lorenz-Mie table, 64x36: diffusion.bin and mie_table.bin uploaded from their files. The
# grid on voxels of 0.5 instead of 0.117 (at most 20.7 MB instead of 184 MB: its solve was most
# of the check's time, 5.5 s each for the export and nimbus rt); the files' roles are the same
data_export = data_export_against_rt(
    "data", "diffusion grid + Mie table",
    ["camera.width=64", "camera.height=36", 'render.multiple_scattering="grid"',
     'medium.phase="mie_table"', "render.light_volume_cell=0.5"],
    ["diffusion.bin", "mie_table.bin"])
# 3d. an export with textures: field.evaluation = "rgba" (Olajos' channel layout), the noise
# tiles as RGBA8 3D textures (params.json's "textures", made by the viewer from their files)
data_export_against_rt("rgba", "rgba noise textures",
                       ["camera.width=64", "camera.height=36", 'field.evaluation="rgba"'],
                       ["noise_base_rgba.bin", "noise_detail_rgba.bin"])

# 4. bad export folders: exit 2 before any window, the file and the problem named
def broken(tag, edit, expect, want=2):
    d = os.path.join(SCRATCH, "bad_" + tag)
    shutil.copytree(export, d)
    edit(d)
    rc, out = xvfb([d, "--frames", "1"])
    check(rc == want and re.search(expect, out) is not None,
          f"bad export ({tag}): exit {rc} (want {want}), output {out.strip()!r} matches {expect!r}")


def rewrite(name, fn):
    def edit(d):
        path = os.path.join(d, name)
        with open(path, "rb") as f:
            data = f.read()
        with open(path, "wb") as f:
            f.write(fn(data))
    return edit


broken("no_params_bin", lambda d: os.remove(os.path.join(d, "params.bin")),
       r"bad_no_params_bin/params\.bin: cannot open \(No such file or directory\)")
broken("no_shader", lambda d: os.remove(os.path.join(d, "march.comp")),
       r"bad_no_shader/march\.comp: cannot open")
broken("no_json", lambda d: os.remove(os.path.join(d, "params.json")),
       r"bad_no_json/params\.json: cannot open")
broken("truncated_json", rewrite("params.json", lambda b: b[: len(b) // 2]),
       r"params\.json: line \d+, column \d+: ")
broken("bad_json", rewrite("params.json", lambda b: b.replace(b'"width":', b'"width"', 1)),
       r"params\.json: line \d+, column \d+: syntax error .*expected ':'")
broken("no_camera", rewrite("params.json", lambda b: b.replace(b'"camForward"', b'"camFwd"')),
       r'no vec4 member "camForward"')
broken("short_bin", rewrite("params.bin", lambda b: b[:-8]),
       r"params\.bin: (\d+) bytes, parameter_block\.bytes says (\d+)")
export = data_export  # the data files of an export: missing or short
broken("no_majorant", lambda d: os.remove(os.path.join(d, "majorant.bin")),
       r"bad_no_majorant/majorant\.bin: cannot open \(No such file or directory\)")
broken("no_grid", lambda d: os.remove(os.path.join(d, "diffusion.bin")),
       r"bad_no_grid/diffusion\.bin: cannot open \(No such file or directory\)")
broken("short_grid", rewrite("diffusion.bin", lambda b: b[:-12]),
       r"bad_short_grid/diffusion\.bin: \d+ bytes, buffers\[\]\.bytes of \"RtDiffusionGrid\" says \d+")
# a shader the driver rejects: exit 3 (GL), with the compiler's log
broken("bad_shader", rewrite("march.comp", lambda b: b + b"\nthis is not GLSL\n"),
       r"march\.comp does not compile:\n.*(error|ERROR)", want=3)

# 5. nimbus_headless: the export without a window (EGL), timed, its image written as PFM
if HEADLESS:
    scene_export = os.path.join(SCRATCH, "export")
    shots = {}
    for n in (1, 4):
        shot = os.path.join(SCRATCH, f"headless_{n}.pfm")
        rc, out = run([HEADLESS, scene_export, "--frames", "2", "--warmup", "1",
                       "--accumulate", str(n), "--pfm", shot])
        print(out.rstrip())
        check(rc == 0, f"headless, accumulate {n}: exit {rc}")
        if rc != 0:
            continue
        m = re.search(r"^pass GPU ms: median [0-9.]+, min [0-9.]+, max [0-9.]+ over (\d+) "
                      r"accumulation passes$", out, re.M)
        check(m is not None and int(m.group(1)) == 2 * n,
              f"headless, accumulate {n}: a GPU time per accumulation pass (2 frames x {n})")
        check(re.search(r"^frame GPU ms: median [0-9.]+", out, re.M) is not None and
              "(0 non-finite values)" in out, f"headless, accumulate {n}: frame times, no NaN")
        shots[n] = pixels(shot)
        ref = reference if n == 1 else acc_reference
        p = psnr(shots[n], ref)
        print(f"PSNR headless, accumulate {n}, against nimbus rt: {p:.2f} dB")
        check(p >= 45.0, f"headless, accumulate {n}: PSNR {p:.2f} dB >= 45")
    if 1 in shots and 4 in shots:
        q = psnr(shots[4], shots[1])
        print(f"PSNR headless accumulate 4 against 1: {q:.2f} dB")
        check(q < 60.0, f"the accumulated passes differ from one pass ({q:.2f} dB < 60)")
    rc, out = run([HEADLESS, scene_export, "--accumulate", "0"])
    check(rc == 2 and "--accumulate wants a count" in out, f"headless --accumulate 0: exit {rc}")
    rc, out = run([HEADLESS, scene_export, "--frames", "99999999999"])  # past a long's range
    check(rc == 2 and "--frames wants a count" in out, f"headless --frames 99999999999: exit {rc}")
    rc, out = run([HEADLESS, os.path.join(SCRATCH, "no_such_export")])
    check(rc == 2 and "no_such_export/" in out and "cannot open" in out,
          f"headless, missing export: exit {rc}: {out.strip()!r}")
    rc, out = run([HEADLESS, os.path.join(SCRATCH, "bad_bad_shader"), "--frames", "1"])
    check(rc == 3 and "does not compile" in out, f"headless, bad shader: exit {rc}")

if failures:
    print(f"{len(failures)} check(s) failed:")
    for what in failures:
        print("  " + what)
    sys.exit(1)
print("all checks passed")
