"""Ink hatching: lines of ink at a set spacing on the surface, denser in the darks (cp_stylize.hatching)."""

import numpy as np
import pytest

from cp_stylize import hatching
from cp_stylize.mesh import parametric_mesh
from cp_stylize.pipeline import ColourInput, hatch_colours, stylize
from cp_stylize.presets import StylizeSettings, load_preset
from cp_stylize.surfaces import Sphere, Torus
from cp_stylize_dev.looks import city_plane, ink_share, kept_hatchings, paper_or_ink

INK, PAPER = np.asarray(hatching.INK), np.asarray(hatching.PAPER)


def _run(image, settings, mesh=None):
    vertices, faces, uvs = city_plane(32, 16) if mesh is None else mesh
    colours = ColourInput.constant(len(faces), (0.0, 0.0, 0.0))
    colours.textures.append((np.asarray(image, np.float32), uvs, np.ones(len(faces), bool)))
    result = stylize(vertices, faces, colours, settings, uvs=uvs)
    return result, result.atlas.coverage.reshape(settings.image_size, settings.image_size)


def _ink(image):
    """How far each texel's colour lies from the paper towards the ink (H, W)."""
    return ink_share(image, INK, PAPER)


#: Lines along the plane's x axis (the image's rows), 0.04 apart: about 11 texels of a 256 x 256 image across them.
_LINES = StylizeSettings(mode="gaussian", T=1e-6, spacing=0.03, image_size=256, detail=0.0, direction="axis",
                         axis=(1.0, 0.0, 0.0), hatch_spacing=0.04, hatch_layers=1, hatch_ink=0.75)


def _period(column):
    """The mean distance (texels) between the lines a 1-D ink profile crosses: from the first line's rising
    edge to the last's, over the lines between."""
    rises = np.flatnonzero((column[1:] >= 0.5) & (column[:-1] < 0.5))
    return (rises[-1] - rises[0]) / (len(rises) - 1)


def test_lines_lie_a_spacing_apart_along_the_direction_and_are_as_wide_as_the_tone_asks():
    grey = np.full((64, 64, 3), 0.5, np.float32)     # Ink 0.75: a flat grey asks for a quarter of its area in ink
    result, covered = _run(grey, _LINES)
    ink = _ink(result.image)
    rows = covered.all(axis=1)
    inner = np.flatnonzero(rows)[8:-8]
    texel_v = 1.0 / 256 * 2.0 / np.sqrt(5.0)               # a texel's height, the plane normalised to a diameter of 2
    expected = 0.04 / texel_v
    periods = np.array([_period(ink[inner, c]) for c in range(16, 240, 8)])
    # the lines' spacing on the surface holds across the whole plane: within 10 % of the set spacing
    assert np.all(np.abs(periods / expected - 1.0) < 0.1), periods / expected
    # the lines run along x: along a row the ink hardly changes, across the rows it does
    block = ink[inner][:, 16:240]
    assert np.abs(np.diff(block, axis=1)).mean() < 0.25 * np.abs(np.diff(block, axis=0)).mean()
    # a flat tone is drawn as whole lines of one width: ink and paper, hardly anything between
    assert np.mean((block < 0.15) | (block > 0.85)) > 0.8
    # ... as wide as the ink asked for: lines a quarter of the spacing wide cover a quarter of the surface
    assert block.mean() == pytest.approx(0.25, abs=0.04)
    assert result.height is None


def test_darker_tones_take_more_ink_and_a_second_layer_crosses_the_first():
    ramp = np.repeat(np.linspace(0.95, 0.05, 64)[None, :, None], 64, axis=0).repeat(3, axis=2)  # dark to the right
    settings = _LINES.replace(hatch_layers=2, hatch_ink=0.5)
    result, covered = _run(ramp, settings)
    ink = _ink(result.image)
    columns = np.array([ink[covered[:, c], c].mean() for c in range(8, 248)])
    lightness = np.linspace(0.95, 0.05, 256)[8:248]
    windows = np.add.reduceat(columns, np.arange(0, len(columns), 8)) / 8
    assert np.corrcoef(windows, np.add.reduceat(lightness, np.arange(0, len(lightness), 8)) / 8)[0, 1] < -0.9
    # the lightest stay paper; the darkest near-solid (two layers cover up to 1 - (1 - WIDEST) (1 - DEEPEST))
    assert columns[:10].mean() < 0.02 and columns[-10:].mean() > 0.6
    # texels are paper or ink: at most anti-aliased edges in between
    assert paper_or_ink(result.image, covered, INK, PAPER, reach=0.15) > 0.8
    # in the darks a second layer crosses the first: the ink changes along the rows too
    dark = ink[np.flatnonzero(covered.all(axis=1))[8:-8]][:, 200:240]
    light = ink[np.flatnonzero(covered.all(axis=1))[8:-8]][:, 70:110]
    assert np.abs(np.diff(dark, axis=1)).mean() > 3 * np.abs(np.diff(light, axis=1)).mean()


