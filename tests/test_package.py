"""Package-level facts: the core stands without Blender, the public API is there."""

import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def test_core_imports_without_bpy():
    code = (
        "import sys, pkgutil, importlib\n"
        "sys.modules['bpy'] = None\n"
        "sys.modules['mathutils'] = None\n"
        "import cp_stylize\n"
        "names = [m.name for m in pkgutil.walk_packages(cp_stylize.__path__, 'cp_stylize.')\n"
        "         if not m.name.startswith('cp_stylize.blender')]\n"
        "for name in names:\n"
        "    importlib.import_module(name)\n"
        "print(len(names))\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    # every module of the core was imported, none skipped
    core = os.path.join(ROOT, "cp_stylize")
    files = [name for name in os.listdir(core) if name.endswith(".py") and name != "__init__.py"]
    assert int(proc.stdout) == len(files)


def test_public_api():
    import cp_stylize

    for name in ("Sphere", "Torus", "Band", "heat", "band_width"):
        assert name in cp_stylize.__all__ and hasattr(cp_stylize, name)
