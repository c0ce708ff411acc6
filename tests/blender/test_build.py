"""The shippable build: tools/build_extension.py makes a linux-x64 zip with SciPy, xatlas and libigl for Python 3.11 and
3.13."""

import importlib.util
import os
import pathlib
import subprocess
import sys
import textwrap
import tomllib
import zipfile

import pytest

bpy = pytest.importorskip("bpy", reason="needs Blender's Python module (pip install -r requirements.txt)")

from blender_support import ROOT, extension_tool, fresh_blender, run_extension_tool  # noqa: E402

pytestmark = [
    pytest.mark.blender,
    pytest.mark.skipif(importlib.util.find_spec("pip") is None, reason="the build downloads wheels with pip"),
]

SCRIPT = os.path.join(ROOT, "tools", "build_extension.py")


def pins():
    """``{name: version}`` of requirements.txt, read as the build reads it."""
    spec = importlib.util.spec_from_file_location("build_extension", SCRIPT)
    build_extension = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(build_extension)
    return build_extension.pinned_versions(["scipy", "xatlas", "libigl"])


@pytest.fixture(scope="module")
def linux_zip(tmp_path_factory):
    """The linux-x64 zip: the one CI built for every Blender it tests ($CP_STYLIZE_ZIP), else a fresh build."""
    given = os.environ.get("CP_STYLIZE_ZIP")
    if given:
        assert os.path.isfile(given), given
        return pathlib.Path(given)
    out = tmp_path_factory.mktemp("dist")
    proc = subprocess.run([sys.executable, SCRIPT, "--out", str(out), "--platforms", "linux-x64",
                           "--blender-ext", extension_tool()], capture_output=True, text=True, timeout=1800)
    assert proc.returncode == 0, f"build failed:\n{proc.stdout}\n{proc.stderr}"
    (zip_path,) = out.glob("*.zip")
    assert zip_path.name.endswith("-linux_x64.zip")
    assert str(zip_path) in proc.stdout
    return zip_path


def test_linux_zip_validates_and_ships_scipy_xatlas_and_libigl_for_both_pythons_but_not_numpy(linux_zip):
    run_extension_tool("validate", str(linux_zip))
    versions = pins()
    with zipfile.ZipFile(linux_zip) as zf:
        names = zf.namelist()
        manifest = tomllib.loads(zf.read("blender_manifest.toml").decode("utf-8"))
    wheels = sorted(n for n in names if n.endswith(".whl"))
    assert [(w.split("-")[:3]) for w in wheels] == [
        ["wheels/libigl", versions["libigl"], "cp311"], ["wheels/libigl", versions["libigl"], "cp312"],   # abi3: 3.13
        ["wheels/scipy", versions["scipy"], "cp311"], ["wheels/scipy", versions["scipy"], "cp313"],
        ["wheels/xatlas", versions["xatlas"], "cp311"], ["wheels/xatlas", versions["xatlas"], "cp313"]]
    assert all("x86_64" in w for w in wheels)
    assert sorted(manifest["wheels"]) == ["./" + w for w in wheels]
    assert manifest["platforms"] == ["linux-x64"]
    assert not any("numpy" in n.lower() for n in names)
    assert not any(n.startswith(("tests/", ".ci/", "examples/", ".git")) for n in names)
    assert "__init__.py" in names and "cp_stylize/blender/operators.py" in names


def test_the_zip_holds_only_the_add_on_and_the_core(linux_zip):
    with zipfile.ZipFile(linux_zip) as zf:
        names = {n for n in zf.namelist() if not n.endswith("/") and not n.startswith("wheels/")}
    core = {os.path.relpath(os.path.join(folder, f), ROOT).replace(os.sep, "/")
            for folder, dirs, files in os.walk(os.path.join(ROOT, "cp_stylize")) for f in files if f.endswith(".py")}
    presets = {f"presets/{f}" for f in os.listdir(os.path.join(ROOT, "presets")) if f.endswith(".toml")}
    presets |= {name[:-len(".toml")] + ".png" for name in presets}          # each preset's picture
    product = {"blender_manifest.toml", "__init__.py"} | (core - {"cp_stylize/__main__.py"}) | presets
    assert names == product, (sorted(names - product), sorted(product - names))
    assert not any(n.startswith(("cp_stylize_dev/", "tests/", "tools/")) for n in names)


def test_committed_manifest_stays_without_wheels(linux_zip):
    with open(os.path.join(ROOT, "blender_manifest.toml"), "rb") as fh:
        manifest = tomllib.load(fh)
    assert "wheels" not in manifest and "platforms" not in manifest


def test_linux_zip_installs_its_wheels_and_stylizes_an_image_and_a_procedural_object(linux_zip, tmp_path):
    script = os.path.join(ROOT, "tests", "extension_check.py")
    code = f"import runpy, sys; sys.argv = [{script!r}, {str(linux_zip)!r}]; runpy.run_path({script!r}, run_name='__main__')"
    home = tmp_path / "home"
    home.mkdir()
    proc = fresh_blender(code, env={"HOME": str(home), "PYTHONPATH": ""})
    line = next(l for l in proc.stdout.splitlines() if l.startswith("EXTENSION CHECK PASSED"))
    print(line)
    version, _, place = line.partition(" scipy=")[2].partition(" from ")
    assert version == pins()["scipy"] and os.path.realpath(place).startswith(os.path.realpath(home)), line
