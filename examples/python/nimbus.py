"""Render Nimbus scenes from Python: a ctypes binding of libnimbus.so (plugin/capi/nimbus.h).

    import nimbus

    with nimbus.Context() as ctx:
        ctx.load_file("examples/scenes/cumulus.toml")
        ctx.set("camera.width", 320)           # or ctx.set("camera.width=320"), as --set
        ctx.set("camera.height", 180)
        print(ctx.plan()["explain"])          # what `nimbus render --explain` prints
        rgba = ctx.render()                   # NumPy float32, height x width x 4
        layers = ctx.render(aovs=("depth",))  # {"rgba": ..., "depth": height x width x 1}
        ctx.render_write(path="out/frame.exr")

Errors raise NimbusError subclasses (BadInput, OutputError, OutOfMemory, Interrupted,
InternalError) carrying the library's message, file and line. Pixels are scene-linear in the
scene's working space (ACEScg by default), RGBA premultiplied, the top row first.

The library is found at `library=` or $NIMBUS_LIBRARY, else in ../../build/ beside this file
(a build of this repository), else wherever the dynamic loader finds libnimbus.so.0.
Needs Debian's python3 and python3-numpy. One context per thread at a time; different contexts
may render at once from different threads (the GIL is released while the library renders).
"""

import ctypes
import os

import numpy as np

__all__ = ["Context", "NimbusError", "BadInput", "OutputError", "OutOfMemory", "Interrupted",
           "InternalError", "version", "library_path"]

# nimbus_status
OK, INTERNAL, BAD_INPUT, IO, NO_MEMORY, INTERRUPTED = 0, 1, 2, 3, 4, 130
# nimbus_aov: name -> (value, channels)
AOVS = {"rgba": (0, 4), "transmittance": (1, 3), "depth": (2, 1)}
# nimbus_plan_item, in the header's order
PLAN_ITEMS = ["width", "height", "integrator", "shadows", "ambient", "bake_noise",
              "light_volume", "volumes", "instances", "surfaces", "solids",
              "aov_transmittance", "aov_depth", "reads_grids", "refused", "warnings"]


class NimbusError(Exception):
    """A failed call: `status` (the nimbus command's exit code), `message`, `file`, `line`."""

    def __init__(self, status, message, file="", line=0):
        super().__init__(message)
        self.status = status
        self.message = message
        self.file = file
        self.line = line


class BadInput(NimbusError):
    """Scene file, override, colour configuration, VDB file, or a misused call (status 2)."""


class OutputError(NimbusError):
    """An output could not be written (status 3)."""


class OutOfMemory(NimbusError):
    """Out of memory (status 4)."""


class Interrupted(NimbusError):
    """The render was cancelled (status 130)."""


class InternalError(NimbusError):
    """A bug in Nimbus (status 1)."""


_ERRORS = {BAD_INPUT: BadInput, IO: OutputError, NO_MEMORY: OutOfMemory,
           INTERRUPTED: Interrupted, INTERNAL: InternalError}

_PROGRESS = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_void_p, ctypes.c_int, ctypes.c_int)


class _Buffer(ctypes.Structure):
    _fields_ = [("aov", ctypes.c_int), ("data", ctypes.POINTER(ctypes.c_float)),
                ("count", ctypes.c_size_t)]


def library_path():
    """Where the library is taken from when Context() is given none."""
    env = os.environ.get("NIMBUS_LIBRARY")
    if env:
        return env
    here = os.path.dirname(os.path.abspath(__file__))
    built = os.path.join(here, "..", "..", "build", "libnimbus.so.0")
    return os.path.normpath(built) if os.path.exists(built) else "libnimbus.so.0"


_libs = {}


