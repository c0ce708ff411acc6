"""Package-level facts: the core stands without Blender, the public API is there."""

import os
import shutil
import subprocess
import sys
import tomllib

import pytest

from optional import installed

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

    for name in ("Sphere", "Torus", "Band", "heat", "band_width", "stylize", "load_preset", "ColourInput", "Texture",
                 "uv_atlas", "bake_to_atlas", "sample_texture", "parametric_mesh"):
        assert name in cp_stylize.__all__
    for name in cp_stylize.__all__:
        assert getattr(cp_stylize, name) is not None, name


def test_the_examples_run_with_the_installed_library(tmp_path):
    """The examples import cp_stylize as a library (the set-up installs it): run from another folder."""
    proc = subprocess.run([sys.executable, os.path.join(ROOT, "examples", "stylize_mesh.py"), "out.png"],
                          cwd=tmp_path, capture_output=True, text=True)
    if proc.returncode != 0 and "No module named 'cp_stylize'" in proc.stderr:
        pytest.skip("cp_stylize is not installed in this Python (the README's set-up installs it)")
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "out.png").stat().st_size > 1000


def test_the_library_installs_with_pip_and_its_version_is_the_extensions(tmp_path):
    for module, why in (("setuptools", "pip builds the library with setuptools (pip install setuptools)"),
                        ("wheel", "pip builds the library into a wheel with it (pip install -r requirements.txt)")):
        if not installed(module):                            # pip imports it, in its own process
            pytest.skip(why)
    with open(os.path.join(ROOT, "pyproject.toml"), "rb") as fh:
        project = tomllib.load(fh)["project"]
    with open(os.path.join(ROOT, "blender_manifest.toml"), "rb") as fh:
        assert project["version"] == tomllib.load(fh)["version"]
    source = tmp_path / "source"                 # a copy: the build leaves nothing in the checkout
    shutil.copytree(os.path.join(ROOT, "cp_stylize"), source / "cp_stylize",
                    ignore=shutil.ignore_patterns("__pycache__"))
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(os.path.join(ROOT, name), source / name)
    target = tmp_path / "site"
    proc = subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--no-build-isolation",
                           "--disable-pip-version-check", "--target", str(target), str(source)],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    assert (target / "cp_stylize" / "diffusion.py").is_file() and (target / "cp_stylize" / "blender").is_dir()
    assert not (target / "cp_stylize_dev").exists() and not (target / "tests").exists()
    code = ("import cp_stylize, numpy as np\n"
            "band = cp_stylize.Band.build(cp_stylize.Sphere(1.0), 0.1)\n"
            "u = cp_stylize.heat(band, np.ones(band.size), 1e-3)\n"
            "print(cp_stylize.__file__, float(np.abs(u - 1).max()))\n")
    proc = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True,
                          env={**os.environ, "PYTHONPATH": str(target)})
    assert proc.returncode == 0, proc.stderr
    where, error = proc.stdout.splitlines()[-1].split()      # the last line: what went before is the build's
    assert where.startswith(str(target)) and float(error) < 1e-5       # the installed core, and it runs
