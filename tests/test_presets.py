import os

import numpy as np
import pytest

from cp_stylize.presets import StylizeSettings, builtin_presets, load_preset, parse_hex, save_preset
from cp_stylize.strokes import LENGTH_SPREAD

REQUIRED = {"starry_night", "sunflower_vase", "van_gogh_form", "denoise_eed", "perona_malik", "gaussian_blur",
            "hatching", "woodcut", "watercolour", "hand_painted"}
PAINTERLY = ("starry_night", "van_gogh_form", "sunflower_vase")


def test_every_shipped_preset_loads():
    presets = builtin_presets()
    assert REQUIRED <= set(presets)
    assert not {"starry_night_paper", "fingerprint"} & set(presets)    # the paper's figures, not looks
    for name in presets:
        settings = load_preset(name)
        assert settings.name and settings.description


@pytest.mark.parametrize("name", PAINTERLY)
def test_the_painterly_presets_paint_strokes_three_to_five_times_longer_than_wide_with_relief(name):
    s = load_preset(name)
    assert (s.noise_mapping, s.strokes) == ("tone", 1.0) and 0.1 <= s.detail <= 1.0     # some of the picture's detail in the paint
    low, high = 1 - LENGTH_SPREAD, 1 + LENGTH_SPREAD
    assert 3.0 <= low * s.stroke_length / s.stroke_width and high * s.stroke_length / s.stroke_width <= 5.0
    assert s.relief > 0 and s.contours > 0 and s.stroke_layers >= 2


def test_the_painterly_presets_are_each_their_own_look():
    starry, form, sunflowers = (load_preset(name) for name in PAINTERLY)
    assert starry.swirl > 0 and form.swirl == sunflowers.swirl == 0            # only Starry Night swirls
    assert form.stroke_direction == "min" and starry.stroke_direction == "texture"   # along the form
    assert sunflowers.relief > starry.relief and sunflowers.stroke_width > starry.stroke_width   # thick, broad
    assert len({starry.palette, form.palette, sunflowers.palette}) == 3


def test_save_and_load_round_trip(tmp_path):
    s = load_preset("starry_night").replace(name="Mine", T=2e-4, image_size=2048)
    back = load_preset(save_preset(s, tmp_path / "mine.toml"))
    assert back.T == s.T and back.image_size == 2048 and back.mode == s.mode
    np.testing.assert_allclose(back.palette, s.palette, atol=1 / 255)
    assert back.palette_weights == s.palette_weights and back.b_rel == s.b_rel
    assert (back.noise_mapping, back.noise_spread, back.detail) == (s.noise_mapping, s.noise_spread, s.detail)
    for field in ("strokes", "stroke_length", "stroke_width", "stroke_layers", "stroke_jitter", "swirl", "relief",
                  "fidelity", "keep_values", "contours"):
        assert getattr(back, field) == getattr(s, field)


def test_every_run_parameter_of_the_table_round_trips_through_a_preset_file(tmp_path):
    """The parameter table says where each run parameter lives in a preset file; a value other than its default
    is written there and read back, for every one."""
    from cp_stylize.parameters import RUN
    from cp_stylize.presets import preset_text

    base = load_preset("starry_night")
    for parameter in RUN.values():
        value = parameter.maximum if getattr(base, parameter.name) != parameter.maximum else parameter.minimum
        changed = base.replace(**{parameter.name: value})
        table, key = parameter.file
        assert f"{key} = " in preset_text(changed).split(f"[{table}]")[-1 if table else 0], parameter.name
        back = load_preset(save_preset(changed, tmp_path / f"{parameter.name}.toml"))
        assert getattr(back, parameter.name) == pytest.approx(value), parameter.name


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
    h, kw = s.scaled(20.0)  # an object 20 units across: ten times the paper's size
    assert h == pytest.approx(0.1) and kw["T"] == pytest.approx(1e-2) and kw["sigma"] == pytest.approx(2e-2)


ENTRY = '"#rrggbb", [r, g, b] or ["#rrggbb", weight] (r, g, b in [0, 1], a weight of at least 0)'


