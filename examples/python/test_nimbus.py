"""Tests of the Python module (examples/python/nimbus.py) through libnimbus.so.

    NIMBUS_LIBRARY=build/libnimbus.so.0 NIMBUS_HOST_C=build/nimbus_host_c \\
        /usr/bin/python3 examples/python/test_nimbus.py

ctest runs it (python.nimbus). The image must have the camera's shape, be finite, and equal bit
for bit the one the C host (examples/host_c, another process through dlopen) renders from the
same scene; errors must raise with the library's message, file and line.
"""

import os
import subprocess
import sys
import tempfile
import threading
import unittest

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import nimbus  # noqa: E402

# a 24x14 cumulus scene (as tests/test_capi.cpp), a fraction of a second to render
TINY = """color_space = "lin_rec709"
frames = "3"
[camera]
position = [0.0, 0.3, -24.0]
look_at = [0.0, 5.5, 0.0]
fov = 45.0
width = 24
height = 14
[sun]
elevation = 9.0
azimuth = -30.0
intensity = 12.0
[medium]
sigma_s = 12.0
g = 0.5
[field]
kind = "cumulus"
bounds_min = [-30.0, 1.2, -20.0]
bounds_max = [30.0, 5.2, 40.0]
base_octaves = 2
detail_octaves = 1
[render]
step = 0.2
shadow_step = 0.2
threads = 2
multiple_scattering = "grid"  # the default scene's model ("auto": 2-8 M photons a frame here)
"""


