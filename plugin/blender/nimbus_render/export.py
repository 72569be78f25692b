"""The Blender scene as a Nimbus scene file (TOML text): camera, sun, world colour, volumes.

Axes: Blender is right-handed with +Z up; Nimbus is right-handed with +Y up (core/camera.h:
right = forward x up). A Blender point (x, y, z) is the Nimbus point (x, z, -y): a rotation of
-90 degrees about X, so lengths, angles and handedness are kept and one Blender unit is one
Nimbus world unit. docs/blender.md has the whole mapping.
"""

import math
import os

import bpy
from mathutils import Matrix, Vector

# Blender world -> Nimbus world: (x, y, z) -> (x, z, -y), the rotation by -90 degrees about X
# written exactly (Matrix.Rotation would leave cos(90 degrees) ~ 1e-17 terms)
TO_NIMBUS = Matrix(((1.0, 0.0, 0.0, 0.0), (0.0, 0.0, 1.0, 0.0), (0.0, -1.0, 0.0, 0.0),
                    (0.0, 0.0, 0.0, 1.0)))

# The keys of a cumulus [field] a cloud object may set as "nimbus_<key>" custom properties
# (examples/scenes/reference.md); bounds come from the object itself.
CLOUD_VECTOR_KEYS = {"wind", "detail_wind"}  # directions: converted to Nimbus axes
CLOUD_MARKER = "nimbus_cloud"
PROPERTY_PREFIX = "nimbus_"


class ExportError(Exception):
    """The Blender scene cannot be rendered by Nimbus; the message says why."""


def _num(v):
    """A number as TOML text (repr keeps every digit of a Python float)."""
    v = float(v)
    if not math.isfinite(v):
        raise ExportError("non-finite number %r" % v)
    return repr(v)


def _vec(v):
    return "[" + ", ".join(_num(c) for c in v) + "]"


def _str(s):
    return '"' + str(s).replace("\\", "\\\\").replace('"', '\\"') + '"'


def _value(v):
    """A custom property value as TOML text."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return _num(v)
    if isinstance(v, str):
        return _str(v)
    try:
        return "[" + ", ".join(_value(x) for x in v) + "]"
    except TypeError:
        raise ExportError("custom property value %r is not a number, string or array" % (v,))


def to_nimbus_point(p):
    return (TO_NIMBUS @ Vector((p[0], p[1], p[2], 1.0))).xyz


def to_nimbus_dir(d):
    return (TO_NIMBUS.to_3x3() @ Vector(d)).normalized()


def camera_fov_y(cam, width, height, pixel_aspect=1.0):
    """Vertical field of view (degrees) of a perspective Blender camera at this resolution,
    following Blender's sensor fit (AUTO: the sensor width spans the larger image side)."""
    aspect = (width * pixel_aspect) / float(height)
    fit = cam.sensor_fit
    if fit == "AUTO":
        fit = "HORIZONTAL" if aspect >= 1.0 else "VERTICAL"
        sensor = cam.sensor_width
    else:
        sensor = cam.sensor_width if fit == "HORIZONTAL" else cam.sensor_height
    half = sensor / (2.0 * cam.lens)  # tangent of the half angle along the fitted side
    tan_half_y = half / aspect if fit == "HORIZONTAL" else half
    return math.degrees(2.0 * math.atan(tan_half_y))


def _world_sky(world, warn):
    """(kind, zenith RGB) of the world: its Background colour x strength as a uniform sky."""
    if world is None:
        return "none", (0.0, 0.0, 0.0)
    color, strength = tuple(world.color), 1.0
    if world.use_nodes and world.node_tree:
        out = next((n for n in world.node_tree.nodes
                    if n.type == "OUTPUT_WORLD" and n.is_active_output), None)
        links = out.inputs["Surface"].links if out else ()
        bg = links[0].from_node if links else None
        if bg is None:
            return "none", (0.0, 0.0, 0.0)
        if bg.type != "BACKGROUND":
            warn("world: a %s node feeds the output; only a Background node's colour is used, "
                 "the sky is world.color" % bg.type)
        else:
            if bg.inputs["Color"].is_linked:
                warn("world: the Background colour is driven by nodes (a texture?); "
                     "the sky is its unlinked default colour")
            color = tuple(bg.inputs["Color"].default_value)[:3]
            strength = 1.0 if bg.inputs["Strength"].is_linked else bg.inputs["Strength"].default_value
    zenith = tuple(max(0.0, c * strength) for c in color[:3])
    return "uniform", zenith