def _load(path):
    """The library at `path` with its functions' signatures declared (loaded once per path)."""
    if path in _libs:
        return _libs[path]
    lib = ctypes.CDLL(path)  # CDLL: the GIL is released during calls
    ctx_p, c_int, c_char_p, c_size_t = ctypes.c_void_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_size_t
    sig = {
        "nimbus_version": (c_char_p, []),
        "nimbus_version_numbers": (None, [ctypes.POINTER(c_int)] * 3),
        "nimbus_status_name": (c_char_p, [c_int]),
        "nimbus_create": (ctx_p, []),
        "nimbus_destroy": (None, [ctx_p]),
        "nimbus_load_file": (c_int, [ctx_p, c_char_p]),
        "nimbus_load_string": (c_int, [ctx_p, c_char_p, c_char_p]),
        "nimbus_set": (c_int, [ctx_p, c_char_p]),
        "nimbus_clear_overrides": (c_int, [ctx_p]),
        "nimbus_frames": (c_int, [ctx_p, ctypes.POINTER(c_int), c_int, ctypes.POINTER(c_int)]),
        "nimbus_plan_int": (c_int, [ctx_p, c_int, c_int, ctypes.POINTER(c_int)]),
        "nimbus_plan_explain": (c_char_p, [ctx_p, c_int]),
        "nimbus_output_path": (c_char_p, [ctx_p, c_int]),
        "nimbus_set_progress": (c_int, [ctx_p, _PROGRESS, ctypes.c_void_p]),
        "nimbus_cancel": (c_int, [ctx_p]),
        "nimbus_render": (c_int, [ctx_p, c_int, ctypes.POINTER(ctypes.c_float), c_size_t]),
        "nimbus_render_aovs": (c_int, [ctx_p, c_int, ctypes.POINTER(_Buffer), c_int]),
        "nimbus_render_write": (c_int, [ctx_p, c_int, c_char_p]),
        "nimbus_warnings": (c_char_p, [ctx_p]),
        "nimbus_last_error_code": (c_int, [ctx_p]),
        "nimbus_last_error": (c_char_p, [ctx_p]),
        "nimbus_last_error_file": (c_char_p, [ctx_p]),
        "nimbus_last_error_line": (c_int, [ctx_p]),
    }
    for name, (res, args) in sig.items():
        fn = getattr(lib, name)
        fn.restype = res
        fn.argtypes = args
    major = ctypes.c_int()
    lib.nimbus_version_numbers(ctypes.byref(major), None, None)
    if major.value != 0:
        raise ImportError("%s is Nimbus %s; this module speaks the ABI of major version 0"
                          % (path, lib.nimbus_version().decode()))
    _libs[path] = lib
    return lib


def version(library=None):
    """The library's version string, e.g. "0.2.0"."""
    return _load(library or library_path()).nimbus_version().decode()


