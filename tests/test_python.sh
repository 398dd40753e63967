#!/bin/sh
# test_python.sh: the Python module (python/moreau) from the source tree over the build tree's
# libmoreau: tests/test_python.py (TAP). Debian's interpreter with numpy (python3-numpy); under
# the sanitizers the instrumented library needs their runtime preloaded into the interpreter.
: "${MOREAU_SRCDIR:?}" "${MOREAU_BUILDDIR:?}" "${MOREAU:?}"
PY=${MOREAU_PYTHON:-/usr/bin/python3}
if ! "$PY" -c 'import numpy' 2> /dev/null; then
  echo "1..0 # SKIP $PY with numpy not found (apt-get install python3-numpy)"
  exit 0
fi
lib="$MOREAU_BUILDDIR/.libs/libmoreau.so.0"
if [ ! -f "$lib" ]; then
  echo "1..0 # SKIP no shared libmoreau in the build tree (configured --disable-shared)"
  exit 0
fi
WORK="$MOREAU_BUILDDIR/tests/out/python.$$"
trap 'rm -rf "$WORK"' EXIT
mkdir -p "$WORK"
# the example plug-in, linked with the build tree's library (test_plugin.sh builds it against the
# installed moreau.pc)
JACOBI="$WORK/jacobi.so"
${CC:-cc} -O1 -fPIC -shared -I"$MOREAU_SRCDIR/src" -o "$JACOBI" "$MOREAU_SRCDIR/examples/backend-jacobi/jacobi.c" \
  -L"$MOREAU_BUILDDIR/.libs" -lmoreau 2> "$WORK/cc.log" || JACOBI=""
if [ -n "$MOREAU_SANITIZERS" ]; then
  asan=$(${CC:-cc} -print-file-name=libasan.so)
  ubsan=$(${CC:-cc} -print-file-name=libubsan.so)
  export LD_PRELOAD="$asan $ubsan"
  export ASAN_OPTIONS="${ASAN_OPTIONS:+$ASAN_OPTIONS:}detect_leaks=0"   # the interpreter's own allocations
fi
PYTHONPATH="$MOREAU_SRCDIR/python" PYTHONDONTWRITEBYTECODE=1 MOREAU_LIBRARY="$lib" MOREAU_PLUGIN_PATH="" \
  WORK="$WORK" JACOBI="$JACOBI" MOREAU_VERSION="$("$MOREAU" --version | cut -d' ' -f2)" \
  "$PY" "$MOREAU_SRCDIR/tests/test_python.py"