@pytest.mark.parametrize("text, message", [
    ('mode = "blur"', "mode must be one of ['gaussian', 'perona_malik', 'eed', 'ced', 'beltrami', 'flow'], got 'blur'"),
    ('mode = "ced"\nT = -1.0', "T must lie in [1e-06, 0.1], got -1.0"),
    ('mode = "ced"\nshape = 3', "unknown key(s) ['shape']; known: ['name', 'description', 'mode', 'T', 'spacing', "
                                "'detail', 'contours', 'direction', 'axis', 'attribute', 'params', 'noise', 'strokes', "
                                "'oil', 'toon', 'watercolour', 'lines', 'hatching', "
                                "'shading', 'output']"),
    ('mode = "ced"\n[params]\ngamma = 1.0', "unknown parameter(s) ['gamma'] in [params]; known: ['sigma', 'rho', "
                                            "'alpha', 'b_rel', 'beta', 'contrast', 'ink', 'lambda_rel']"),
    ('mode = "ced"\n[noise]\nfraction = 0.5\npalette = [["#12345", 1]]',
     f"[noise] palette entry 1 must be {ENTRY}, got ['#12345', 1]"),
    ('mode = "ced"\ndirection = "up"', "direction must be one of ['texture', 'max', 'min', 'axis', 'around', 'attribute'], "
                                       "got 'up'"),
    ('mode = "eed"\ndirection = "min"', "direction 'min' is for the modes ['ced', 'flow'], brush strokes and "
                                       "hatching, not 'eed' without either"),
    ('mode = "flow"\ndirection = "texture"', "mode 'flow' draws along a direction field: direction must be one of "
                                             "['max', 'min', 'axis', 'around', 'attribute'], not 'texture'"),
    ('mode = "ced"\naxis = [0, 0, 0]', "axis must be three finite numbers, not all zero, got [0, 0, 0]"),
    ('mode = "ced"\naxis = [1, 2]', "axis must be three finite numbers, not all zero, got [1, 2]"),
    ('mode = "ced"\ndetail = 1.5', "detail must lie in [0, 1], got 1.5"),
    ('mode = "ced"\n[noise]\nmapping = "hue"\npalette = ["#102040"]',
     "[noise] mapping must be one of ['random', 'tone'], got 'hue'"),
    ('mode = "ced"\n[noise]\nmapping = "tone"', "noise needs a palette of at least one colour"),
    ('mode = "ced"\n[noise]\nmapping = "tone"\nspread = -1\npalette = ["#102040"]',
     "[noise] spread must lie in [0, 1], got -1"),
    ('mode = "ced"\n[strokes]\nlenght = 0.1', "unknown key(s) ['lenght'] in [strokes]; known: strength, length, "
                                              "width, layers, chain, broad, jitter, swirl, stars, relief, sheen"),
    ('mode = "ced"\n[strokes]\nwidth = 0.5\n[noise]\npalette = ["#102040"]',
     "[strokes] width must lie in [0.003, 0.2], got 0.5"),
    ('mode = "ced"\n[strokes]\nlayers = 2.5', "[strokes] layers must be a whole number in [1, 4], got 2.5"),
    ('mode = "ced"\n[noise]\nfidelity = 2\npalette = ["#102040"]', "[noise] fidelity must lie in [0, 1], got 2"),
    ('mode = "ced"\ncontours = "yes"', "contours must lie in [0, 1], got 'yes'"),
    ('mode = = "ced"', "not valid TOML: Invalid value (at line 1, column 8)"),
    ('# nothing but a comment\n', "the preset is empty: it holds no settings"),
])
def test_bad_presets_are_reported(tmp_path, text, message):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(ValueError) as info:
        load_preset(str(path))
    assert str(info.value) == f"{path}: {message}"


# -- every field of the format, and every wrong type: one message a bad field -----------------------------

