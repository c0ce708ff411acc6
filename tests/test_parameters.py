"""The one table of parameters: limits, defaults, and that the settings obey it."""

import pytest

from cp_stylize.parameters import DEFAULTS, FILTER_PARAMETERS, FILTERS, MODES, RUN, check_value
from cp_stylize.presets import StylizeSettings, builtin_presets, load_preset


def test_every_mode_has_a_filter_and_its_defaults_lie_within_the_limits():
    assert set(FILTERS) == set(MODES) == set(DEFAULTS)
    for mode, filt in FILTERS.items():
        assert set(filt.defaults) <= set(FILTER_PARAMETERS), mode
        for parameter in filt.parameters:
            assert parameter.minimum <= filt.defaults[parameter.name] <= parameter.maximum, (mode, parameter.name)
    for parameter in list(RUN.values()) + list(FILTER_PARAMETERS.values()):
        assert parameter.minimum <= parameter.default <= parameter.maximum, parameter.name


def test_every_filter_parameter_is_used_by_a_mode():
    used = {name for filt in FILTERS.values() for name in filt.defaults}
    assert used == set(FILTER_PARAMETERS)


def test_shipped_presets_lie_within_the_limits():
    presets = builtin_presets()
    assert {"starry_night", "van_gogh_form", "sunflower_vase", "denoise_eed"} <= set(presets)
    for name in presets:
        settings = load_preset(name)            # raises if a value is out of its limits; and they hold after
        for parameter in RUN.values():
            assert parameter.minimum <= getattr(settings, parameter.name) <= parameter.maximum, (name, parameter.name)
        for parameter_name, value in settings.params.items():
            parameter = FILTER_PARAMETERS[parameter_name]
            assert parameter.minimum <= value <= parameter.maximum, (name, parameter_name)


def test_settings_made_without_values_take_the_tables_defaults():
    settings = StylizeSettings()
    for parameter in RUN.values():
        assert getattr(settings, parameter.name) == parameter.default, parameter.name


@pytest.mark.parametrize("field, value, message", [
    ("T", 1000.0, "T must lie in [1e-06, 0.1], got 1000.0"),
    ("spacing", 5.0, "spacing must lie in [0.002, 0.1], got 5.0"),
    ("spacing", 0.0, "spacing must lie in [0.002, 0.1], got 0.0"),
    ("rho", -1e-4, "rho must lie in [0, 0.05], got -0.0001"),
    ("alpha", 1.5, "alpha must lie in [0, 1], got 1.5"),
    ("noise_fraction", float("nan"), "noise_fraction must lie in [0, 1], got nan"),
    ("lambda_rel", True, "lambda_rel must lie in [1e-06, 10], got True"),
])
def test_settings_outside_the_limits_are_refused(field, value, message):
    with pytest.raises(ValueError) as info:
        StylizeSettings().replace(**{field: value})
    assert str(info.value) == message


def test_single_precision_values_at_a_limit_pass():
    import numpy as np

    # the panel stores 1e-6 as float32, a hair below the limit
    assert check_value("T", float(np.float32(1e-6)), 1e-6, 0.1) == pytest.approx(1e-6)
