#!/usr/bin/env python3
"""`nimbus export-glsl` from the command line (docs/realtime.md, "Export for engines").

Usage: export_glsl_check.py NIMBUS GLSLANG_VALIDATOR SCENE SCRATCH_DIR

For the variants of the scene made with --set (sun on/off, sky ambient on/off, sky background
on/off, one or four samples per pixel; sixteen combinations would repeat the same checks):
  - the command exits 0 and writes march.comp, params.json and params.bin;
  - glslangValidator accepts march.comp;
  - params.json parses with Python's json module and names the features the variant must have;
  - the text of march.comp has the code of every enabled feature and none of a disabled one's
    (the #if blocks are preprocessed away, not set to 0; the kernels only that code calls are
    gone too), and no #if on an RT_* macro is left;
  - every line after a `#line N S` is line N of the file S names (the renumbering after removed
    code is right);
  - the JSON's members tile the block by the std430 rules (vec4 16-byte aligned, scalars 4),
    every member has a meaning and units, and each value equals the bytes of params.bin at the
    member's offset (floats bit for bit);
A baked variant (field.evaluation = "baked": RT_BAKED_NOISE) has the tiles' buffers and lookup,
noise_base.bin and noise_detail.bin at bindings 10 and 11 of baseBakeRes^3 and detailBakeRes^3
floats, and none of the noise kernels (worleyFbm); the others have the noise kernels and no tiles.
An "rgba" variant (RT_BAKED_NOISE and RT_RGBA_NOISE, Olajos' layout) has the two samplers and
the channels' combination instead of the buffers, noise_base_rgba.bin and noise_detail_rgba.bin
of res^3 RGBA8 texels listed in params.json's "textures" (units 4 and 5), and no float tiles.
Every variant skips empty space (RT_SKIP: majorant.bin at binding 13, majorantResX * Y * Z floats,
some of them 0) but one with render.skip_empty = false, which has neither the file nor the code.
An SDF cloud (examples/scenes/sdf_cloud.toml, RT_SDF) has the tree's buffer, lookup and kernels
and sdf_nodes.bin at binding 12 holding sdfNodeCount nodes of 144 bytes, and no cumulus code;
the others have no RT_SDF code. No variant has RT_RESUMABLE (`nimbus rt`'s march in slices on
llvmpipe; its state buffer and loop probe are pruned away). With the shared data folder beside
the repository, the same checks on smoke1 (a VDB field:
RT_VDB's buffer and lookups present, the cumulus' code absent, vdb_grid.bin at binding 9); without
it that variant is skipped with a message.
`nimbus --help` lists the command and its --help its options; and the errors: no -o (exit 2), a folder that cannot be made (exit 3, nothing written), a scene
`nimbus rt` refuses (exit 2, the key named, the same message as `nimbus rt`).
A variant with render.shadow = "volume" (RT_LIGHT_VOLUME), or whose octave gate reads the grid's
sun-depth volume (RT_GATE_VOLUME), has light_tau.bin at binding 15 and the
volume's lookup; the others have neither (the SDF cloud as it ships uses the volume too).
A variant with the single-scattered sky from its volume (RT_SKY_VOLUME) has sky_volume.bin at
binding 7 and its lookup, and no ambient.
Exit 0 when every check passes; each failure is printed.
"""
import json
import os
import re
import shutil
import struct
import subprocess
import sys

NIMBUS, VALIDATOR, SCENE, SCRATCH = sys.argv[1:5]
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(SCENE))))
FAILURES = []


def check(ok, what):
    if not ok:
        FAILURES.append(what)
        print("FAIL:", what)
    return ok


def run(args):
    p = subprocess.run([NIMBUS] + args, capture_output=True, text=True)
    return p.returncode, p.stdout + p.stderr


# a coarse light-volume grid (voxel 0.5 instead of the default scene's 0.117): with its diffusion
# solve it was most of each export's time (3.6-4.4 s of the grid variants'); the files, their
# sizes against the JSON and the features are checked the same way at any resolution
BASE = ["--set", "camera.width=32", "--set", "camera.height=18",
        "--set", "render.light_volume_cell=0.5"]