def _cloud_field(obj, warn):
    """[field] lines of a Nimbus cloud object (an Empty marked with nimbus_cloud)."""
    kind = obj.get(CLOUD_MARKER)
    kind = "cumulus" if kind in (1, True, "1", "") or kind is None else str(kind)
    if kind not in ("cumulus", "homogeneous"):
        raise ExportError("%s: nimbus_cloud = %r: a cloud object is \"cumulus\" or "
                          "\"homogeneous\"" % (obj.name, kind))
    size = obj.empty_display_size if obj.type == "EMPTY" else 1.0
    corners = [obj.matrix_world @ Vector((sx * size, sy * size, sz * size))
               for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]
    pts = [to_nimbus_point(c) for c in corners]
    lo = [min(p[i] for p in pts) for i in range(3)]
    hi = [max(p[i] for p in pts) for i in range(3)]
    rot = obj.matrix_world.to_quaternion()
    if rot.angle > 1e-5 and abs(rot.angle - math.pi) > 1e-5:
        warn("%s: a cloud layer is axis-aligned: its rotation is ignored (the box is the "
             "bounding box of the rotated one)" % obj.name)
    lines = ["[field]", "kind = %s" % _str(kind),
             "bounds_min = %s" % _vec(lo), "bounds_max = %s" % _vec(hi)]
    for key in sorted(obj.keys()):
        if not key.startswith(PROPERTY_PREFIX) or key == CLOUD_MARKER:
            continue
        name = key[len(PROPERTY_PREFIX):]
        if name in ("bounds_min", "bounds_max", "kind"):
            raise ExportError("%s: %s is set by the object's location, scale and display size "
                              "(or nimbus_cloud), not by a custom property" % (obj.name, key))
        v = obj[key]
        if name in CLOUD_VECTOR_KEYS:
            v = tuple(TO_NIMBUS.to_3x3() @ Vector(tuple(v)))
        lines.append("%s = %s" % (name, _value(v)))
    return lines


def _volume_path(obj):
    vol = obj.data
    if not vol.filepath:
        raise ExportError("%s: the volume has no .vdb file" % obj.name)
    path = os.path.abspath(bpy.path.abspath(vol.filepath, library=vol.library))
    return path


def _default_grid(vol):
    """"density" when the file has it (or Blender has not read the file), else the grid that is
    active in Blender's Grids panel."""
    try:
        if not vol.grids.is_loaded:
            vol.grids.load()  # the file's grid list (metadata), as the Grids panel reads it
        names = [g.name for g in vol.grids]
        active = vol.grids.active_index
    except (AttributeError, RuntimeError):
        return "density"
    if not names or "density" in names:
        return "density"
    return names[active] if 0 <= active < len(names) else names[0]


def _placement(obj, warn):
    """translate, rotate (degrees, R = Rz Ry Rx), scale of the object in Nimbus's world."""
    m = TO_NIMBUS @ obj.matrix_world
    loc, quat, scale = m.decompose()
    if min(scale) <= 0.0:
        raise ExportError("%s: negative or zero scale %s: Nimbus places volumes with a positive "
                          "scale only (mirror the VDB instead)" % (obj.name, tuple(scale)))
    back = Matrix.LocRotScale(loc, quat, scale)
    if max(abs(a - b) for ra, rb in zip(m, back) for a, b in zip(ra, rb)) > 1e-4 * max(
            1.0, max(abs(x) for x in scale)):
        warn("%s: the object's transform has a shear (a non-uniformly scaled parent?); "
             "Nimbus uses its closest translate/rotate/scale" % obj.name)
    euler = quat.to_euler("XYZ")  # Blender's XYZ Euler is R = Rz Ry Rx, as Nimbus's rotate
    return loc, tuple(math.degrees(a) for a in euler), scale


