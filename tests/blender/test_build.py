"""The shippable build: tools/build_extension.py makes a linux-x64 zip with SciPy and xatlas inside."""

import importlib.util
import os
import subprocess
import sys
import textwrap
import tomllib
import zipfile

import pytest

bpy = pytest.importorskip("bpy", reason="needs Blender's Python module (pip install -r requirements.txt)")

from blender_support import ROOT, fresh_blender, run_extension_tool  # noqa: E402

pytestmark = [
    pytest.mark.blender,
    pytest.mark.skipif(importlib.util.find_spec("pip") is None, reason="the build downloads wheels with pip"),
]

SCRIPT = os.path.join(ROOT, "tools", "build_extension.py")


def pins():
    versions = {}
    with open(os.path.join(ROOT, "requirements.txt"), encoding="utf-8") as fh:
        for line in fh:
            name, sep, version = line.split("#", 1)[0].strip().partition("==")
            if sep:
                versions[name.strip().lower()] = version.strip()
    return versions


@pytest.fixture(scope="module")
def linux_zip(tmp_path_factory):
    out = tmp_path_factory.mktemp("dist")
    proc = subprocess.run([sys.executable, SCRIPT, "--out", str(out), "--platforms", "linux-x64"],
                          capture_output=True, text=True, timeout=1800)
    assert proc.returncode == 0, f"build failed:\n{proc.stdout}\n{proc.stderr}"
    (zip_path,) = out.glob("*.zip")
    assert zip_path.name.endswith("-linux_x64.zip")
    assert str(zip_path) in proc.stdout
    return zip_path


def test_linux_zip_validates_and_ships_scipy_and_xatlas_but_not_numpy(linux_zip):
    run_extension_tool("validate", str(linux_zip))
    versions = pins()
    with zipfile.ZipFile(linux_zip) as zf:
        names = zf.namelist()
        manifest = tomllib.loads(zf.read("blender_manifest.toml").decode("utf-8"))
    wheels = sorted(n for n in names if n.endswith(".whl"))
    assert [w.split("-")[:2] for w in wheels] == [
        ["wheels/scipy", versions["scipy"]], ["wheels/xatlas", versions["xatlas"]]]
    assert all("-cp311-" in w and "x86_64" in w for w in wheels)
    assert sorted(manifest["wheels"]) == ["./" + w for w in wheels]
    assert manifest["platforms"] == ["linux-x64"]
    assert not any("numpy" in n.lower() for n in names)
    assert not any(n.startswith(("tests/", ".ci/", "examples/", ".git")) for n in names)
    assert "__init__.py" in names and "cp_stylize/blender/operators.py" in names


def test_committed_manifest_stays_without_wheels(linux_zip):
    with open(os.path.join(ROOT, "blender_manifest.toml"), "rb") as fh:
        manifest = tomllib.load(fh)
    assert "wheels" not in manifest and "platforms" not in manifest


def test_linux_zip_installs_its_wheels_and_the_operator_runs(linux_zip, tmp_path):
    code = textwrap.dedent(f"""
        import os, sys
        import numpy, bpy
        # hide this environment's scipy and xatlas: they must come from the zip's wheels
        sys.path[:] = [p for p in sys.path
                       if not any(os.path.exists(os.path.join(p or ".", m)) for m in ("scipy", "xatlas"))
                       and not any(n.startswith("xatlas") for n in (os.listdir(p) if os.path.isdir(p) else ()))]
        assert "scipy" not in sys.modules and "xatlas" not in sys.modules
        result = bpy.ops.extensions.package_install_files(
            filepath={str(linux_zip)!r}, repo="user_default", enable_on_install=True)
        assert result == {{"FINISHED"}}, result
        import addon_utils
        assert addon_utils.check("bl_ext.user_default.cp_stylize")[1], "not enabled"
        bpy.ops.mesh.primitive_uv_sphere_add(radius=2.0)
        assert bpy.ops.object.cp_stylize_estimate() == {{"FINISHED"}}
        # Starry Night from the installed extension on an image-textured sphere
        obj = bpy.context.active_object
        image = bpy.data.images.new("Source", 64, 64)
        pixels = numpy.ones((64, 64, 4), numpy.float32)
        pixels[..., :3] = numpy.linspace(0.3, 0.9, 64)[:, None, None]
        image.pixels.foreach_set(pixels.ravel())
        image.pack()
        material = bpy.data.materials.new("Source")
        if material.node_tree is None:
            material.use_nodes = True
        tree = material.node_tree
        tex = tree.nodes.new("ShaderNodeTexImage")
        tex.image = image
        bsdf = next(n for n in tree.nodes if n.type == "BSDF_PRINCIPLED")
        tree.links.new(tex.outputs["Color"], bsdf.inputs["Base Color"])
        obj.data.materials.append(material)
        bpy.context.scene.cp_stylize.image_size = "512"
        assert bpy.ops.object.cp_stylize(preset="starry_night", quality="PREVIEW") == {{"FINISHED"}}
        copy = obj.material_slots[0].material
        assert copy.name == "Source_stylized" and copy.node_tree.nodes["cp_stylize"].image.name == "Sphere_stylized"
        out = numpy.empty(512 * 512 * 4, numpy.float32)
        bpy.data.images["Sphere_stylized"].pixels.foreach_get(out)
        out = out.reshape(-1, 4)
        assert (out[:, 2] > out[:, 0]).mean() > 0.5  # the painting's blues over a grey source
        print("STYLIZED", copy.name)
        import scipy, xatlas
        print("SCIPY", scipy.__version__, scipy.__file__)
        print("XATLAS", xatlas.__file__)
        vmapping, indices, uvs = xatlas.parametrize(
            numpy.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], dtype=numpy.float32),
            numpy.array([[0, 1, 2]], dtype=numpy.uint32))
        assert uvs.shape[1] == 2 and indices.shape == (1, 3)
    """)
    home = tmp_path / "home"
    home.mkdir()
    proc = fresh_blender(code, env={"HOME": str(home), "PYTHONPATH": ""})
    lines = dict(line.split(" ", 1) for line in proc.stdout.splitlines() if line.startswith(("SCIPY", "XATLAS")))
    scipy_version, scipy_file = lines["SCIPY"].split(" ", 1)
    assert scipy_version == pins()["scipy"]
    assert "STYLIZED Source_stylized" in proc.stdout
    for path in (scipy_file, lines["XATLAS"]):
        assert os.path.realpath(path).startswith(os.path.realpath(home)), path
