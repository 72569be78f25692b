"""Nimbus for Blender: a render engine that renders the scene's clouds and VDB volumes with
libnimbus.so (through the ctypes module examples/python/nimbus.py).

Install: see docs/blender.md. The binding nimbus.py is taken from beside this package (an
installed zip made by `cmake --build build --target blender_addon`) or from the repository's
examples/python/ (the add-on run from a checkout); the library from the add-on's preference,
$NIMBUS_LIBRARY, or where nimbus.py looks (the checkout's build/, then the loader's path).
"""

bl_info = {
    "name": "Nimbus",
    "author": "Nimbus developers",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "Properties > Render > Render Engine > Nimbus",
    "description": "Render clouds and OpenVDB volumes with the Nimbus cloud renderer "
                   "(libnimbus.so)",
    "category": "Render",
}

import importlib.util
import os
import sys
import threading
import traceback

import bpy
import numpy as np

from . import export

_HERE = os.path.dirname(os.path.abspath(__file__))
_BINDING_PLACES = [os.path.join(_HERE, "nimbus.py"),
                   os.path.join(_HERE, "..", "..", "..", "examples", "python", "nimbus.py")]


def binding():
    """The ctypes module nimbus.py (loaded once, as module "nimbus" unless one is loaded)."""
    mod = sys.modules.get("nimbus")
    if mod is not None and hasattr(mod, "Context"):
        return mod
    for path in _BINDING_PLACES:
        if os.path.exists(path):
            spec = importlib.util.spec_from_file_location("nimbus", os.path.normpath(path))
            mod = importlib.util.module_from_spec(spec)
            spec.loader.exec_module(mod)
            sys.modules["nimbus"] = mod
            return mod
    raise ImportError("nimbus.py (the ctypes binding of libnimbus.so) not found in %s"
                      % " or ".join(os.path.normpath(p) for p in _BINDING_PLACES))


def library_path(context=None):
    prefs = (context or bpy.context).preferences.addons.get(__name__)
    lib = prefs.preferences.library if prefs else ""
    return bpy.path.abspath(lib) if lib else None  # None: $NIMBUS_LIBRARY, then nimbus.py's


# ACEScg (Nimbus's working space with its built-in OCIO config) -> linear Rec.709 (Blender's
# scene linear): both primaries to XYZ, Bradford adaptation from the ACES white (~D60) to D65,
# as OCIO's "ACES-AP1_to_LINEAR-REC709_BFD" (which `nimbus --set output.color_space=lin_rec709`
# applies) derives it.
def _rgb_to_xyz(prims, white):
    xyz = np.array([[x / y, 1.0, (1.0 - x - y) / y] for x, y in prims]).T
    wx, wy = white
    w = np.array([wx / wy, 1.0, (1.0 - wx - wy) / wy])
    return xyz * np.linalg.solve(xyz, w)


def _acescg_to_rec709():
    ap1 = _rgb_to_xyz([(0.713, 0.293), (0.165, 0.830), (0.128, 0.044)], (0.32168, 0.33767))
    rec = _rgb_to_xyz([(0.64, 0.33), (0.30, 0.60), (0.15, 0.06)], (0.3127, 0.3290))
    brad = np.array([[0.8951, 0.2664, -0.1614], [-0.7502, 1.7135, 0.0367],
                     [0.0389, -0.0685, 1.0296]])
    src = brad @ (ap1 @ np.ones(3))
    dst = brad @ (rec @ np.ones(3))
    cat = np.linalg.inv(brad) @ np.diag(dst / src) @ brad
    return np.linalg.inv(rec) @ cat @ ap1


ACESCG_TO_REC709 = _acescg_to_rec709()


def to_blender_pixels(rgba):
    """Nimbus's RGBA (height x width x 4, ACEScg, premultiplied, top row first) as Blender's
    render-result rectangle: (width * height) x 4, linear Rec.709, bottom row first."""
    out = np.empty_like(rgba)
    out[..., :3] = rgba[..., :3] @ ACESCG_TO_REC709.T.astype(np.float32)
    out[..., 3] = rgba[..., 3]
    return np.ascontiguousarray(out[::-1]).reshape(-1, 4)


class NimbusPreferences(bpy.types.AddonPreferences):
    bl_idname = __name__
    library: bpy.props.StringProperty(
        name="Library", subtype="FILE_PATH",
        description="libnimbus.so.0 to render with (empty: $NIMBUS_LIBRARY, else the "
                    "checkout's build/, else the loader's path)")

    def draw(self, context):
        self.layout.prop(self, "library")