# name -> (extra --set values, expected features); features not named are off
NONE = 'render.multiple_scattering="none"'
VARIANTS = {
    "all": ([NONE], dict(RT_SUN=1, RT_AMBIENT=1, RT_BACKGROUND_SKY=1, RT_SKIP=1)),
    "no_sun": ([NONE, "sun.enabled=false"], dict(RT_AMBIENT=1, RT_BACKGROUND_SKY=1, RT_SKIP=1)),
    "no_ambient": ([NONE, "sky.ambient=0"], dict(RT_SUN=1, RT_BACKGROUND_SKY=1, RT_SKIP=1)),
    "transparent_4spp": ([NONE, 'render.background="transparent"', "render.pixel_samples=4"],
                         dict(RT_SUN=1, RT_AMBIENT=1, RT_MULTISAMPLE=1, RT_SKIP=1)),
    "none": ([NONE, "sun.enabled=false", "sky.ambient=0", 'render.background="transparent"'],
             dict(RT_SKIP=1)),
    "all_4spp": ([NONE, "render.pixel_samples=4"],
                 dict(RT_SUN=1, RT_AMBIENT=1, RT_BACKGROUND_SKY=1, RT_MULTISAMPLE=1, RT_SKIP=1)),
    # the scene as it ships (the diffusion grid, which carries the sky: no ambient) with the
    # Lorenz-Mie table; then the photon grid (the sun) with its skin profile
    "grid_mie": (['medium.phase="mie_table"'],
                 dict(RT_SUN=1, RT_FORWARD_DELTA=1, RT_BACKGROUND_SKY=1, RT_MIE_TABLE=1,
                      RT_MS_DIFFUSION=1, RT_SKIP=1, RT_GATE_VOLUME=1)),
    "photons_skin": (['render.multiple_scattering="photons"', "render.photons=20000",
                      "render.photon_skin=0.2"],
                     dict(RT_SUN=1, RT_BACKGROUND_SKY=1, RT_MS_DIFFUSION=1, RT_MS_PHOTONS=1,
                          RT_PHOTON_SKIN=1, RT_SKIP=1)),
    # the noise from the tiles the CPU bakes
    "baked": ([NONE, 'field.evaluation="baked"'],
              dict(RT_SUN=1, RT_AMBIENT=1, RT_BACKGROUND_SKY=1, RT_BAKED_NOISE=1, RT_SKIP=1)),
    # Olajos' layout: the tiles as RGBA8 3D textures (params.json's "textures")
    "rgba": ([NONE, 'field.evaluation="rgba"'],
             dict(RT_SUN=1, RT_AMBIENT=1, RT_BACKGROUND_SKY=1, RT_BAKED_NOISE=1, RT_RGBA_NOISE=1,
                  RT_SKIP=1)),
    # render.skip_empty = false: no majorant grid, no RT_SKIP (its code and majorant.bin absent)
    "no_skip": ([NONE, "render.skip_empty=false"],
                dict(RT_SUN=1, RT_AMBIENT=1, RT_BACKGROUND_SKY=1)),
    # the diffusion grid as it ships keeps the forward peak in the beams (RT_FORWARD_DELTA);
    # render.forward_scattering = "none": no forward beam (its transmittance and step absent);
    # both read the octave gate's line integral from the grid's sun-depth volume (RT_GATE_VOLUME)
    "grid": ([], dict(RT_SUN=1, RT_FORWARD_DELTA=1, RT_BACKGROUND_SKY=1, RT_MS_DIFFUSION=1,
                      RT_SKIP=1, RT_GATE_VOLUME=1)),
    "no_forward": (['render.forward_scattering="none"'],
                   dict(RT_SUN=1, RT_BACKGROUND_SKY=1, RT_MS_DIFFUSION=1, RT_SKIP=1,
                        RT_GATE_VOLUME=1)),
    # the octave gate off: the grid's sun-depth volume stays on the CPU (no light_tau.bin)
    "grid_no_gate": (["render.octave_gate=0"],
                     dict(RT_SUN=1, RT_FORWARD_DELTA=1, RT_BACKGROUND_SKY=1, RT_MS_DIFFUSION=1,
                          RT_SKIP=1)),
    # render.shadow = "volume": the sun's light-attenuation volume instead of shadow marches
    # (and for the octave gate's line integral)
    "light_volume": ([NONE, 'render.shadow="volume"'],
                     dict(RT_SUN=1, RT_AMBIENT=1, RT_BACKGROUND_SKY=1, RT_SKIP=1,
                          RT_LIGHT_VOLUME=1, RT_GATE_VOLUME=1)),
    # the single-scattered sky from the CPU's sky volume instead of the ambient
    "sky_volume": ([NONE, 'render.sky_scattering="single"', 'render.sky_shadow="volume"'],
                   dict(RT_SUN=1, RT_BACKGROUND_SKY=1, RT_SKIP=1, RT_SKY_VOLUME=1)),
}
# a VDB field (RT_VDB): smoke1 (examples/scenes/smoke1.toml) when the shared data folder beside
# the repository holds its file; skipped, with a message, when it does not
SMOKE1 = os.path.join(ROOT, "examples", "scenes", "smoke1.toml")
SMOKE1_VDB = os.path.join(ROOT, "..", "shared", "data", "vdb", "openvdb_smoke1.vdb")
SCENES = {}
if os.path.isfile(SMOKE1_VDB):
    VARIANTS["vdb_smoke1"] = ([NONE], dict(RT_SUN=1, RT_AMBIENT=1, RT_BACKGROUND_SKY=1, RT_VDB=1,
                                           RT_SKIP=1))
    SCENES["vdb_smoke1"] = SMOKE1