WRONG_TYPES = [
    ('name = 5', "name must be text, got 5"),
    ('description = ["x"]', "description must be text, got ['x']"),
    ('mode = 3', "mode must be one of ['gaussian', 'perona_malik', 'eed', 'ced', 'beltrami', 'flow'], got 3"),
    ('mode = ["ced"]', "mode must be one of ['gaussian', 'perona_malik', 'eed', 'ced', 'beltrami', 'flow'], "
                       "got ['ced']"),
    ('T = "abc"', "T must lie in [1e-06, 0.1], got 'abc'"),
    ('spacing = true', "spacing must lie in [0.002, 0.1], got True"),
    ('detail = [1]', "detail must lie in [0, 1], got [1]"),
    ('direction = 1', "direction must be one of ['texture', 'max', 'min', 'axis', 'around', 'attribute'], got 1"),
    ('axis = 5', "axis must be three finite numbers, not all zero, got 5"),
    ('axis = "xyz"', "axis must be three finite numbers, not all zero, got 'xyz'"),
    ('axis = [1, "a", 0]', "axis must be three finite numbers, not all zero, got [1, 'a', 0]"),
    ('attribute = 2', "attribute must be text, got 2"),
    ('params = "x"', "params must be a table ([params] with sigma, rho, alpha, b_rel, beta, contrast, ink, "
                     "lambda_rel), got 'x'"),
    ('[params]\nrho = "wide"', "[params] rho must lie in [0, 0.05], got 'wide'"),
    ('noise = 5', "noise must be a table ([noise] with mapping, seed, fraction, spread, fidelity, keep_values, keep_darks, hue_snap, palette), got 5"),
    ('[noise]\nfraction = "half"', "[noise] fraction must lie in [0, 1], got 'half'"),
    ('[noise]\nmapping = 1', "[noise] mapping must be one of ['random', 'tone'], got 1"),
    ('[noise]\nspread = {a = 1}', "[noise] spread must lie in [0, 1], got {'a': 1}"),
    ('[noise]\nseed = 99999999999', "[noise] seed must be a whole number in [0, 2147483647], got 99999999999"),
    ('[noise]\nseed = -5', "[noise] seed must be a whole number in [0, 2147483647], got -5"),
    ('[noise]\nseed = 1.5', "[noise] seed must be a whole number in [0, 2147483647], got 1.5"),
    ('[noise]\nseed = "1"', "[noise] seed must be a whole number in [0, 2147483647], got '1'"),
    ('[noise]\npalette = "#ff0000"', f"[noise] palette must be a list of colours, each {ENTRY}, got '#ff0000'"),
    ('[noise]\npalette = [[1, 2]]', f"[noise] palette entry 1 must be {ENTRY}, got [1, 2]"),
    ('[noise]\npalette = [["#ffffff"]]', f"[noise] palette entry 1 must be {ENTRY}, got ['#ffffff']"),
    ('[noise]\npalette = [["#ff0000", -1]]', f"[noise] palette entry 1 must be {ENTRY}, got ['#ff0000', -1]"),
    ('[noise]\npalette = [["#ff0000", "heavy"]]', f"[noise] palette entry 1 must be {ENTRY}, got ['#ff0000', 'heavy']"),
    ('[noise]\npalette = [[0.5, 2.0, 0.0]]', f"[noise] palette entry 1 must be {ENTRY}, got [0.5, 2.0, 0.0]"),
    ('[noise]\npalette = [5]', f"[noise] palette entry 1 must be {ENTRY}, got 5"),
    ('strokes = [1]', "strokes must be a table ([strokes] with strength, length, width, layers, chain, broad, jitter, "
                      "swirl, stars, relief, sheen), got [1]"),
    ('[strokes]\nstrength = "full"', "[strokes] strength must lie in [0, 1], got 'full'"),
    ('[strokes]\nlength = [0.1]', "[strokes] length must lie in [0.01, 1], got [0.1]"),
    ('[strokes]\nwidth = false', "[strokes] width must lie in [0.003, 0.2], got False"),
    ('output = 1024', "output must be a table ([output] with size, margin), got 1024"),
    ('[output]\nsize = 1024.5', "[output] size must be a whole number in [16, 8192], got 1024.5"),
    ('[output]\nsize = 100000', "[output] size must be a whole number in [16, 8192], got 100000"),
    ('[output]\nmargin = -1', "[output] margin must be a whole number in [0, 256], got -1"),
    ('[output]\nmargin = "16"', "[output] margin must be a whole number in [0, 256], got '16'"),
]


@pytest.mark.parametrize("text, message", WRONG_TYPES)
def test_every_field_of_a_preset_is_checked_with_its_name_and_what_it_must_be(tmp_path, text, message):
    path = tmp_path / "bad.toml"
    path.write_text(text + "\n")
    with pytest.raises(ValueError) as info:
        load_preset(str(path))
    assert str(info.value) == f"{path}: {message}"


