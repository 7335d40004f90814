"""A fitted model file evaluated by gonio's own C code (libgonio_model.so,
python/gonio_model.c, through ctypes): the values gonio computes, with no
second implementation of any model."""
import ctypes
import os

from . import _arrays

LIBRARY = "libgonio_model.so"


def _library_path():
    """$GONIO_MODEL_LIB (a build tree's), else the one installed beside this
    package."""
    env = os.environ.get("GONIO_MODEL_LIB")
    if env:
        return env
    return os.path.join(os.path.dirname(os.path.abspath(__file__)), LIBRARY)


_lib = None


def _load():
    global _lib
    if _lib is None:
        path = _library_path()
        try:
            lib = ctypes.CDLL(path)
        except OSError as e:
            raise OSError("%s: cannot load gonio's model library (set GONIO_MODEL_LIB to the "
                          "build's python/%s): %s" % (path, LIBRARY, e)) from None
        lib.gonio_model_open.restype = ctypes.c_void_p
        lib.gonio_model_open.argtypes = [ctypes.c_char_p, ctypes.c_char_p, ctypes.c_size_t]
        d = ctypes.POINTER(ctypes.c_double)
        lib.gonio_model_eval.restype = ctypes.c_long
        lib.gonio_model_eval.argtypes = [ctypes.c_void_p, d, d, d, d, ctypes.c_size_t, d]
        lib.gonio_model_eval_inplane.restype = ctypes.c_long
        lib.gonio_model_eval_inplane.argtypes = [ctypes.c_void_p, d, d, ctypes.c_size_t, d]
        lib.gonio_model_name.restype = ctypes.c_char_p
        lib.gonio_model_name.argtypes = [ctypes.c_void_p]
        lib.gonio_model_close.restype = None
        lib.gonio_model_close.argtypes = [ctypes.c_void_p]
        _lib = lib
    return _lib


def _doubles(values, n=None):
    values = [float(v) for v in values]
    if n is not None and len(values) != n:
        raise ValueError("%d angles where %d were given before" % (len(values), n))
    return (ctypes.c_double * max(len(values), 1))(*values)


class Model:
    """The model file at path (any kind gonio fits: docs/models.md)."""

    def __init__(self, path):
        self._lib = _load()
        msg = ctypes.create_string_buffer(1024)
        self._m = self._lib.gonio_model_open(os.fsencode(path), msg, len(msg))
        if not self._m:
            raise ValueError(msg.value.decode(errors="replace"))
        self.path = path
        self.name = self._lib.gonio_model_name(self._m).decode(errors="replace")

    def close(self):
        if self._m:
            self._lib.gonio_model_close(self._m)
            self._m = None

    def __del__(self):
        self.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def _run(self, call, n, *angles):
        rgb = (ctypes.c_double * max(3 * n, 1))()
        missing = call(self._m, *angles, n, rgb)
        if missing < 0:
            raise MemoryError("gonio_model_eval: out of memory")
        return _arrays.rows(list(rgb)[:3 * n], 3)

    def eval_inplane(self, theta_i, theta_r):
        """RGB BRDF (1/sr), one row per pair, at in-plane angles in degrees
        (theta_r signed, as samples.csv's)."""
        theta_i, theta_r = list(theta_i), list(theta_r)
        n = len(theta_i)
        return self._run(self._lib.gonio_model_eval_inplane, n, _doubles(theta_i),
                         _doubles(theta_r, n))

    def eval(self, theta_i, phi_i, theta_o, phi_o):
        """RGB BRDF (1/sr), one row per pair, at spherical angles in degrees
        (samples.csv's theta_i, phi_i, theta_o, phi_o)."""
        cols = [list(c) for c in (theta_i, phi_i, theta_o, phi_o)]
        n = len(cols[0])
        return self._run(self._lib.gonio_model_eval, n, *[_doubles(c, n) for c in cols])
