import numpy as np
import pytest

from cp_stylize.presets import StylizeSettings, builtin_presets, load_preset, parse_hex, save_preset

REQUIRED = {"starry_night", "starry_night_paper", "sunflower_vase", "fingerprint", "denoise_eed", "perona_malik", "gaussian_blur",
            "hatching", "van_gogh_form"}


def test_every_shipped_preset_loads():
    presets = builtin_presets()
    assert REQUIRED <= set(presets)
    for name in presets:
        settings = load_preset(name)
        assert settings.name and settings.description


def test_starry_night_paper_follows_the_paper():
    s = load_preset("starry_night_paper")
    assert (s.mode, s.sigma, s.rho, s.alpha, s.b_rel, s.spacing) == ("ced", 1e-4, 5e-4, 1e-3, 1e-6, 0.008)
    assert s.noise_fraction == pytest.approx(0.67) and s.noise_mapping == "random"
    # about ten steps of the paper's 0.15 h^2
    assert 9 <= s.T / (0.15 * s.spacing**2) <= 12
    # mostly dark blues: blue dominates and the colours are dark in most of the weight
    rgb, w = np.array(s.palette), np.array(s.palette_weights)
    dark_blue = (rgb[:, 2] > rgb[:, 0]) & (rgb.mean(axis=1) < 0.45)
    assert w[dark_blue].sum() > 0.6 * w.sum()
    assert any(r > 0.9 and g > 0.7 and b < 0.4 for r, g, b in rgb)  # a star yellow


def test_starry_night_maps_the_pictures_tones_with_long_coherent_strokes():
    s, paper = load_preset("starry_night"), load_preset("starry_night_paper")
    assert (s.mode, s.noise_mapping, s.detail) == ("ced", "tone", 0.0)
    assert s.rho >= 4 * paper.rho and s.T >= 3 * paper.T          # wider orientation, longer strokes
    assert set(s.palette) <= set(paper.palette)                    # the painting's colours


def test_the_looks_along_the_form_follow_the_minimum_curvature():
    hatching, van_gogh = load_preset("hatching"), load_preset("van_gogh_form")
    assert (hatching.mode, hatching.stroke_direction, hatching.ink > 0) == ("flow", "min", True)
    assert hatching.noise_fraction == 0                      # the texture keeps its tones: ink over it
    starry = load_preset("starry_night")
    assert (van_gogh.mode, van_gogh.stroke_direction) == ("ced", "min")
    assert van_gogh.palette == starry.palette and van_gogh.noise_fraction == starry.noise_fraction


def test_save_and_load_round_trip(tmp_path):
    s = load_preset("starry_night").replace(name="Mine", T=2e-4, image_size=2048)
    back = load_preset(save_preset(s, tmp_path / "mine.toml"))
    assert back.T == s.T and back.image_size == 2048 and back.mode == s.mode
    np.testing.assert_allclose(back.palette, s.palette, atol=1 / 255)
    assert back.palette_weights == s.palette_weights and back.b_rel == s.b_rel
    assert (back.noise_mapping, back.noise_spread, back.detail) == (s.noise_mapping, s.noise_spread, s.detail)
    assert (back.strokes, back.stroke_length, back.stroke_width) == (1.0, 0.2, 0.008)    # starry_night's [strokes]


def test_a_stroke_direction_round_trips_and_each_mode_has_its_own_default(tmp_path):
    assert StylizeSettings(mode="ced").stroke_direction == "texture"
    assert StylizeSettings(mode="flow").stroke_direction == "min"
    assert StylizeSettings(mode="eed").stroke_direction == "texture"
    s = StylizeSettings(mode="ced", direction="attribute", axis=(1, 0, 0), attribute="comb", name="Combed")
    back = load_preset(save_preset(s, tmp_path / "combed.toml"))
    assert (back.direction, back.axis, back.attribute) == ("attribute", (1.0, 0.0, 0.0), "comb")
    assert load_preset(save_preset(StylizeSettings(), tmp_path / "plain.toml")).direction is None


def test_settings_scale_with_the_object():
    s = StylizeSettings(mode="eed", T=1e-4, spacing=0.01, params={"sigma": 2e-4})
    h, kw = s.scaled(20.0)  # an object 20 units long: ten times the paper's size
    assert h == pytest.approx(0.1) and kw["T"] == pytest.approx(1e-2) and kw["sigma"] == pytest.approx(2e-2)


@pytest.mark.parametrize("text, message", [
    ('mode = "blur"', "mode must be one of"),
    ('mode = "ced"\nT = -1.0', r"T must lie in \[1e-06, 0.1\], got -1.0"),
    ('mode = "ced"\nshape = 3', "unknown key"),
    ('mode = "ced"\n[params]\ngamma = 1.0', "unknown parameter"),
    ('mode = "ced"\n[noise]\nfraction = 0.5\npalette = [["#12345", 1]]', "'#rrggbb'"),
    ('mode = = "ced"', "not valid TOML"),
    ('mode = "ced"\ndirection = "up"', "direction must be one of"),
    ('mode = "eed"\ndirection = "min"', r"direction 'min' is for the modes \['ced', 'flow'\], not 'eed'"),
    ('mode = "flow"\ndirection = "texture"', "mode 'flow' draws along a direction field"),
    ('mode = "ced"\naxis = [0, 0, 0]', "axis must be three finite numbers, not all zero"),
    ('mode = "ced"\naxis = [1, 2]', "axis must be three finite numbers"),
    ('mode = "ced"\ndetail = 1.5', r"detail must lie in \[0, 1\], got 1.5"),
    ('mode = "ced"\n[noise]\nmapping = "hue"\npalette = ["#102040"]', "noise mapping must be one of"),
    ('mode = "ced"\n[noise]\nmapping = "tone"', "noise needs a palette"),
    ('mode = "ced"\n[noise]\nmapping = "tone"\nspread = -1\npalette = ["#102040"]', r"noise_spread must lie in \[0, 1\], got -1"),
    ('mode = "ced"\n[strokes]\nstrength = 1', "strokes are drawn in a palette's colours: they need a palette"),
    ('mode = "ced"\n[strokes]\nlenght = 0.1', r"unknown key\(s\) \['lenght'\] in \[strokes\]"),
    ('mode = "ced"\n[strokes]\nwidth = 0.5\n[noise]\npalette = ["#102040"]', r"stroke_width must lie in \[0.001, 0.1\], got 0.5"),
])
def test_bad_presets_are_reported(tmp_path, text, message):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(ValueError, match=message):
        load_preset(str(path))


def test_unknown_preset_name_lists_the_shipped_ones():
    with pytest.raises(ValueError, match="starry_night"):
        load_preset("no_such_preset")


def test_parse_hex():
    assert parse_hex("#ff8000") == (1.0, 128 / 255, 0.0)