def test_a_preset_with_several_bad_fields_names_each_of_them(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text('name = 5\nmode = "eed"\nT = 3e-4\n[noise]\nseed = 99999999999\npalette = [[1, 2], "#00ff00"]\n')
    with pytest.raises(ValueError) as info:
        load_preset(str(path))
    assert str(info.value) == (f"{path}: [noise] palette entry 1 must be {ENTRY}, got [1, 2]; name must be text, "
                               "got 5; [noise] seed must be a whole number in [0, 2147483647], got 99999999999")


@pytest.mark.parametrize("content, message", [
    (b"\xff\xfem\x00o\x00d\x00e\x00", "not valid TOML: a preset is a text file in UTF-8"),
    (bytes(range(256)), "not valid TOML: a preset is a text file in UTF-8"),
])
def test_a_preset_that_is_not_text_is_reported(tmp_path, content, message):
    path = tmp_path / "binary.toml"
    path.write_bytes(content)
    with pytest.raises(ValueError) as info:
        load_preset(str(path))
    assert str(info.value) == f"{path}: {message}"


@pytest.mark.parametrize("changes, message", [
    (dict(seed=2**31), "seed must be a whole number in [0, 2147483647], got 2147483648"),
    (dict(seed=True), "seed must be a whole number in [0, 2147483647], got True"),
    (dict(name=None), "name must be text, got None"),
    (dict(noise_mapping=["tone"]), "noise_mapping must be one of ['random', 'tone'], got ['tone']"),
    (dict(params="x"), "params must be a table of filter parameters (sigma, rho, alpha, b_rel, beta, contrast, ink, "
                       "lambda_rel), got 'x'"),
    (dict(palette=((1, 2),)), "palette must be colours of three numbers in [0, 1], got ((1, 2),)"),
    (dict(palette=((0.1, 0.2, 0.3),), palette_weights=(-1,)), "palette_weights must be numbers of at least 0, one a "
                                                               "colour, got (-1,)"),
    (dict(image_size=1000.0), "image_size must be a whole number in [16, 8192], got 1000.0"),
    (dict(noise_fraction=0.3, palette=((0.1, 0.2, 0.3),), palette_weights=(0.0,)),
     "the palette's weights are all 0, so no colour could be drawn: give at least one colour a weight above 0"),
    (dict(strokes=0.5, palette=((0.1, 0.2, 0.3), (0.5, 0.5, 0.5)), palette_weights=(0.0, 0.0)),
     "the palette's weights are all 0, so no colour could be drawn: give at least one colour a weight above 0"),
])
def test_settings_check_every_field_before_a_run(changes, message):
    with pytest.raises(ValueError) as info:
        StylizeSettings(**changes)
    assert str(info.value) == message


def test_every_field_round_trips_through_a_preset_file(tmp_path):
    settings = StylizeSettings(
        mode="ced", T=3.3e-4, spacing=0.011, params={"sigma": 2e-4, "rho": 1e-3, "alpha": 0.01, "b_rel": 1e-5},
        noise_fraction=0.0, noise_mapping="random", noise_spread=0.3, detail=0.4, strokes=0.6, stroke_length=0.2,
        stroke_width=0.02, palette=((0.1, 0.1, 0.5), (0.3, 0.302, 0.9), (1.0, 0.8, 0.0)),
        palette_weights=(2.0, 0.5, 0.0),
        seed=2**31 - 1, direction="axis", axis=(1.0, -0.5, 0.25), attribute="comb", image_size=2048, margin=7,
        name='Mine "quoted" \\ Звёзды', description="strokes without noise")
    back = load_preset(save_preset(settings, tmp_path / "mine.toml"))
    assert back == settings       # every field, the palette's colours exact (not rounded to 8 bits)


@pytest.mark.parametrize("settings", [
    StylizeSettings(mode="ced", strokes=0.6, palette=((0.2, 0.3, 0.9),)),           # strokes, no noise
    StylizeSettings(mode="eed", seed=42, noise_spread=0.3),                          # no palette at all
    StylizeSettings(mode="flow", direction="min", params={"ink": 0.5}),
    StylizeSettings(mode="ced", noise_mapping="tone", noise_fraction=0.2, palette=((0.2, 0.3, 0.9),)),
])
def test_what_is_saved_loads_back(tmp_path, settings):
    assert load_preset(save_preset(settings, tmp_path / "p.toml")) == settings


def test_a_failed_save_leaves_the_file_that_was_there(tmp_path, monkeypatch):
    import cp_stylize.presets as presets

    path = tmp_path / "mine.toml"
    save_preset(StylizeSettings(mode="eed", name="Mine"), path)
    before = path.read_bytes()

    def broken(settings):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(presets, "preset_text", lambda settings: "mode = " + str(broken(settings)))
    with pytest.raises(OSError):
        save_preset(StylizeSettings(mode="ced"), path)
    assert path.read_bytes() == before and sorted(p.name for p in tmp_path.iterdir()) == ["mine.toml"]


# -- names: one preset a key, and saving never over another -----------------------------------------------


def test_names_that_share_a_key_are_saved_apart(tmp_path):
    from cp_stylize.presets import preset_menu, save_user_preset

    eed, blur = StylizeSettings(mode="eed", T=3e-4), StylizeSettings(mode="gaussian", T=5e-4)
    assert save_user_preset(eed, tmp_path, "Wood grain")[:1] == ("wood_grain",)
    key, path, replaced = save_user_preset(blur, tmp_path, "wood/grain")
    assert (key, os.path.basename(path), replaced) == ("wood_grain_2", "wood_grain_2.toml", False)
    assert load_preset("wood_grain", [tmp_path]).replace(name="") == eed
    assert load_preset("wood_grain_2", [tmp_path]).name == "wood/grain"
    menu = dict(preset_menu([tmp_path]))
    assert (menu["wood_grain"], menu["wood_grain_2"]) == ("Wood grain", "wood/grain")
    # the same name again is that preset, saved anew (and said so)
    key, path, replaced = save_user_preset(blur, tmp_path, "Wood grain")
    assert (key, replaced) == ("wood_grain", True) and load_preset("wood_grain", [tmp_path]).mode == "gaussian"
    assert sorted(os.listdir(tmp_path)) == ["wood_grain.toml", "wood_grain_2.toml"]


@pytest.mark.parametrize("name, message", [
    ("Starry Night", "'Starry Night' is the name of a shipped preset: choose another name"),
    ("starry night", "'starry night' is the name of a shipped preset: choose another name"),
    ("   ", "a preset needs a name"),
    ("///", "a preset's name needs a letter or a digit, got '///'"),
    ("x" * 300, "a preset's name may be 64 characters long, and this one has 300: choose a shorter name"),
])
def test_names_that_cannot_be_saved_are_refused(tmp_path, name, message):
    from cp_stylize.presets import save_user_preset

    with pytest.raises(ValueError) as info:
        save_user_preset(StylizeSettings(), tmp_path, name)
    assert str(info.value) == message
    assert os.listdir(tmp_path) == []


@pytest.mark.parametrize("name, key", [
    ("Sunflower Vase 2", "sunflower_vase_2"),
    ("Sunflower-Vase", "sunflower_vase_2"),                 # a shipped key, another name
    ("Звёздная ночь", "звёздная_ночь"), ("日本", "日本"), ("CON", "con_"),
    ("../../evil", "evil"), ("a/b", "a_b"),
    ("y" * 64, "y" * 64), ("日" * 64, "日" * 40),
])
def test_keys_are_file_names_on_every_system(tmp_path, name, key):
    from cp_stylize.presets import save_user_preset

    assert save_user_preset(StylizeSettings(), tmp_path, name)[0] == key
    assert os.listdir(tmp_path) == [key + ".toml"] and load_preset(key, [tmp_path]).name == name


def test_a_key_means_one_file_everywhere(tmp_path):
    from cp_stylize.presets import find_preset, preset_menu, preset_paths, remove_user_preset

    user = tmp_path / "starry_night.toml"     # made by hand, or by an older version: a shipped key
    save_preset(StylizeSettings(mode="gaussian", name="Starry Night"), user)
    assert find_preset("starry_night", [tmp_path]) == builtin_presets()["starry_night"]
    assert load_preset("starry_night", [tmp_path]).strokes == 1.0
    paths = preset_paths([tmp_path])
    assert paths[str(user)] == str(user) and paths["starry_night"] == builtin_presets()["starry_night"]
    assert load_preset(str(user), [tmp_path]).mode == "gaussian"
    labels = dict(preset_menu([tmp_path]))
    assert (labels["starry_night"], labels[str(user)]) == ("Starry Night", "Starry Night (starry_night.toml)")
    assert len(set(labels.values())) == len(labels)
    with pytest.raises(ValueError, match="'starry_night' is a shipped preset, not a user preset: it cannot be removed"):
        remove_user_preset("starry_night", tmp_path)
    assert remove_user_preset(str(user), tmp_path) == str(user) and not user.exists()


def test_unknown_preset_name_lists_the_shipped_ones():
    with pytest.raises(ValueError, match="starry_night"):
        load_preset("no_such_preset")


def test_parse_hex():
    assert parse_hex("#ff8000") == (1.0, 128 / 255, 0.0)