else:
    print(f"SKIP: the vdb_smoke1 variant: {SMOKE1_VDB} is absent (the shared data folder)")
# an SDF cloud (RT_SDF): examples/scenes/sdf_cloud.toml as it ships (the sun through its light
# volume)
VARIANTS["sdf_cloud"] = ([NONE],
                         dict(RT_SUN=1, RT_AMBIENT=1, RT_BACKGROUND_SKY=1, RT_SDF=1, RT_SKIP=1,
                              RT_LIGHT_VOLUME=1))
SCENES["sdf_cloud"] = os.path.join(ROOT, "examples", "scenes", "sdf_cloud.toml")
ALL_FEATURES = ["RT_SUN", "RT_AMBIENT", "RT_BACKGROUND_SKY", "RT_MULTISAMPLE", "RT_MIE_TABLE",
                "RT_MS_DIFFUSION", "RT_MS_PHOTONS", "RT_PHOTON_SKIN", "RT_VDB", "RT_BAKED_NOISE",
                "RT_RGBA_NOISE", "RT_SKIP", "RT_SDF", "RT_LIGHT_VOLUME", "RT_GATE_VOLUME", "RT_SKY_VOLUME",
                "RT_FORWARD_DELTA", "RT_RESUMABLE"]
# the data files of each feature that reads some, and their buffers' bindings
DATA = {"RT_MIE_TABLE": [("mie_table.bin", 3)], "RT_MS_DIFFUSION": [("diffusion.bin", 4)],
        "RT_MS_PHOTONS": [("photons.bin", 5)], "RT_PHOTON_SKIN": [("skin_tau.bin", 6)],
        "RT_VDB": [("vdb_grid.bin", 9)],
        "FLOAT_TILES": [("noise_base.bin", 10), ("noise_detail.bin", 11)],
        "RT_SKIP": [("majorant.bin", 13)],
        "RT_SDF": [("sdf_nodes.bin", 12)],
        "LIGHT_BUFFER": [("light_tau.bin", 15)],
        "RT_SKY_VOLUME": [("sky_volume.bin", 7)]}
SDF_NODE_BYTES = 144  # struct SdfTreeNode (core/kernels/sdf_tree.glsl), std430

