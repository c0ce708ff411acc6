"""The add-on as Blender sees it: registration, the built zip, its operators."""

import os
import textwrap

import pytest

bpy = pytest.importorskip("bpy", reason="needs Blender's Python module (pip install -r requirements.txt)")

from blender_support import ROOT, fresh_blender, run_extension_tool  # noqa: E402

pytestmark = pytest.mark.blender


@pytest.fixture(scope="module")
def extension_zip(tmp_path_factory):
    out = tmp_path_factory.mktemp("dist")
    run_extension_tool("build", "--source-dir", ROOT, "--output-dir", str(out))
    (zip_path,) = out.glob("*.zip")
    return zip_path


def test_built_zip_validates_and_ships_the_core_but_not_the_tests(extension_zip):
    import zipfile

    run_extension_tool("validate", str(extension_zip))
    names = zipfile.ZipFile(extension_zip).namelist()
    assert "blender_manifest.toml" in names and "__init__.py" in names
    assert "cp_stylize/band.py" in names and "cp_stylize/blender/operators.py" in names
    assert not any(n.startswith(("tests/", ".ci/", "examples/")) for n in names)


def test_zip_installs_enables_and_its_operator_runs(extension_zip, tmp_path):
    code = textwrap.dedent(f"""
        import bpy, sys
        result = bpy.ops.extensions.package_install_files(
            filepath={str(extension_zip)!r}, repo="user_default", enable_on_install=True)
        assert result == {{"FINISHED"}}, result
        import addon_utils
        assert "bl_ext.user_default.cp_stylize" in {{m.__name__ for m in addon_utils.modules()}}
        assert addon_utils.check("bl_ext.user_default.cp_stylize")[1], "not enabled"
        # enabling is cheap: no core, no SciPy, no calibration
        assert not any(name.startswith(("bl_ext.user_default.cp_stylize.cp_stylize.calibration", "scipy"))
                       for name in sys.modules)
        bpy.ops.mesh.primitive_uv_sphere_add(radius=2.0)
        assert bpy.ops.object.cp_stylize_estimate() == {{"FINISHED"}}
        addon = sys.modules["bl_ext.user_default.cp_stylize"]
        # the first estimate timed the computer once and kept it in the extension's user folder
        import json, os
        kept = os.path.join(bpy.utils.extension_path_user("bl_ext.user_default.cp_stylize"), "calibration.json")
        seconds = json.load(open(kept))["seconds"]
        calibration = sys.modules["bl_ext.user_default.cp_stylize.cp_stylize.calibration"]
        assert calibration.machine_speed(kept) == min(max(seconds / calibration.REFERENCE_SECONDS, 0.25), 8.0)
        h, n, nbytes, seconds = addon.cp_stylize.blender.operators.estimate(
            bpy.context.active_object, bpy.context.scene.cp_stylize.to_settings())
        assert abs(h - 0.016 * 4.0 / 2) < 1e-9, h
        print("ESTIMATE", h, n)
    """)
    home = tmp_path / "home"
    home.mkdir()
    proc = fresh_blender(code, env={"HOME": str(home), "PYTHONPATH": ""})
    line = next(l for l in proc.stdout.splitlines() if l.startswith("ESTIMATE"))
    n = int(line.split()[2])
    # a sphere of radius 2 (area 16 pi, diameter 4) at the preview spacing 0.016 * 4 / 2:
    # the band holds about 2 w A / h^3 points
    from cp_stylize import band_width

    h = 0.032
    expected = 2 * band_width(h, stencil="anisotropic") * 1.01 * 16 * 3.14159 / h**3
    assert 0.95 * expected < n < 1.0 * expected
    assert os.path.isdir(home / ".config" / "blender")


def test_register_unregister_register_again():
    import cp_stylize.blender as addon

    bpy.ops.wm.read_factory_settings(use_empty=True)
    addon.register()
    try:
        assert hasattr(bpy.types.Scene, "cp_stylize")
        assert hasattr(bpy.ops.object, "cp_stylize_estimate")
        addon.unregister()
        assert not hasattr(bpy.types.Scene, "cp_stylize")
        addon.register()
        assert bpy.context.scene.cp_stylize.quality == "PREVIEW"
    finally:
        addon.unregister()


def test_estimate_reports_an_error_for_a_non_mesh_object(registered):
    bpy.ops.object.empty_add()
    with pytest.raises(RuntimeError, match="^Error: 'Empty' is an empty, not a mesh\n$"):
        bpy.ops.object.cp_stylize_estimate()


def test_estimate_follows_the_object_size(registered):
    from cp_stylize.blender.operators import estimate

    bpy.ops.mesh.primitive_cube_add(size=2.0)
    cube = bpy.context.active_object
    settings = bpy.context.scene.cp_stylize.to_settings()
    h1, n1, _, _ = estimate(cube, settings)
    cube.scale = (10.0, 10.0, 10.0)
    h2, n2, _, _ = estimate(cube, settings)
    # relative settings: ten times the size means ten times the spacing and the same band
    assert h2 == pytest.approx(10 * h1) and n2 == pytest.approx(n1, rel=1e-6)