def test_the_lines_run_on_across_a_uv_seam():
    """A torus whose texture wraps at u = 0: the columns either side of the seam meet as neighbours inside do."""
    vertices, faces, uvs = parametric_mesh(Torus(10.0, 4.0).point, 64, 32, periodic_u=True, periodic_v=True)
    grey = np.full((32, 32, 3), 0.45, np.float32)
    settings = StylizeSettings(mode="gaussian", T=1e-6, spacing=0.04, image_size=256, detail=0.0, margin=0,
                               direction="max", hatch_spacing=0.06, hatch_layers=1, hatch_ink=0.75)
    result, covered = _run(grey, settings, (vertices, faces, uvs))
    ink = _ink(result.image)
    rows = np.flatnonzero(covered[:, 0] & covered[:, -1])
    across = np.abs(ink[rows, 0] - ink[rows, -1]).mean()
    inside = np.abs(np.diff(ink[rows], axis=1)).mean()
    assert 0.05 < ink[covered].mean() < 0.6
    assert across < 1.5 * inside, (across, inside)


def test_phase_alignment_leaves_few_breaks_in_the_lines():
    """With a calm direction field, aligned kernels sum to one plane wave: the phase rises at the set rate
    nearly everywhere, where random kernel phases would break the lines at every few spacings."""
    grey = np.full((16, 16, 3), 0.5, np.float32)
    with kept_hatchings() as made:
        _run(grey, _LINES.replace(image_size=64))
    h = made[0]
    rng = np.random.default_rng(0)
    at = np.column_stack([rng.uniform(-0.6, 0.6, 2000), rng.uniform(-0.25, 0.25, 2000), np.zeros(2000)])
    at *= 2.0 / np.sqrt(5.0)
    normals = np.tile([0.0, 0.0, 1.0], (2000, 1))
    piece = np.zeros(2000, np.int32)
    step = 0.05 * h.spacing
    before = h.phase(0, at, normals, piece)
    after = h.phase(0, at + [0.0, step, 0.0], normals, piece)
    rate = np.abs(np.angle(np.exp(1j * (after - before)))) / step
    assert np.mean(np.abs(rate / h.frequency - 1.0) < 0.15) > 0.95
    # the same kernels with random phases: many more breaks
    kernels = h._layers[0]
    aligned = kernels.phases
    kernels.phases = np.exp(2j * np.pi * rng.random(len(aligned)))
    before = h.phase(0, at, normals, piece)
    after = h.phase(0, at + [0.0, step, 0.0], normals, piece)
    kernels.phases = aligned
    rate_random = np.abs(np.angle(np.exp(1j * (after - before)))) / step
    steady = np.mean(np.abs(rate / h.frequency - 1.0) < 0.15)
    assert np.mean(np.abs(rate_random / h.frequency - 1.0) < 0.15) < steady - 0.1


def test_full_swell_fills_the_darks_with_solid_ink_cut_by_tapering_white_lines():
    # one layer; the darkest tones leave paper between the lines at the default swell, none at swell 1
    ramp = np.repeat(np.linspace(0.95, 0.05, 64)[None, :, None], 64, axis=0).repeat(3, axis=2)  # dark to the right
    settings = _LINES.replace(hatch_ink=0.5)
    rows = None
    shares = {}
    for swell in (hatching.DEEPEST, 1.0):
        result, covered = _run(ramp, settings.replace(hatch_swell=swell))
        rows = np.flatnonzero(covered.all(axis=1))[8:-8] if rows is None else rows
        shares[swell] = _ink(result.image)[rows]
    darkest = slice(246, 252)                                       # the ramp's darkest 2 % (Ink 0.5: solid)
    assert shares[hatching.DEEPEST][:, darkest].mean() == pytest.approx(hatching.DEEPEST, abs=0.03)
    assert shares[1.0][:, darkest].mean() > 0.95                    # solid black
    # the white lines between taper out towards the darks: the paper's share falls steadily along the ramp
    paper = 1.0 - shares[1.0].mean(axis=0)
    steps = [paper[c:c + 16].mean() for c in range(120, 248, 16)]
    assert np.all(np.diff(steps) < 0.01) and steps[0] - steps[-1] > 0.3
    # where the white lines would be narrower than the finest line, they are cut as dashes of it and the ink
    # closes between them: clean white cuts and solid ink, few grey hairlines
    dark = shares[1.0][:, 220:246]
    assert np.mean((dark > 0.15) & (dark < 0.85)) < 0.15
    # the lights are the same at either swell: only the last layer's widest lines differ
    np.testing.assert_allclose(shares[1.0][:, 8:60], shares[hatching.DEEPEST][:, 8:60], atol=1e-6)