class NimbusSceneSettings(bpy.types.PropertyGroup):
    integrator: bpy.props.EnumProperty(
        name="Integrator", default="march",
        items=[("march", "March", "Fast single scattering with approximations (production)"),
               ("pathtrace", "Path trace", "Unbiased multiple scattering (references)")])
    spp: bpy.props.IntProperty(name="Samples", default=16, min=1, max=1048576,
                               description="Path-traced samples per pixel")
    step: bpy.props.FloatProperty(name="Step", default=0.0, min=0.0, unit="LENGTH",
                                  description="Ray-march step (0: chosen from the VDB voxels)")
    overrides: bpy.props.StringProperty(
        name="Overrides",
        description="Further Nimbus settings, ';'-separated, as `nimbus render --set` takes "
                    "them: render.octaves=4; medium.g=0.6")


class NimbusRenderEngine(bpy.types.RenderEngine):
    bl_idname = "NIMBUS"
    bl_label = "Nimbus"
    bl_use_preview = False
    bl_use_postprocess = True

    def render(self, depsgraph):
        scene = depsgraph.scene
        rd = scene.render
        w = max(1, rd.resolution_x * rd.resolution_percentage // 100)
        h = max(1, rd.resolution_y * rd.resolution_percentage // 100)
        try:
            nimbus = binding()
        except Exception as e:  # ImportError, or the library's major version
            return self._fail("Nimbus: %s" % e)
        try:
            text = export.scene_toml(depsgraph, warn=self._warn, render_size=(w, h))
        except export.ExportError as e:
            return self._fail("Nimbus: %s" % e)
        except Exception as e:  # a bug of the add-on: say so in Blender, traceback on stderr
            traceback.print_exc()
            return self._fail("Nimbus: the add-on failed to export the scene (%s: %s); "
                              "please report it" % (type(e).__name__, e))

        try:
            ctx = nimbus.Context(library=library_path())
        except (OSError, ImportError) as e:  # not found; or of another major version
            return self._fail("Nimbus: cannot load libnimbus.so (%s); set the add-on's "
                              "Library preference or $NIMBUS_LIBRARY" % e)
        with ctx:
            try:
                ctx.load_string(text, name="%s.nimbus.toml" % bpy.path.clean_name(scene.name))
                for a in export.overrides(scene):
                    ctx.set(a)
            except nimbus.NimbusError as e:
                return self._fail("Nimbus: %s" % e.message)
            for line in ctx.warnings():
                self._warn(line)
            rgba, error, cancelled = self._render_frame(ctx, nimbus, scene.frame_current)
            for line in ctx.warnings():
                self._warn(line)
        if cancelled:
            self.update_stats("", "Nimbus: cancelled at %d/%d tiles"
                              % (self._done, self._total))
            return
        if error is not None:
            if "level set" in error:
                error += " [Blender: the object's custom property nimbus_levelset_to_fog = 1]"
            return self._fail("Nimbus: %s" % error)
        result = self.begin_result(0, 0, w, h)
        combined = result.layers[0].passes["Combined"]
        pixels = to_blender_pixels(rgba)
        try:
            combined.rect.foreach_set(pixels)  # one copy: 0.01 s at 1920x1080
        except (AttributeError, TypeError, ValueError):
            combined.rect = pixels  # element by element: about 1 s at 1920x1080
        self.end_result(result)
        self.update_stats("", "Nimbus: rendered %dx%d, %d/%d tiles" % (w, h, self._done,
                                                                       self._total))

    def _render_frame(self, ctx, nimbus, frame):
        """Renders on a thread of its own while this one polls Blender's cancel (test_break)
        and shows the progress: (pixels or None, error message or None, cancelled)."""
        self._done, self._total = 0, 0
        out = {}

        def progress(done, total):  # on a worker thread of the library: only store
            self._done, self._total = done, total
            return False

        def run():
            try:
                out["rgba"] = ctx.render(frame=frame, progress=progress)
            except nimbus.Interrupted:
                out["cancelled"] = True
            except nimbus.NimbusError as e:
                out["error"] = e.message
            except Exception as e:  # MemoryError from NumPy, ...
                out["error"] = "%s: %s" % (type(e).__name__, e)

        self.update_stats("", "Nimbus: rendering frame %d" % frame)
        t = threading.Thread(target=run, name="nimbus-render")
        t.start()
        asked = False
        shown = -1
        while t.is_alive():
            t.join(0.05)
            if not asked and self.test_break():
                ctx.cancel()
                asked = True
            if self._total and self._done != shown:
                shown = self._done
                self.update_progress(self._done / self._total)
                self.update_stats("", "Nimbus: frame %d, tile %d/%d"
                                  % (frame, self._done, self._total))
        if asked and "rgba" in out:  # finished before the cancel landed: keep the frame
            return out["rgba"], None, False
        return out.get("rgba"), out.get("error"), out.get("cancelled", False) or asked

    def _warn(self, message):
        self.report({"WARNING"}, "Nimbus: %s" % message)

    def _fail(self, message):
        self.report({"ERROR"}, message)
        self.error_set(message)


class NIMBUS_OT_export_scene(bpy.types.Operator):
    """Write the scene as a Nimbus scene file (TOML) for the nimbus command"""
    bl_idname = "nimbus.export_scene"
    bl_label = "Export Nimbus Scene"

    filepath: bpy.props.StringProperty(subtype="FILE_PATH")
    filename_ext = ".toml"

    def execute(self, context):
        warnings = []
        try:
            text = export.scene_toml(context.evaluated_depsgraph_get(), warn=warnings.append)
        except export.ExportError as e:
            self.report({"ERROR"}, "Nimbus: %s" % e)
            return {"CANCELLED"}
        extra = export.overrides(context.scene)
        if extra:
            text += "# render settings of the add-on (apply with --set):\n" + "".join(
                "#   --set %s\n" % a for a in extra)
        path = bpy.path.abspath(self.filepath)
        tmp = path + ".tmp"
        with open(tmp, "w") as f:
            f.write(text)
        os.replace(tmp, path)
        for w in warnings:
            self.report({"WARNING"}, "Nimbus: %s" % w)
        self.report({"INFO"}, "Nimbus: wrote %s" % path)
        return {"FINISHED"}

    def invoke(self, context, event):
        if not self.filepath:
            self.filepath = bpy.path.ensure_ext(bpy.path.display_name_sanitized(
                context.scene.name), ".toml")
        context.window_manager.fileselect_add(self)
        return {"RUNNING_MODAL"}


class NIMBUS_OT_cloud_add(bpy.types.Operator):
    """Add a Nimbus cumulus cloud layer: an Empty box whose custom properties are the cloud's"""
    bl_idname = "nimbus.cloud_add"
    bl_label = "Nimbus Cloud"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        obj = bpy.data.objects.new("Nimbus Cloud", None)
        obj.empty_display_type = "CUBE"
        obj.location = (0.0, 0.0, 3.0)
        obj.scale = (20.0, 20.0, 1.5)  # the default cumulus layer, z from 1.5 to 4.5
        obj[export.CLOUD_MARKER] = "cumulus"
        obj["nimbus_coverage"] = 0.85
        obj["nimbus_density"] = 1.0
        obj["nimbus_seed"] = 1
        context.collection.objects.link(obj)
        return {"FINISHED"}


class NIMBUS_PT_settings(bpy.types.Panel):
    bl_label = "Nimbus"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "render"
    COMPAT_ENGINES = {"NIMBUS"}

    @classmethod
    def poll(cls, context):
        return context.engine in cls.COMPAT_ENGINES

    def draw(self, context):
        s = context.scene.nimbus
        col = self.layout.column()
        col.prop(s, "integrator")
        if s.integrator == "pathtrace":
            col.prop(s, "spp")
        col.prop(s, "step")
        col.prop(s, "overrides")
        col.operator(NIMBUS_OT_export_scene.bl_idname)


def _menu_add(self, context):
    self.layout.operator(NIMBUS_OT_cloud_add.bl_idname, icon="OUTLINER_OB_VOLUME")


def _panels():
    """Blender's own panels that show for our engine too (camera, light, world, dimensions)."""
    names = ["DATA_PT_camera", "DATA_PT_lens", "DATA_PT_camera_display", "DATA_PT_light",
             "DATA_PT_EEVEE_light", "WORLD_PT_context_world", "DATA_PT_volume_file",
             "DATA_PT_volume_grids"]
    return [getattr(bpy.types, n) for n in names if hasattr(bpy.types, n)]


_CLASSES = (NimbusPreferences, NimbusSceneSettings, NimbusRenderEngine, NIMBUS_OT_export_scene,
            NIMBUS_OT_cloud_add, NIMBUS_PT_settings)


def register():
    for c in _CLASSES:
        bpy.utils.register_class(c)
    bpy.types.Scene.nimbus = bpy.props.PointerProperty(type=NimbusSceneSettings)
    bpy.types.VIEW3D_MT_add.append(_menu_add)
    for p in _panels():
        p.COMPAT_ENGINES.add("NIMBUS")


def unregister():
    for p in _panels():
        p.COMPAT_ENGINES.discard("NIMBUS")
    bpy.types.VIEW3D_MT_add.remove(_menu_add)
    del bpy.types.Scene.nimbus
    for c in reversed(_CLASSES):
        bpy.utils.unregister_class(c)