def scene_toml(depsgraph, warn=print, render_size=None):
    """The Nimbus scene file of the evaluated scene of `depsgraph`. `warn(message)` receives
    what is approximated or ignored. Raises ExportError for what cannot be rendered."""
    scene = depsgraph.scene
    rd = scene.render
    props = getattr(scene, "nimbus", None)
    width, height = render_size or (max(1, rd.resolution_x * rd.resolution_percentage // 100),
                                    max(1, rd.resolution_y * rd.resolution_percentage // 100))
    objects = [o for o in depsgraph.objects]

    cam_obj = scene.camera
    if cam_obj is None:
        raise ExportError("the scene has no active camera")
    cam_obj = cam_obj.evaluated_get(depsgraph)
    cam = cam_obj.data
    if cam.type != "PERSP":
        raise ExportError("camera %s: only perspective cameras are supported (this one is %s)"
                          % (cam_obj.name, cam.type))
    if cam.shift_x or cam.shift_y:
        warn("camera %s: lens shift is ignored" % cam_obj.name)
    if rd.pixel_aspect_x != rd.pixel_aspect_y:
        warn("pixel aspect %g:%g is ignored (square pixels)" % (rd.pixel_aspect_x,
                                                                rd.pixel_aspect_y))
    if rd.use_border:
        warn("the render region (border) is ignored: the whole frame is rendered")
    cm = cam_obj.matrix_world
    rot = cm.to_quaternion().to_matrix()
    position = to_nimbus_point(cm.translation)
    forward = to_nimbus_dir(rot @ Vector((0.0, 0.0, -1.0)))
    up = to_nimbus_dir(rot @ Vector((0.0, 1.0, 0.0)))
    fov = camera_fov_y(cam, width, height)
    if not 0.0 < fov < 180.0:
        raise ExportError("camera %s: vertical field of view %g degrees is outside (0, 180)"
                          % (cam_obj.name, fov))

    fps = rd.fps / rd.fps_base
    lines = ["# Nimbus scene exported by the Blender add-on nimbus_render from scene %s"
             % _str(scene.name),
             'color_space = "lin_rec709"  # Blender colours are linear Rec.709',
             "frames = %s" % _str(str(scene.frame_current)), "",
             "[camera]",
             "position = %s" % _vec(position),
             "look_at = %s" % _vec(position + forward),
             "up = %s" % _vec(up),
             "fov = %s" % _num(fov),
             "width = %d" % width, "height = %d" % height, ""]

    suns = sorted((o for o in objects if o.type == "LIGHT" and o.data.type == "SUN"),
                  key=lambda o: o.name)
    others = [o.name for o in objects if o.type == "LIGHT" and o.data.type != "SUN"]
    if others:
        warn("only sun lights are rendered; ignored: %s" % ", ".join(sorted(others)))
    lines.append("[sun]")
    if suns:
        sun = suns[0]
        if len(suns) > 1:
            warn("only one sun is rendered (%s); ignored: %s"
                 % (sun.name, ", ".join(o.name for o in suns[1:])))
        toward = to_nimbus_dir(sun.matrix_world.to_quaternion() @ Vector((0.0, 0.0, 1.0)))
        lines += ["direction = %s" % _vec(toward),
                  "irradiance = %s" % _vec(tuple(sun.data.color)),
                  "intensity = %s" % _num(sun.data.energy),
                  "angular_diameter = %s" % _num(min(30.0, math.degrees(sun.data.angle)))]
    else:
        lines.append("enabled = false")
    lines.append("")

    kind, zenith = _world_sky(scene.world, warn)
    lines += ["[sky]", "kind = %s" % _str(kind)]
    if kind != "none":
        lines.append("zenith = %s" % _vec(zenith))
    lines.append("")

    clouds = sorted((o for o in objects if o.get(CLOUD_MARKER) is not None),
                    key=lambda o: o.name)
    vdbs = sorted((o for o in objects if o.type == "VOLUME"), key=lambda o: o.name)
    if len(clouds) > 1:
        raise ExportError("one Nimbus cloud object per scene (the [field]); found %s"
                          % ", ".join(o.name for o in clouds))
    field, volumes, instances = [], [], []
    if clouds:
        field = _cloud_field(clouds[0], warn)
        if vdbs:
            instances.append(["[[instance]]", 'volume = "field"'])
    for obj in vdbs:
        grid = obj.get("nimbus_grid")
        if grid is None:
            grid = _default_grid(obj.data)
        density = float(obj.get("nimbus_density", 1.0))
        if obj.data.is_sequence:
            warn("%s: a VDB sequence renders the file named (%s), not the frame's"
                 % (obj.name, obj.data.filepath))
        body = ["path = %s" % _str(_volume_path(obj)), "grid = %s" % _str(str(grid))]
        if obj.get("nimbus_levelset_to_fog"):
            body.append("levelset_to_fog = true")
        if not field:
            name = "field"
            field = ["[field]", 'kind = "vdb"'] + body
        else:
            name = obj.name if obj.name != "field" else "field (object)"  # in error messages
            volumes.append(["[[volume]]", "name = %s" % _str(name)] + body)
        loc, rot_deg, scale = _placement(obj, warn)
        instances.append(["[[instance]]  # object %s" % _str(obj.name),
                          "volume = %s" % _str(name),
                          "translate = %s" % _vec(loc), "rotate = %s" % _vec(rot_deg),
                          "scale = %s" % _vec(scale), "density = %s" % _num(density)])
    if not field:
        warn("no volume to render (a Volume object with a .vdb file, or a Nimbus cloud): "
             "only the sky is rendered")
        field = ["[field]", 'kind = "homogeneous"', "density = 0.0"]
    lines += field + [""]
    for block in volumes + instances:
        lines += block + [""]

    lines += ["[render]", "fps = %s" % _num(fps)]
    if rd.film_transparent:
        lines.append('background = "transparent"')
    if rd.threads_mode == "FIXED":
        lines.append("threads = %d" % rd.threads)
    if props is not None:
        lines.append("integrator = %s" % _str(props.integrator))
        if props.integrator == "pathtrace":
            lines.append("spp = %d" % props.spp)
        lines.append("step = %s" % _num(props.step))
    lines.append("")
    return "\n".join(lines)


def overrides(scene):
    """The scene's extra `section.key=value` assignments (Nimbus render settings, ';'-separated)."""
    props = getattr(scene, "nimbus", None)
    if props is None:
        return []
    return [a.strip() for a in props.overrides.split(";") if a.strip()]