def _toml(value):
    """A Python value as the TOML text of an override."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float, np.integer, np.floating)):
        return repr(float(value)) if isinstance(value, (float, np.floating)) else str(int(value))
    if isinstance(value, (list, tuple, np.ndarray)):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    text = str(value)
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _text(s):
    return s.encode() if isinstance(s, str) else s


class Context:
    """One loaded scene with its overrides (a nimbus_context)."""

    def __init__(self, library=None):
        self._lib = _load(library or library_path())
        self._ctx = self._lib.nimbus_create()
        if not self._ctx:
            raise MemoryError("nimbus_create: out of memory")
        self._progress = None  # the ctypes callback, kept alive while set

    # -- life time --
    def close(self):
        if self._ctx:
            self._lib.nimbus_destroy(self._ctx)
            self._ctx = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __del__(self):
        try:
            self.close()
        except Exception:
            pass

    # -- errors --
    def _check(self, status):
        if status != OK:
            self._raise(status)

    def _raise(self, status=None):
        raise self._error(status)

    def _error(self, status=None):
        """The context's last error as an exception (read before the next call clears it)."""
        lib, c = self._lib, self._ctx
        if status is None:
            status = lib.nimbus_last_error_code(c)
        return _ERRORS.get(status, NimbusError)(
            status, (lib.nimbus_last_error(c) or b"").decode(errors="replace"),
            (lib.nimbus_last_error_file(c) or b"").decode(errors="replace"),
            lib.nimbus_last_error_line(c))

    def _live(self):
        if not self._ctx:
            raise ValueError("the context is closed")
        return self._ctx

    # -- scenes --
    def load_file(self, path):
        """Loads a scene file (with the overrides set so far)."""
        self._check(self._lib.nimbus_load_file(self._live(), _text(os.fspath(path))))

    def load_string(self, text, name=None):
        """Loads a scene from TOML text; `name` stands for the file in messages."""
        self._check(self._lib.nimbus_load_string(self._live(), _text(text),
                                                 None if name is None else _text(name)))

    def set(self, key, value=None):
        """Overrides a parameter: set("render.step=0.5") as --set takes it, or
        set("render.step", 0.5) with a Python value (str, number, bool, list)."""
        assignment = key if value is None else "%s=%s" % (key, _toml(value))
        self._check(self._lib.nimbus_set(self._live(), _text(assignment)))

    def clear_overrides(self):
        self._check(self._lib.nimbus_clear_overrides(self._live()))

    def frames(self):
        """The frames of the scene's frame spec."""
        count = ctypes.c_int()
        self._check(self._lib.nimbus_frames(self._live(), None, 0, ctypes.byref(count)))
        buf = (ctypes.c_int * count.value)()
        self._check(self._lib.nimbus_frames(self._live(), buf, count.value, ctypes.byref(count)))
        return list(buf)

    def _frame(self, frame):
        return self.frames()[0] if frame is None else int(frame)

    def plan(self, frame=None):
        """The frame's plan: every nimbus_plan_item by name, "integrator" as a word, and
        "explain" (what `nimbus render --explain` prints)."""
        frame = self._frame(frame)
        out = {}
        v = ctypes.c_int()
        for i, name in enumerate(PLAN_ITEMS):
            self._check(self._lib.nimbus_plan_int(self._live(), frame, i, ctypes.byref(v)))
            out[name] = v.value
        out["integrator"] = "pathtrace" if out["integrator"] == 1 else "march"
        text = self._lib.nimbus_plan_explain(self._live(), frame)
        if text is None:
            self._raise()
        out["explain"] = text.decode()
        out["frame"] = frame
        return out

    def output_path(self, frame=None):
        p = self._lib.nimbus_output_path(self._live(), self._frame(frame))
        if p is None:
            self._raise()
        return p.decode()

    def warnings(self):
        """The warnings collected since the last call, as a list of lines."""
        w = self._lib.nimbus_warnings(self._live())
        if w is None:
            self._raise()
        return [line for line in w.decode().split("\n") if line]

    # -- rendering --
    def cancel(self):
        """Stops the render running on this context (from any thread)."""
        self._lib.nimbus_cancel(self._live())

    def _with_progress(self, progress, call):
        """Runs call() with `progress(done, total)` as the callback (a true return cancels);
        an exception raised by it cancels the render and is raised here."""
        if progress is None:
            self._check(self._lib.nimbus_set_progress(self._live(), _PROGRESS(), None))
            return call()
        raised = []

        def trampoline(_user, done, total):
            try:
                return 1 if progress(done, total) else 0
            except BaseException as e:  # noqa: B902 - handed back to the caller below
                raised.append(e)
                return 1

        cb = _PROGRESS(trampoline)
        self._check(self._lib.nimbus_set_progress(self._live(), cb, None))
        failure = None
        try:
            status = call()
            if status != OK:  # taken now: removing the callback below clears the error
                failure = self._error(status)
        finally:
            self._lib.nimbus_set_progress(self._live(), _PROGRESS(), None)
        if raised:
            raise raised[0]
        if failure is not None:
            raise failure
        return status

    def render(self, frame=None, aovs=(), progress=None):
        """Renders a frame. Without `aovs`, a float32 array height x width x 4 (RGBA); with
        layer names ("transmittance", "depth"), a dict of arrays (height x width x channels)
        that also holds "rgba"."""
        frame = self._frame(frame)
        v = ctypes.c_int()
        self._check(self._lib.nimbus_plan_int(self._live(), frame, 0, ctypes.byref(v)))
        w = v.value
        self._check(self._lib.nimbus_plan_int(self._live(), frame, 1, ctypes.byref(v)))
        h = v.value
        names = ["rgba"] + [a for a in aovs if a != "rgba"]
        for a in names:
            if a not in AOVS:
                raise ValueError("unknown layer %r (known: %s)" % (a, ", ".join(AOVS)))
        arrays = {a: np.empty((h, w, AOVS[a][1]), dtype=np.float32) for a in names}
        bufs = (_Buffer * len(names))()
        for i, a in enumerate(names):
            arr = arrays[a]
            bufs[i] = _Buffer(AOVS[a][0], arr.ctypes.data_as(ctypes.POINTER(ctypes.c_float)),
                              arr.size)
        status = self._with_progress(
            progress, lambda: self._lib.nimbus_render_aovs(self._live(), frame, bufs, len(names)))
        self._check(status)
        return arrays if aovs else arrays["rgba"]

    def render_write(self, frame=None, path=None, progress=None):
        """Renders a frame and writes it as the nimbus command does (EXR, atomically, plus the
        scene's preview); `path` replaces output.path. Returns the path written."""
        frame = self._frame(frame)
        status = self._with_progress(
            progress, lambda: self._lib.nimbus_render_write(
                self._live(), frame, None if path is None else _text(os.fspath(path))))
        self._check(status)
        return os.fspath(path) if path is not None else self.output_path(frame)