class NimbusModule(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory(prefix="nimbus_python_")
        self.dir = self.tmp.name

    def tearDown(self):
        self.tmp.cleanup()

    def test_version(self):
        v = nimbus.version()
        self.assertRegex(v, r"^0\.\d+\.\d+$")

    def test_render_has_the_camera_shape_is_finite_and_equals_the_c_host(self):
        scene = os.path.join(self.dir, "tiny.toml")
        with open(scene, "w") as f:
            f.write(TINY)
        with nimbus.Context() as ctx:
            ctx.load_file(scene)
            self.assertEqual(ctx.frames(), [3])
            ctx.set("camera.width", 32)  # a Python value, as TOML
            ctx.set("camera.height=20")  # or as --set takes it
            plan = ctx.plan()
            self.assertEqual((plan["width"], plan["height"], plan["frame"]), (32, 20, 3))
            self.assertEqual(plan["integrator"], "march")
            self.assertIn("frame 3", plan["explain"])
            img = ctx.render()
        self.assertEqual(img.shape, (20, 32, 4))
        self.assertEqual(img.dtype, np.float32)
        self.assertTrue(np.isfinite(img).all())
        self.assertGreater(float(img[..., 3].mean()), 0.0)  # some cloud in view

        host = os.environ.get("NIMBUS_HOST_C")
        if not host:
            self.skipTest("NIMBUS_HOST_C not set: no C host to compare with")
        raw = os.path.join(self.dir, "host.f32")
        run = subprocess.run([host, "--lib", nimbus.library_path(), scene, "--set",
                              "camera.width=32", "--set", "camera.height=20", "--raw", raw,
                              "--quiet"], capture_output=True, text=True)
        self.assertEqual(run.returncode, 0, run.stderr)
        fromC = np.fromfile(raw, dtype=np.float32).reshape(20, 32, 4)
        # bit for bit (NaN-safe): the same library, scene, overrides and frame
        self.assertTrue(np.array_equal(img.view(np.uint32), fromC.view(np.uint32)))

    def test_aovs(self):
        with nimbus.Context() as ctx:
            ctx.load_string(TINY, "tiny.toml")
            layers = ctx.render(aovs=("transmittance", "depth"))
            rgba = ctx.render()
        self.assertEqual(layers["transmittance"].shape, (14, 24, 3))
        self.assertEqual(layers["depth"].shape, (14, 24, 1))
        self.assertTrue(np.array_equal(layers["rgba"], rgba))
        t, d = layers["transmittance"], layers["depth"][..., 0]
        self.assertTrue(((t >= 0.0) & (t <= 1.0)).all())
        self.assertTrue((d > 0.0).any())
        # depth is where the transmittance first falls below 0.5: only rays it fell on have one
        self.assertTrue((t[d > 0.0].min(axis=1) < 0.5 + 1e-6).all())
        self.assertTrue((d[t.max(axis=2) > 0.5 + 1e-6] == 0.0).all())

    def test_errors_carry_message_file_and_line(self):
        with nimbus.Context() as ctx:
            with self.assertRaises(nimbus.BadInput) as e:
                ctx.load_string("[camera]\nfov = 45.0\nwidht = 64\n", "bad.toml")
            self.assertEqual(e.exception.status, 2)
            self.assertEqual(e.exception.file, "bad.toml")
            self.assertEqual(e.exception.line, 3)
            self.assertIn("widht", e.exception.message)
            self.assertIn("did you mean", str(e.exception))
            # the context is usable after it
            ctx.load_string(TINY, "tiny.toml")
            with self.assertRaises(nimbus.BadInput) as e:
                ctx.set("render.stepp", 0.5)
            self.assertIn("--set render.stepp=0.5", e.exception.message)
            self.assertEqual(e.exception.line, 0)
            with self.assertRaises(nimbus.OutputError):
                blocker = os.path.join(self.dir, "file")
                open(blocker, "w").close()
                ctx.render_write(path=os.path.join(blocker, "x.exr"))
            self.assertEqual(ctx.render().shape, (14, 24, 4))
        with self.assertRaises(ValueError):
            ctx.render()  # closed

    def test_progress_cancels_and_its_exceptions_come_back(self):
        with nimbus.Context() as ctx:
            ctx.load_string(TINY, "tiny.toml")
            ctx.set("camera.width", 96)
            ctx.set("render.tile_size", 4)
            seen = []
            ctx.render(progress=lambda done, total: seen.append((done, total)) and False)
            self.assertEqual(len(seen), seen[-1][1])
            with self.assertRaises(nimbus.Interrupted):
                ctx.render(progress=lambda done, total: done >= 3)

            def boom(done, total):
                raise KeyError("from the callback")

            with self.assertRaises(KeyError):
                ctx.render(progress=boom)
            self.assertEqual(ctx.render().shape, (14, 96, 4))

    def test_a_failed_render_with_progress_keeps_its_message(self):
        missing = os.path.join(self.dir, "no_such_file.vdb")
        with nimbus.Context() as ctx:
            ctx.load_string(TINY.split("[field]")[0] + '[field]\nkind = "vdb"\npath = "%s"\n'
                            % missing, "vdb.toml")
            for progress in (None, lambda done, total: False):
                with self.assertRaises(nimbus.BadInput) as e:
                    ctx.render(progress=progress)
                self.assertIn("no_such_file.vdb", e.exception.message)

    def test_render_write(self):
        out = os.path.join(self.dir, "frame.exr")
        with nimbus.Context() as ctx:
            ctx.load_string(TINY, os.path.join(self.dir, "tiny.toml"))
            self.assertEqual(ctx.render_write(path=out), out)
        with open(out, "rb") as f:
            self.assertEqual(f.read(4), b"\x76\x2f\x31\x01")  # OpenEXR magic

    def test_two_contexts_in_two_threads(self):
        def render(text):
            with nimbus.Context() as ctx:
                ctx.load_string(text, "tiny.toml")
                return ctx.render()

        other = TINY.replace("elevation = 9.0", "elevation = 40.0")
        sequential = [render(TINY), render(other)]
        results = [None, None]

        def work(i, text):
            results[i] = render(text)

        threads = [threading.Thread(target=work, args=(0, TINY)),
                   threading.Thread(target=work, args=(1, other))]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        for a, b in zip(results, sequential):
            self.assertTrue(np.array_equal(a, b))
        self.assertFalse(np.array_equal(sequential[0], sequential[1]))


if __name__ == "__main__":
    unittest.main(verbosity=2)