# code that exists only with the feature (march_pass.glsl, march_data.glsl): the shadow march
# and the octaves of the sun, the height-occluded ambient, the sky behind the clouds, the
# pixel-sample loop's body, the data buffers and their lookups (and the kernels only that code
# calls)
MARKERS = {
    "RT_SUN": ["rtDensityIntegral(", "higher += octaveSun(ph, sigmaT", "inScatterFactor(P.inScatter",
               "NB_FN vec3 octaveSun(", "NB_FN PhaseParams phaseOctave(",
               "NB_FN vec3 octaveGateFactor("],
    "RT_AMBIENT": ["skyHeightInScatter(rtXyz(P.skySphere)", "NB_FN vec3 skyHeightInScatter("],
    "RT_BACKGROUND_SKY": ["L += T * rtSkyRadiance(P, d);"],
    "RT_MULTISAMPLE": ["pixelSampleOffset(k, ns", "atomicAdd(nonFinite",
                       "NB_FN vec2 pixelSampleOffset("],
    "RT_MIE_TABLE": ["buffer RtMieTable", "rtMieNode["],
    "RT_MS_DIFFUSION": ["buffer RtDiffusionGrid", "rtDiffusion["],
    "RT_MS_PHOTONS": ["buffer RtPhotonGrid", "rtPhoton["],
    "RT_PHOTON_SKIN": ["buffer RtSkinGrid", "rtSkinTau["],
    "RT_VDB": ["buffer RtVdbGrid", "pnanovdb_readaccessor_get_value_address(", "rtVdbDensity("],
    "RT_BAKED_NOISE": ["rtBakedCumulusDensity("],
    # the float tiles (RT_BAKED_NOISE without RT_RGBA_NOISE) and Olajos' RGBA8 textures
    "FLOAT_TILES": ["buffer RtBaseNoise", "buffer RtDetailNoise", "rtNoiseSample("],
    "RT_RGBA_NOISE": ["uniform sampler3D rtBaseChannels", "uniform sampler3D rtDetailChannels",
                      "cumulusBaseFromChannels(rtChannels(", "NB_FN float cumulusDetailFromChannels("],
    "RT_SKIP": ["buffer RtMajorant", "bool rtEmptyCell(", "int rtSkipTo(",
                "n = rtSkipTo(s, n, tExit, tOut);"],
    "RT_SDF": ["buffer RtSdfNodes", "rtSdfDensity(", "NB_FN void sdfTreeStep(",
               "NB_FN float sdfTreePrimitive("],
    "RT_LIGHT_VOLUME": ["rtLightVolumeSample(p)"],
    # the octave gate's line integral read from the sun-depth volume
    "RT_GATE_VOLUME": ["rtLightVolumeSample(boxExitPoint(", "NB_FN vec3 boxExitPoint("],
    # the volume's buffer, read by either
    "LIGHT_BUFFER": ["buffer RtLightGrid", "rtLightTau["],
    "RT_SKY_VOLUME": ["buffer RtSkyVolume", "rtSkyVolume[", "rtSkySingleScatter(phase, p, d"],
    "RT_RESUMABLE": ["buffer RtSlices", "rtLoopBudgetHeld(", "atomicAdd(unfinished"],
    # the forward beam: the sun's single scattering under its own transmittance
    "RT_FORWARD_DELTA": ["sunForward = octaveSun(ph, sigmaTF", "marchStep(SF, sigmaS, sigmaTF"],
}
# code only a frame with neither RT_VDB nor RT_SDF has (the procedural cumulus, direct or baked)
CUMULUS = ["cumulusEnvelope(", "rtCumulusParams("]
# code only a cumulus frame whose noise is evaluated per sample has (the noise kernels; an SDF
# cloud's displacement calls worleyFbm too)
DIRECT = ["NB_FN float worleyFbm(", "NB_FN float cumulusDensity("]
SDF_TOO = ["NB_FN float worleyFbm("]

SIZES = {"vec4": 16, "float": 4, "int": 4, "uint": 4}

