"""The add-on in a real Blender window: the sidebar, the Stylize button's modal run, Esc, undo and redo,
and the object deleted or put in Edit Mode while the run works.

Each test starts a Blender binary (``$CP_STYLIZE_BLENDER``, else ``blender`` on the PATH) in a window on
the X display ``$DISPLAY``, with a throw-away user configuration, and lets ``driver.py`` install the
extension zip (``$CP_STYLIZE_ZIP``, else one built here) and work through a scenario.  Screenshots go to
a folder the tests print (``$CP_STYLIZE_SCREENSHOTS``, else a temporary one).  Run them on a virtual
screen with ``tools/real_blender.sh run --gui python3 -m pytest tests/gui``; without a display or a
Blender binary they are skipped.
"""

import json
import os
import re
import shutil
import subprocess
import sys
import tempfile

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
DRIVER = os.path.join(ROOT, "tests", "gui", "driver.py")
BLENDER = os.environ.get("CP_STYLIZE_BLENDER") or shutil.which("blender")

pytestmark = [
    pytest.mark.window,
    pytest.mark.skipif(not os.environ.get("DISPLAY") or not BLENDER,
                       reason="needs an X display and a Blender binary (tools/real_blender.sh run --gui)"),
]


@pytest.fixture(scope="session")
def screenshots():
    folder = os.environ.get("CP_STYLIZE_SCREENSHOTS") or tempfile.mkdtemp(prefix="cp_stylize_screenshots_")
    os.makedirs(folder, exist_ok=True)
    print(f"\nscreenshots: {folder}")
    return folder


@pytest.fixture(scope="session")
def extension_zip(tmp_path_factory):
    given = os.environ.get("CP_STYLIZE_ZIP")
    if given:
        return given
    out = tmp_path_factory.mktemp("dist")
    subprocess.run([sys.executable, os.path.join(ROOT, "tools", "build_extension.py"), "--out", str(out),
                    "--platforms", "linux-x64", "--blender", BLENDER], check=True, capture_output=True, timeout=1800)
    (path,) = out.glob("*.zip")
    return str(path)


def drive(scenario, screenshots, extension_zip, tmp_path):
    """Run ``driver.py`` through ``scenario``; returns its facts (raises on a failed scenario)."""
    out = os.path.join(screenshots, scenario)
    shutil.rmtree(out, ignore_errors=True)
    env = dict(os.environ, HOME=str(tmp_path / "home"), PYTHONPATH=ROOT)
    os.makedirs(env["HOME"])
    proc = subprocess.run([BLENDER, "--factory-startup", "--python-use-system-env", "--python", DRIVER, "--",
                           scenario, out, extension_zip], env=env, capture_output=True, text=True, timeout=900)
    path = os.path.join(out, "result.json")
    assert os.path.isfile(path), f"the driver wrote no result:\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"
    with open(path, encoding="utf-8") as fh:
        facts = json.load(fh)
    assert "error" not in facts, facts["error"] + "\n" + "\n".join(facts["steps"])
    print("\n".join(facts["steps"]))
    for name, shot in sorted(facts["screenshots"].items()):
        print(f"  {name}: {shot}")
    return facts


def messages(facts):
    """The add-on's own reports (the operator calls the window also reports are left out)."""
    return [line for line in facts["reports"] if not line.startswith("bpy.ops.")]


def test_the_sidebar_tab_draws_every_panel_for_every_mode(screenshots, extension_zip, tmp_path):
    facts = drive("panel", screenshots, extension_zip, tmp_path)
    assert facts["sidebar"]["category"] == "Stylize"
    from cp_stylize.parameters import FILTERS

    assert facts["modes"] == list(FILTERS)
    for mode in facts["modes"]:
        assert os.path.getsize(facts["screenshots"][f"panel_{mode}_crop"]) > 10_000, mode
    for direction in facts["directions"]:
        assert os.path.getsize(facts["screenshots"][f"panel_direction_{direction}_crop"]) > 10_000, direction
    assert os.path.getsize(facts["screenshots"]["panel_oil_toon_crop"]) > 10_000
    assert os.path.getsize(facts["screenshots"]["panel_toon_crop"]) > 10_000
    assert facts["toon"] == {"toon_levels": 4, "toon_outlines": 1.0, "line_width": pytest.approx(0.004)}
    assert os.path.getsize(facts["screenshots"]["panel_watercolour_crop"]) > 10_000
    from cp_stylize.presets import load_preset

    shipped = load_preset("watercolour")
    assert facts["watercolour"] == {"wash_levels": shipped.wash_levels, "oil_size": pytest.approx(shipped.oil_size),
                                    "labels": ["Edge Darkening", "Granulation", "Bleeding", "Wobble"]}
    assert os.path.getsize(facts["screenshots"]["panel_hatching_crop"]) > 10_000
    assert facts["hatching"] == {"hatch_spacing": pytest.approx(0.016), "hatch_layers": 3,
                                 "line_width": pytest.approx(0.004)}
    assert os.path.getsize(facts["screenshots"]["panel_hand_painted_crop"]) > 10_000
    hand = load_preset("hand_painted")
    assert facts["hand_painted"] == {"shade_light": pytest.approx(hand.shade_light),
                                     "shade_edges": pytest.approx(hand.shade_edges),
                                     "shade_warmth": pytest.approx(hand.shade_warmth)}
    assert os.path.getsize(facts["screenshots"]["panel_palette_crop"]) > 10_000
    sunflower = load_preset("sunflower_vase")
    assert facts["palette"] == {"fidelity": pytest.approx(sunflower.fidelity), "hue_snap": pytest.approx(1.0),
                                "label": "Palette Hues"}
    # the Output sub-panel drawn with its limits, each label short enough for the sidebar's default width
    assert facts["output_labels"] == ["Max RAM (GiB)", "Max Time (min)"]
    assert os.path.getsize(facts["screenshots"]["panel_output_crop"]) > 10_000
    assert os.path.getsize(facts["screenshots"]["panel_advanced_crop"]) > 10_000
    from cp_stylize.presets import builtin_presets

    icons = facts["preset_icons"]     # each shipped preset's picture is an icon the menu draws
    assert set(builtin_presets()) <= set(icons) and all(icons[key] > 0 for key in builtin_presets()), icons
    assert os.path.getsize(facts["screenshots"]["preset_menu"]) > 50_000
    sizes = facts["sizes"]      # Smoothing: the blur's radius, in the scene's units on the ball
    assert sizes["time_size"] == pytest.approx((2 * sizes["time"]) ** 0.5 * sizes["radius"], rel=0.02)


