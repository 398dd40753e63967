"""_lib.py: libmoreau through ctypes, by its opaque interface (moreau/api.h, moreau/backend.h):
the library found, the prototypes declared, a context per call with its plug-ins."""
import ctypes
import ctypes.util
import os

_c = ctypes
_P = _c.c_void_p          # an opaque object: mo_ctx *, mo_run_job *, mo_compare_job *
_S = _c.c_char_p


class MoreauError(RuntimeError):
    """A failure reported by libmoreau: status is the library's code (2 bad input, 3 a file that
    could not be read or written, 5 no convergence, 6 a NaN, 8 interrupted...), message its
    sentence (file, line and key for bad input). A failed run's partial outputs are in outdir
    (steps done, summary.json says "incomplete")."""

    def __init__(self, status, message, outdir=None, steps=0):
        RuntimeError.__init__(self, message)
        self.status = status
        self.message = message
        self.outdir = outdir
        self.steps = steps


def _library_path():
    """MOREAU_LIBRARY, else the library moreau was installed with, else the loader's search."""
    env = os.environ.get("MOREAU_LIBRARY")
    if env:
        return env
    try:
        from . import _paths
        for name in ("libmoreau.so.0", "libmoreau.so"):
            cand = os.path.join(_paths.LIBDIR, name)
            if os.path.exists(cand):
                return cand
    except ImportError:
        pass
    return ctypes.util.find_library("moreau") or "libmoreau.so.0"


def _declare(lib):
    sig = {
        "mo_ctx_create": (_P, []),
        "mo_ctx_destroy": (None, [_P]),
        "mo_ctx_status": (_c.c_int, [_P]),
        "mo_ctx_message": (_S, [_P]),
        "mo_ctx_set_verbosity": (None, [_P, _c.c_int]),
        "mo_version": (_S, []),
        "mo_plugin_load": (_c.c_int, [_P, _S]),
        "mo_plugin_scan": (_c.c_int, [_P, _S, _c.POINTER(_c.c_int)]),
        "mo_plugin_failures": (_S, [_P]),
        "mo_backend_count": (_c.c_int, [_P]),
        "mo_backend_name": (_S, [_P, _c.c_int, _c.POINTER(_S)]),
        "mo_run_job_create": (_c.c_int, [_S, _c.POINTER(_P), _P]),
        "mo_run_job_free": (None, [_P]),
        "mo_run_job_solver": (_c.c_int, [_P, _S, _P]),
        "mo_run_job_add_set": (_c.c_int, [_P, _S, _P]),
        "mo_run_job_outdir": (_c.c_int, [_P, _S, _P]),
        "mo_run_job_dump_fclib": (_c.c_int, [_P, _S, _P]),
        "mo_run_job_log": (None, [_P, _c.c_int]),
        "mo_run_job_exec": (_c.c_int, [_P, _P]),
        "mo_run_job_check": (_c.c_int, [_P, _P]),
        "mo_run_job_steps": (_c.c_long, [_P]),
        "mo_run_job_time": (_c.c_double, [_P]),
        "mo_run_job_wall": (_c.c_double, [_P]),
        "mo_run_job_step_wall": (_c.c_double, [_P]),
        "mo_run_job_energy": (_c.c_double, [_P, _c.c_int]),
        "mo_run_job_complete": (_c.c_int, [_P]),
        "mo_run_job_summary_written": (_c.c_int, [_P]),
        "mo_run_job_out": (_S, [_P]),
        "mo_run_job_nmetrics": (_c.c_int, [_P]),
        "mo_run_job_metric": (_S, [_P, _c.c_int, _c.POINTER(_c.c_double), _c.POINTER(_c.c_double)]),
        "mo_compare_job_create": (_c.c_int, [_S, _c.POINTER(_P), _P]),
        "mo_compare_job_free": (None, [_P]),
        "mo_compare_job_add_solver": (_c.c_int, [_P, _S, _P]),
        "mo_compare_job_add_dt": (_c.c_int, [_P, _c.c_double, _P]),
        "mo_compare_job_add_vary": (_c.c_int, [_P, _S, _S, _P]),
        "mo_compare_job_add_set": (_c.c_int, [_P, _S, _P]),
        "mo_compare_job_add_peer": (_c.c_int, [_P, _S, _P]),
        "mo_compare_job_outdir": (_c.c_int, [_P, _S, _P]),
        "mo_compare_job_metric": (_c.c_int, [_P, _S, _P]),
        "mo_compare_job_repeat": (_c.c_int, [_P, _c.c_int, _P]),
        "mo_compare_job_reference": (_c.c_int, [_P, _c.c_double, _P]),
        "mo_compare_job_penetration_tol": (_c.c_int, [_P, _c.c_double, _P]),
        "mo_compare_job_exec": (_c.c_int, [_P, _P]),
        "mo_compare_job_out": (_S, [_P]),
        "mo_compare_job_count": (_c.c_int, [_P, _S]),
    }
    for name, (res, args) in sig.items():
        f = getattr(lib, name)
        f.restype = res
        f.argtypes = args
    return lib


_lib = None


def lib():
    """The loaded library (loaded at the first call)."""
    global _lib
    if _lib is None:
        path = _library_path()
        try:
            _lib = _declare(_c.CDLL(path))
        except OSError as e:
            raise ImportError("moreau: libmoreau not loaded from %s (%s); set MOREAU_LIBRARY to the library "
                              "file, e.g. build/.libs/libmoreau.so.0 in a build tree" % (path, e))
        except AttributeError as e:
            raise ImportError("moreau: %s lacks a function of this module (%s): another moreau version?" % (path, e))
    return _lib


def text(b):
    return b.decode("utf-8", "replace") if b is not None else None


def arg(s):
    """A str or path for a const char * argument (None stays NULL)."""
    return None if s is None else os.fsencode(s)


class Context:
    """A libmoreau context for one call: its plug-ins (the explicit ones, then the plug-in folders,
    as the command line loads them), its error, freed on exit."""

    def __init__(self, plugins=(), verbose=False):
        self.lib = lib()
        self.ptr = self.lib.mo_ctx_create()
        if not self.ptr:
            raise MemoryError("moreau: no memory for a context")
        self.lib.mo_ctx_set_verbosity(self.ptr, 1 if verbose else 0)
        try:
            if isinstance(plugins, (str, bytes, os.PathLike)):
                plugins = [plugins]
            for p in plugins:
                self.check(self.lib.mo_plugin_load(self.ptr, arg(p)))
            self.check(self.lib.mo_plugin_scan(self.ptr, None, None))
        except BaseException:
            self.close()
            raise

    def check(self, status, outdir=None, steps=0):
        if status:
            raise MoreauError(status, text(self.lib.mo_ctx_message(self.ptr)), outdir, steps)

    def close(self):
        if self.ptr:
            self.lib.mo_ctx_destroy(self.ptr)
            self.ptr = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False