def test_the_form_light_darkens_the_side_turned_from_it_and_turns_with_the_object():
    h = hatching.Hatching.__new__(hatching.Hatching)
    away = np.array([-hatching.LIGHT, np.cross(hatching.LIGHT, [0.0, 0.0, 1.0])])
    away[1] /= np.linalg.norm(away[1])
    for h.light in (0.0, 0.5, 1.0):
        np.testing.assert_allclose(h.shading(hatching.LIGHT[None]), 1.0)
        np.testing.assert_allclose(h.shading(away), 1.0 - h.light * (1.0 - hatching.SHADOW))
    # a sphere of one even grey: with the light, its side turned from the light takes more ink
    vertices, faces, uvs = parametric_mesh(Sphere().point, 48, 24, periodic_u=True)
    grey = np.full((16, 16, 3), 0.5, np.float32)
    settings = StylizeSettings(mode="gaussian", T=1e-6, spacing=0.04, image_size=256, detail=0.0,
                               hatch_spacing=0.06, hatch_layers=1)
    size = settings.image_size
    u, v = (np.arange(size) + 0.5) / size, (np.arange(size) + 0.5) / size
    uu, vv = np.meshgrid(u, v)                                              # row 0 at the bottom, as the image
    normals = Sphere().point(uu, vv)
    facing = normals @ hatching.LIGHT
    inks = {}
    for light in (0.0, 1.0):
        result, covered = _run(grey, settings.replace(hatch_light=light), (vertices, faces, uvs))
        ink = _ink(result.image)
        inks[light] = ink[covered & (facing > 0.7)].mean(), ink[covered & (facing < -0.2)].mean()
    assert abs(inks[0.0][1] - inks[0.0][0]) < 0.08                        # without it, one tone all round
    assert inks[1.0][1] - inks[1.0][0] > 0.25                             # with it, the far side darker


@pytest.mark.parametrize("mode", ["eed", "gaussian"])     # the flow along the lines; a Gaussian's fallback
def test_line_smoothing_calms_the_widths_along_the_lines_and_keeps_a_step_across_them(mode):
    rng = np.random.default_rng(5)
    image = np.clip(0.5 + 0.2 * rng.standard_normal((48, 48, 1)), 0, 1).repeat(3, axis=2).astype(np.float32)
    image[:24] *= 0.5                                       # a step across the lines (they run along the rows)
    found = {}
    for smooth in (0.0, 0.5):
        result, covered = _run(image, _LINES.replace(mode=mode, T=1e-6, hatch_ink=0.5, hatch_smooth=smooth))
        ink = _ink(result.image)[np.flatnonzero(covered.all(axis=1))[8:-8]][:, 16:240]
        half = len(ink) // 2
        found[smooth] = np.abs(np.diff(ink, axis=1)).mean(), ink[:half - 12].mean() - ink[half + 12:].mean()
    assert found[0.5][0] < 0.8 * found[0.0][0]              # the widths change less along the lines
    assert found[0.5][1] > 0.9 * found[0.0][1] > 0.2       # the step across them stays


def test_the_woodcut_preset_is_one_layer_swelling_to_black_cut_by_white_lines():
    preset = load_preset("woodcut")
    assert preset.name == "Woodcut" and preset.hatch_layers == 1 and preset.hatch_swell >= 1.0 - hatching.LINE_MIN
    assert preset.hatch_spacing > load_preset("hatching").hatch_spacing and preset.line_width > 0


def test_the_ink_and_paper_are_the_palettes_darkest_and_lightest():
    settings = _LINES.replace(palette=((0.9, 0.85, 0.7), (0.1, 0.05, 0.2), (0.5, 0.5, 0.5)))
    ink, paper = hatch_colours(settings)
    np.testing.assert_allclose(ink, (0.1, 0.05, 0.2))
    np.testing.assert_allclose(paper, (0.9, 0.85, 0.7))
    np.testing.assert_allclose(hatch_colours(_LINES), [hatching.INK, hatching.PAPER])


def test_bad_hatching_settings_are_refused_with_their_names():
    with pytest.raises(ValueError, match="hatch_layers"):
        StylizeSettings(mode="gaussian", hatch_spacing=0.02, hatch_layers=4)
    with pytest.raises(ValueError, match="hatch_angle"):
        StylizeSettings(mode="gaussian", hatch_spacing=0.02, hatch_angle=120)
    with pytest.raises(ValueError, match="hatch_swell"):
        StylizeSettings(mode="gaussian", hatch_spacing=0.02, hatch_swell=0.2)
    with pytest.raises(ValueError, match="direction 'max' is for"):
        StylizeSettings(mode="gaussian", direction="max")
    assert StylizeSettings(mode="eed", direction="max", hatch_spacing=0.02).stroke_direction == "max"


def test_the_ink_hatching_preset_draws_lines_with_outlines():
    preset = load_preset("hatching")
    assert preset.name == "Ink Hatching" and preset.hatch_spacing > 0 and preset.line_width > 0
    assert preset.hatch_layers >= 2 and preset.stroke_direction == "max"        # around the form
    assert preset.strokes == 0 and preset.noise_fraction == 0 and not preset.palette     # black ink, white paper