def test_a_run_shows_progress_finishes_and_undo_and_redo_restore_both_states(screenshots, extension_zip, tmp_path):
    facts = drive("undo", screenshots, extension_zip, tmp_path)
    assert facts["invoke"] == ["RUNNING_MODAL"]
    progress = facts["progress"]
    assert len(set(progress)) >= 4 and progress == sorted(progress) and progress[-1] >= 0.95
    assert "images.Ball_stylized: added" in facts["changed_by_run"]
    assert "materials.Painted_stylized: added" in facts["changed_by_run"]
    assert facts["after_undo"] == []   # undo: exactly the state before the run
    assert facts["after_redo"] == []   # redo: exactly the stylized state
    assert messages(facts)[-1].startswith("stylized 'Ball' into 'Ball_stylized' in ")
    assert facts["shading"] == "SOLID" and "switch to Material Preview (Z)" in messages(facts)[-1]


def test_a_scan_filtered_into_a_colour_attribute_is_one_undo_step(screenshots, extension_zip, tmp_path):
    facts = drive("attribute", screenshots, extension_zip, tmp_path)
    assert facts["method_label"] == ["Filters on the mesh's vertices", "(they lie closer than the grid)"]
    assert os.path.getsize(facts["screenshots"]["attribute_output"]) > 10_000
    changed = facts["changed_by_run"]
    assert "materials.Scanned_stylized: added" in changed and not any(c.startswith("images.") for c in changed)
    assert any(c.startswith("meshes.") and "colour_attributes" in c for c in changed), changed
    assert facts["after_undo"] == [] and facts["after_redo"] == []
    assert messages(facts)[-1].startswith("stylized 'Scan' into the colour attribute 'Col_stylized' on the mesh's "
                                          "own vertices in ")


def test_a_second_run_reuses_the_band_and_the_panel_can_free_it(screenshots, extension_zip, tmp_path):
    facts = drive("rerun", screenshots, extension_zip, tmp_path)
    first, second = [m for m in messages(facts) if m.startswith("stylized 'Ball'")][-2:]
    assert "reused" not in first and "the last run's band reused)" in second
    # what is kept holds at least the band's extension E: 64 weights and indices a point
    points = int(re.search(r"in [0-9.]+ s \(([0-9,]+) band points", second).group(1).replace(",", ""))
    assert facts["kept_mib"] * 2**20 > points * 64 * 8 and facts["kept_after_free"] == 0


def test_a_udim_asset_is_read_from_every_tile_in_a_window_and_undo_restores_it(screenshots, extension_zip, tmp_path):
    facts = drive("udim", screenshots, extension_zip, tmp_path)
    assert facts["tiles"] == [1001, 1002, 1011] and facts["tile_files_unchanged"]
    changed = facts["changed_by_run"]
    assert "images.Ball_stylized: added" in changed and "materials.Tiled_stylized: added" in changed, changed
    assert not any(c.startswith("images.Tiles") for c in changed), changed        # the tiled image untouched
    assert facts["after_undo"] == [] and facts["after_redo"] == []
    assert messages(facts)[-1].startswith("stylized 'Ball' into 'Ball_stylized' in ")
    assert os.path.getsize(facts["screenshots"]["udim_after"]) > 10_000


def test_esc_mid_run_changes_nothing(screenshots, extension_zip, tmp_path):
    facts = drive("escape", screenshots, extension_zip, tmp_path)
    assert facts["acted"] and max(facts["progress"]) < 0.95
    assert facts["changed"] == []
    assert messages(facts)[-1] == "stylize cancelled; nothing was changed"


def test_deleting_the_object_mid_run_changes_nothing_else(screenshots, extension_zip, tmp_path):
    facts = drive("delete", screenshots, extension_zip, tmp_path)
    assert facts["acted"] and not facts["ball_exists"]
    assert facts["changed"] == []
    assert messages(facts)[-1] == "'Ball' was deleted or renamed while it was being stylized; nothing was changed"


def test_edit_mode_mid_run_changes_nothing(screenshots, extension_zip, tmp_path):
    facts = drive("edit_mode", screenshots, extension_zip, tmp_path)
    assert facts["acted"] and facts["mode"] == "EDIT"
    assert facts["changed"] == []
    assert messages(facts)[-1] == ("'Ball' is in Edit Mode; nothing was changed: leave Edit Mode and press "
                                   "Stylize again")