shutil.rmtree(SCRATCH, ignore_errors=True)
os.makedirs(SCRATCH)
texts = {}
for name, (sets, on) in VARIANTS.items():
    features = {f: int(f in on and on[f]) for f in ALL_FEATURES}
    out = os.path.join(SCRATCH, name)
    args = ["export-glsl", SCENES.get(name, SCENE), "-o", out, "--frame", "3"] + BASE
    for s in sets:
        args += ["--set", s]
    rc, log = run(args)
    if not check(rc == 0, f"{name}: exit {rc}: {log}"):
        continue
    shader = os.path.join(out, "march.comp")
    for f in ("march.comp", "params.json", "params.bin"):
        check(os.path.isfile(os.path.join(out, f)), f"{name}: {f} not written")
    v = subprocess.run([VALIDATOR, shader], capture_output=True, text=True)
    check(v.returncode == 0, f"{name}: glslangValidator: {v.stdout}{v.stderr}")
    text = open(shader).read()
    texts[name] = text
    with open(os.path.join(out, "params.json")) as fh:
        doc = json.load(fh)
    check(doc["features"] == {k: bool(x) for k, x in features.items()},
          f"{name}: features {doc['features']} != {features}")
    check(doc["frame"] == 3, f"{name}: frame {doc['frame']}")
    check(not re.search(r"^\s*#\s*(if|ifdef|ifndef|elif)\b.*\bRT_", text, re.M),
          f"{name}: an #if on an RT_ macro is left in the text")
    have = dict(features, FLOAT_TILES=int(features["RT_BAKED_NOISE"] and
                                          not features["RT_RGBA_NOISE"]),
                LIGHT_BUFFER=int(features["RT_LIGHT_VOLUME"] or features["RT_GATE_VOLUME"]))
    for feature, on in have.items():
        for marker in MARKERS[feature]:
            check((marker in text) == bool(on),
                  f"{name}: {feature} {'on' if on else 'off'} but '{marker}' is "
                  f"{'absent' if on else 'present'}")
    other_field = bool(features["RT_VDB"] or features["RT_SDF"])
    for marker in CUMULUS:
        check((marker in text) != other_field,
              f"{name}: RT_VDB {features['RT_VDB']}, RT_SDF {features['RT_SDF']} but '{marker}' "
              f"is {'present' if other_field else 'absent'}")
    direct = not other_field and not features["RT_BAKED_NOISE"]
    for marker in DIRECT:
        want = direct or (marker in SDF_TOO and bool(features["RT_SDF"]))
        check((marker in text) == want,
              f"{name}: noise evaluated per sample {direct}, RT_SDF {features['RT_SDF']} but "
              f"'{marker}' is {'absent' if want else 'present'}")
    # every line after a #line is the line of the file it names (the header lists the
    # source-string numbers): the renumbering after removed code is right
    sources = dict((int(n), f) for n, f in
                   re.findall(r"(\d+)\s+(?://\s*)?((?:core|plugin)/[\w/]+\.glsl)", text.split("#define")[0]))
    check(len(sources) >= 3, f"{name}: the header lists no source strings")
    files = {n: open(os.path.join(ROOT, f)).read().split("\n") for n, f in sources.items()}
    src, num, compared = 0, None, 0
    for line in text.split("\n"):
        m = re.match(r"#line (\d+) (\d+)$", line)
        if m:
            num, src = int(m.group(1)), int(m.group(2))
            continue
        if num is not None and src in files:
            original = files[src][num - 1] if num - 1 < len(files[src]) else None
            if not check(original == line, f"{name}: line {num} of {sources[src]} is "
                                           f"{original!r}, the export has {line!r}"):
                break
            compared += 1
        if num is not None:
            num += 1
    check(compared > 300, f"{name}: only {compared} lines compared with their files")

    # the block: std430 offsets, documentation, values = params.bin
    block = doc["parameter_block"]
    data = open(os.path.join(out, block["file"]), "rb").read()
    check(len(data) == block["bytes"], f"{name}: params.bin {len(data)} != {block['bytes']}")
    offset = 0
    for m in block["members"]:
        size = SIZES.get(m["type"])
        if not check(size is not None, f"{name}: {m['name']}: type {m['type']}"):
            break
        offset = (offset + size - 1) // size * size
        check(m["offset"] == offset, f"{name}: {m['name']} at {m['offset']}, std430 says {offset}")
        check(m["meaning"] and m["units"], f"{name}: {m['name']} has no meaning or units")
        raw = data[m["offset"]:m["offset"] + size]
        if m["type"] == "vec4":
            want = struct.pack("<4f", *m["value"])
        else:
            want = struct.pack({"float": "<f", "int": "<i", "uint": "<I"}[m["type"]], m["value"])
        check(raw == want, f"{name}: {m['name']} = {m['value']} but params.bin has {raw.hex()}")
        offset += size
    check(block["bytes"] == (offset + 15) // 16 * 16, f"{name}: block size {block['bytes']}")
    groups = doc["dispatch"]["groups"]
    wg = doc["workgroup_size"]
    check(groups[0] * wg[0] >= 32 and groups[1] * wg[1] >= 18, f"{name}: dispatch {groups}")
    check(doc["dispatch"]["passes"] == (4 if features["RT_MULTISAMPLE"] else 1),
          f"{name}: passes {doc['dispatch']['passes']}")
    bindings = sorted(b["binding"] for b in doc["buffers"])
    want = sorted([0, 1, 2] + [b for f in DATA if have[f] for _, b in DATA[f]])
    check(bindings == want, f"{name}: bindings {bindings}, expected {want}")
    # the data files: written exactly for the features that read them, of the size the JSON says
    for f, files in DATA.items():
        for file, binding in files:
            path = os.path.join(out, file)
            check(os.path.isfile(path) == bool(have[f]),
                  f"{name}: {file} {'missing' if have[f] else 'written'} with {f} "
                  f"{'on' if have[f] else 'off'}")
            if have[f]:
                b = [b for b in doc["buffers"] if b["binding"] == binding]
                check(len(b) == 1 and b[0].get("file") == file and
                      b[0]["bytes"] == os.path.getsize(path) > 0,
                      f"{name}: buffer {binding} {b} vs {file} of {os.path.getsize(path)} bytes")
    # the tiles: res^3 floats each, res from the block (the scene's bake resolutions)
    res = {m["name"]: m["value"] for m in block["members"]
           if m["name"] in ("baseBakeRes", "detailBakeRes")}
    check(len(res) == 2, f"{name}: baseBakeRes / detailBakeRes not in the block")
    # (the float tiles: res^3 floats; the RGBA8 textures: res^3 texels of 4 bytes, in "textures"
    # on units 4 and 5; the same byte count)
    textures = doc["textures"]
    check(len(textures) == (2 if features["RT_RGBA_NOISE"] else 0),
          f"{name}: {len(textures)} textures with RT_RGBA_NOISE {features['RT_RGBA_NOISE']}")
    rgba_files = [(t.get("file"), t.get("unit"), t.get("size"), t.get("format")) for t in textures]
    for k, (file, key) in enumerate((("noise_base", "baseBakeRes"),
                                     ("noise_detail", "detailBakeRes"))):
        file += "_rgba.bin" if features["RT_RGBA_NOISE"] else ".bin"
        path = os.path.join(out, file)
        if features["RT_BAKED_NOISE"]:
            check(res.get(key, 0) > 0 and os.path.isfile(path) and
                  os.path.getsize(path) == 4 * res[key] ** 3,
                  f"{name}: {file} is not {key}^3 floats or RGBA8 texels ({res.get(key)})")
        else:
            check(res.get(key) == 0, f"{name}: {key} {res.get(key)} without RT_BAKED_NOISE")
        if features["RT_RGBA_NOISE"]:
            check(rgba_files[k] == (file, 4 + k, [res.get(key)] * 3, "GL_RGBA8"),
                  f"{name}: texture {k} is {rgba_files[k]}")
        check(not os.path.isfile(os.path.join(out, file.replace("_rgba.bin", ".bin")
                                              if features["RT_RGBA_NOISE"] else
                                              file.replace(".bin", "_rgba.bin"))),
              f"{name}: the other kind of tile was written too")
    # the majorant grid: one float per cell, resX * resY * resZ from the block (0 without), then
    # one per block of 4^3 cells (the distances: whole numbers 0..255)
    mres = {m["name"]: m["value"] for m in block["members"] if m["name"].startswith("majorantRes")}
    check(len(mres) == 3, f"{name}: majorantResX/Y/Z not in the block")
    cells = mres.get("majorantResX", 0) * mres.get("majorantResY", 0) * mres.get("majorantResZ", 0)
    path = os.path.join(out, "majorant.bin")
    if features["RT_SKIP"]:
        blocks = 1
        for k in ("majorantResX", "majorantResY", "majorantResZ"):
            blocks *= (mres.get(k, 0) + 3) // 4
        check(cells > 0 and os.path.isfile(path) and
              os.path.getsize(path) == 4 * (cells + blocks),
              f"{name}: majorant.bin is not majorantResX * Y * Z + the blocks' floats ({mres})")
        floats = struct.unpack(f"<{cells + blocks}f", open(path, "rb").read()) if cells else ()
        check(any(b == 0.0 for b in floats[:cells]), f"{name}: majorant.bin has no empty cell")
        check(all(d == int(d) and 0 <= d <= 255 for d in floats[cells:]),
              f"{name}: majorant.bin's block distances are not whole numbers 0..255")
    else:
        check(cells == 0, f"{name}: majorantRes {mres} without RT_SKIP")
    if features["RT_SDF"]:
        # whole nodes, as many as the block says
        size = os.path.getsize(os.path.join(out, "sdf_nodes.bin"))
        count = [m["value"] for m in block["members"] if m["name"] == "sdfNodeCount"]
        check(size % SDF_NODE_BYTES == 0 and count == [size // SDF_NODE_BYTES] and size > 0,
              f"{name}: sdf_nodes.bin of {size} bytes, sdfNodeCount {count}")
check(len(set(texts.values())) == len(texts), "two variants exported the same text")

# the help
rc, log = run(["--help"])
check(rc == 0 and "export-glsl" in log, f"nimbus --help does not list export-glsl: {log}")
rc, log = run(["export-glsl", "--help"])
check(rc == 0 and all(w in log for w in ("--output", "--frame", "--set")),
      f"export-glsl --help: exit {rc}: {log}")

# errors
rc, log = run(["export-glsl", SCENE] + BASE)
check(rc == 2 and "--output" in log, f"no -o: exit {rc}: {log}")
blocker = os.path.join(SCRATCH, "a_file")
open(blocker, "w").write("x")
rc, log = run(["export-glsl", SCENE, "-o", os.path.join(blocker, "sub")] + BASE)
check(rc == 3 and "cannot create the folder" in log, f"folder under a file: exit {rc}: {log}")
rc, log = run(["export-glsl", SCENE, "-o", blocker] + BASE)
check(rc == 3 and "cannot create the folder" in log, f"-o names a file: exit {rc}: {log}")
refused = os.path.join(SCRATCH, "refused")
rc, log = run(["export-glsl", SCENE, "-o", refused, "--set", "camera.width=32",
               "--set", NONE, "--set", 'render.sky_occlusion="column"'])
check(rc == 2 and "render.sky_occlusion" in log and "not supported by the GPU path" in log,
      f"refused scene: exit {rc}: {log}")
check(not os.path.exists(refused), "a refused export wrote its folder")
rc2, log2 = run(["rt", SCENE, "--frames", "1", "--explain", "--set", "camera.width=32",
                 "--set", NONE, "--set", 'render.sky_occlusion="column"'])
check(rc2 == 2 and log2.strip() == log.strip(),
      f"nimbus rt refuses with another message: exit {rc2}: {log2} vs {log}")

print(f"{len(VARIANTS)} variants, {len(FAILURES)} failures")
sys.exit(1 if FAILURES else 0)
