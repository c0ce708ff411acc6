"""Running code in a fresh Blender: the bpy module here, or a Blender binary under ``blender -b``.

Inside a real Blender (``bpy.app.binary_path`` is set) a fresh process is
``blender -b --factory-startup --python-use-system-env --python-expr CODE``
(Blender reads PYTHONPATH only with ``--python-use-system-env``); with the bpy
wheel it is ``python -c CODE``.  Either way the repository root is importable.

Blender 4.2 to 4.4.2 as a Python module crash when the interpreter exits once
a PropertyGroup was registered, even after it was unregistered (a Blender bug,
fixed in 4.4.3).  :data:`EXIT_CRASHES` says whether this Blender has it; only
then do the test runs here end with ``os._exit`` after their own result is
known, instead of the interpreter's teardown (see :func:`fresh_blender` and
``tests/conftest.py``).
"""

import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def exit_crashes(bpy):
    """Whether this bpy module crashes at interpreter exit after a PropertyGroup was registered."""
    return not bpy.app.binary_path and bpy.app.version < (4, 4, 3)


#: The code run after a fresh Blender's test code succeeded, where exiting would crash.
_EXIT_NOW = "\nimport os as _os, sys as _sys\n_sys.stdout.flush(); _sys.stderr.flush(); _os._exit(0)\n"


def fresh_blender(code, *, env=None, timeout=900):
    """Run Python ``code`` in a new Blender process; returns the CompletedProcess (raises on failure)."""
    import bpy

    if exit_crashes(bpy):
        code += _EXIT_NOW
    full_env = dict(os.environ)
    full_env.update(env or {})
    paths = [ROOT] + [p for p in full_env.get("PYTHONPATH", "").split(os.pathsep) if p]
    if bpy.app.binary_path:  # a Blender binary: hand on the packages found here (scipy, ...), not user extensions
        paths += [p for p in sys.path if p.endswith(("site-packages", "dist-packages"))
                  and os.sep + "extensions" + os.sep not in p]
    full_env["PYTHONPATH"] = os.pathsep.join(paths)
    if bpy.app.binary_path:
        cmd = [bpy.app.binary_path, "-b", "--factory-startup", "--python-use-system-env", "--python-exit-code", "1",
               "--python-expr", code]
    else:
        cmd = [sys.executable, "-c", code]
    proc = subprocess.run(cmd, env=full_env, capture_output=True, text=True, timeout=timeout, cwd=ROOT)
    if proc.returncode != 0:
        raise AssertionError(f"Blender process failed ({proc.returncode}):\n{proc.stdout[-4000:]}\n{proc.stderr[-4000:]}")
    return proc


def extension_tool():
    """Path of blender_ext.py, Blender's extension build and validate tool."""
    import bpy

    path = os.path.join(bpy.utils.system_resource("SCRIPTS"), "addons_core", "bl_pkg", "cli", "blender_ext.py")
    if not os.path.isfile(path):
        raise FileNotFoundError(f"blender_ext.py is not at {path}")
    return path


def run_extension_tool(*args):
    """Run blender_ext.py with Blender's Python; returns its output (raises on failure)."""
    # inside Blender, sys.executable is Blender's own Python, which runs the tool too
    proc = subprocess.run([sys.executable, extension_tool(), *args],
                          capture_output=True, text=True, timeout=600)
    if proc.returncode != 0:
        raise AssertionError(f"blender_ext.py {' '.join(args)} failed:\n{proc.stdout}\n{proc.stderr}")
    return proc.stdout
