"""The settings of a stylization run: one frozen :class:`StylizeSettings`, every field checked.

Lengths and times are relative to the object's size: the object is normalised
so that its diameter is 2 (as in the paper: a sphere of radius 1), so the same
settings look the same on a 2 cm object and on a 20 m one.  The run's numbers
take their limits and defaults from the parameter table
(:mod:`cp_stylize.parameters`); a bad field is refused with a ValueError that
names each bad one, what it must be and what it got.  Presets
(:mod:`cp_stylize.presets`) are these settings in TOML files.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from collections.abc import Mapping

from .parameters import (DIRECTED_MODES, DIRECTIONS, FILTER_PARAMETERS, MODES, NOISE_MAPPINGS, RUN, SEED_LIMITS,
                         check_value, paints_shading, takes_direction)

__all__ = ["StylizeSettings", "check_fields", "check_colour", "check_parameter", "is_number", "IMAGE_SIZES", "MARGINS"]

#: The parameters that are times: they scale with the square of the object's size.
_TIMES = {p.name for p in (*RUN.values(), *FILTER_PARAMETERS.values()) if p.unit == "time"}

#: Output image sizes a run may ask for, in texels a side.
IMAGE_SIZES = (16, 8192)
#: Margins a run may ask for, in texels.
MARGINS = (0, 256)


class _Params(Mapping):
    """The filter parameters of a :class:`StylizeSettings`: a read-only, hashable mapping."""

    __slots__ = ("_values",)

    def __init__(self, values):
        self._values = dict(values)

    def __getitem__(self, name):
        return self._values[name]

    def __iter__(self):
        return iter(self._values)

    def __len__(self):
        return len(self._values)

    def __hash__(self):
        return hash(frozenset(self._values.items()))

    def __repr__(self):
        return repr(self._values)


# -- one check a field: each returns the value it accepts, or raises ValueError naming ``label`` ---------


def _text(label, value):
    if not isinstance(value, str):
        raise ValueError(f"{label} must be text, got {value!r}")
    return value


def _choice(choices, *, optional=False):
    def check(label, value):
        if optional and value is None:
            return None
        if not isinstance(value, str) or value not in choices:
            raise ValueError(f"{label} must be one of {list(choices)}, got {value!r}")
        return value
    return check


def _whole(low, high):
    def check(label, value):
        if isinstance(value, bool) or not isinstance(value, numbers.Integral) or not low <= value <= high:
            raise ValueError(f"{label} must be a whole number in [{low}, {high}], got {value!r}")
        return int(value)
    return check


def _parameter(parameter):
    if parameter.unit == "count":
        return _whole(int(parameter.minimum), int(parameter.maximum))
    return lambda label, value: check_value(label, value, parameter.minimum, parameter.maximum)


def is_number(value):
    """Whether ``value`` is a finite real number (not a bool)."""
    return not isinstance(value, bool) and isinstance(value, numbers.Real) and math.isfinite(value)


def _axis(label, value):
    try:
        axis = tuple(float(a) for a in value) if not isinstance(value, str) else ()
    except (TypeError, ValueError):
        axis = ()
    if len(axis) != 3 or not all(is_number(a) for a in value) or not any(axis):
        raise ValueError(f"{label} must be three finite numbers, not all zero, got {value!r}")
    return axis


def _colours(label, value):
    colours = tuple(tuple(c) if isinstance(c, (tuple, list)) else c for c in value) \
        if isinstance(value, (tuple, list)) else None
    if colours is None or not all(isinstance(c, tuple) and len(c) == 3 and all(is_number(x) and 0 <= x <= 1 for x in c)
                                  for c in colours):
        raise ValueError(f"{label} must be colours of three numbers in [0, 1], got {value!r}")
    return tuple(tuple(float(x) for x in c) for c in colours)


def _weights(label, value):
    if not isinstance(value, (tuple, list)) or not all(is_number(w) and w >= 0 for w in value):
        raise ValueError(f"{label} must be numbers of at least 0, one a colour, got {value!r}")
    return tuple(float(w) for w in value)


def _params(label, value):
    if not isinstance(value, Mapping):
        raise ValueError(f"{label} must be a table of filter parameters ({', '.join(tuple(FILTER_PARAMETERS))}), got {value!r}")
    unknown = sorted(set(value) - set(FILTER_PARAMETERS), key=str)
    if unknown:
        raise ValueError(f"unknown filter parameter(s) {unknown}; known: {list(FILTER_PARAMETERS)}")
    problems, params = [], {}
    for name, v in value.items():
        if v is not None:
            try:
                params[name] = FILTER_PARAMETERS[name].check(v)
            except ValueError as err:
                problems.append(str(err))
    if problems:
        raise ValueError("; ".join(problems))
    return _Params(params)


#: How each field of :class:`StylizeSettings` is checked (its limits: :mod:`cp_stylize.parameters`).
_CHECKS = {
    "mode": _choice(MODES),
    **{name: _parameter(parameter) for name, parameter in RUN.items()},
    "params": _params,
    "noise_mapping": _choice(NOISE_MAPPINGS),
    "palette": _colours,
    "palette_weights": _weights,
    "seed": _whole(*SEED_LIMITS),
    "direction": _choice(DIRECTIONS, optional=True),
    "axis": _axis,
    "attribute": _text,
    "image_size": _whole(*IMAGE_SIZES),
    "margin": _whole(*MARGINS),
    "name": _text,
    "description": _text,
}


def check_colour(label, value):
    """``value``, three numbers in [0, 1], as a colour tuple; ValueError naming ``label`` otherwise."""
    return _colours(label, [value])[0]


def check_parameter(name, label, value):
    """The filter parameter ``name``'s ``value`` checked against its limits (ValueError naming ``label``)."""
    return _parameter(FILTER_PARAMETERS[name])(label, value)


def check_fields(values, labels):
    """``values`` ({field: value}) each checked, and the messages of those that are bad (``labels`` names them)."""
    good, problems = {}, []
    for field, value in values.items():
        try:
            good[field] = _CHECKS[field](labels.get(field, field), value)
        except ValueError as err:
            problems.append(str(err))
    return good, problems


@dataclasses.dataclass(frozen=True)
class StylizeSettings:
    """Everything a stylization run needs, relative to an object whose diameter is 2.

    Every field is checked when the settings are made: a ValueError names each
    bad one, what it must be and what it got.
    """

    mode: str = "ced"
    # the run's numbers default to the parameter table's (cp_stylize.parameters.RUN)
    T: float = RUN["T"].default
    spacing: float = RUN["spacing"].default
    params: Mapping = dataclasses.field(default_factory=dict)   # filter parameters set; the mode's defaults fill in
    noise_fraction: float = RUN["noise_fraction"].default
    noise_mapping: str = "random"   # see NOISE_MAPPINGS
    noise_spread: float = RUN["noise_spread"].default
    detail: float = RUN["detail"].default          # the texture's own detail laid back (baking.lay_detail)
    strokes: float = RUN["strokes"].default        # brush strokes over the result (cp_stylize.strokes)
    stroke_length: float = RUN["stroke_length"].default
    stroke_width: float = RUN["stroke_width"].default
    stroke_layers: int = RUN["stroke_layers"].default
    stroke_chain: int = RUN["stroke_chain"].default
    broad_paint: float = RUN["broad_paint"].default
    stroke_jitter: float = RUN["stroke_jitter"].default
    swirl: float = RUN["swirl"].default
    stars: int = RUN["stars"].default              # stars in the picture's sky (cp_stylize.stars)
    fidelity: float = RUN["fidelity"].default      # mapping "tone": how much of the picture's own colours
    keep_values: float = RUN["keep_values"].default   # mapping "tone": how much of the picture's own lightness
    keep_darks: float = RUN["keep_darks"].default     # and how much more of it in its darks
    hue_snap: float = RUN["hue_snap"].default      # mapping "tone": how far its hues turn to the palette's
    contours: float = RUN["contours"].default      # lines along the strong edges (cp_stylize.contours)
    relief: float = RUN["relief"].default          # the strokes' height, as a second image
    sheen: float = RUN["sheen"].default            # the relief's light and shade in the colour
    shade_light: float = RUN["shade_light"].default    # hand-painted shading (cp_stylize.shading): form light,
    shade_edges: float = RUN["shade_edges"].default    # convex edges and creases,
    shade_warmth: float = RUN["shade_warmth"].default  # and the hue's warm and cool shift with them
    oil_size: float = RUN["oil_size"].default      # oil paint: the Kuwahara filter's radius (cp_stylize.kuwahara)
    oil_sharpness: float = RUN["oil_sharpness"].default
    oil_eccentricity: float = RUN["oil_eccentricity"].default
    toon_levels: int = RUN["toon_levels"].default   # toon bands of lightness (cp_stylize.toon); 0: none
    toon_softness: float = RUN["toon_softness"].default
    toon_outlines: float = RUN["toon_outlines"].default
    wash_levels: int = RUN["wash_levels"].default   # watercolour washes (cp_stylize.watercolour); 0: none
    wash_edges: float = RUN["wash_edges"].default
    wash_granulation: float = RUN["wash_granulation"].default
    wash_bleed: float = RUN["wash_bleed"].default
    wash_wobble: float = RUN["wash_wobble"].default
    hatch_spacing: float = RUN["hatch_spacing"].default   # ink hatching (cp_stylize.hatching); 0: none
    hatch_layers: int = RUN["hatch_layers"].default
    hatch_angle: int = RUN["hatch_angle"].default
    hatch_ink: float = RUN["hatch_ink"].default
    hatch_swell: float = RUN["hatch_swell"].default
    hatch_light: float = RUN["hatch_light"].default
    hatch_smooth: float = RUN["hatch_smooth"].default
    line_width: float = RUN["line_width"].default   # ink lines (cp_stylize.lines); 0: none
    line_detail: float = RUN["line_detail"].default
    palette: tuple = ()             # sRGB colours as (r, g, b) in [0, 1]
    palette_weights: tuple = ()     # one a colour, at least 0 (none given: all 1)
    seed: int = 0                   # a whole number in SEED_LIMITS
    direction: str | None = None    # CED and Flow: see DIRECTIONS; None: the mode's own (stroke_direction)
    axis: tuple = (0.0, 0.0, 1.0)   # directions "axis" and "around", in the object's space
    attribute: str = ""             # direction "attribute": the mesh's vector attribute, for the add-on
    image_size: int = 1024
    margin: int = 16
    name: str = ""
    description: str = ""

    def __post_init__(self):
        """Check every field (the limits are the panel's, :mod:`cp_stylize.parameters`), then how they fit."""
        values, problems = check_fields({f.name: getattr(self, f.name) for f in dataclasses.fields(self)}, {})
        if problems:
            raise ValueError("; ".join(problems))
        if values["palette"] and not values["palette_weights"]:
            values["palette_weights"] = (1.0,) * len(values["palette"])      # all alike
        for field, value in values.items():
            object.__setattr__(self, field, value)
        self._check_palette()
        self._check_direction()
        if self.toon_levels == 1:
            raise ValueError("Toon Levels (toon_levels, [toon] levels in a preset) must be 0 (no toon shading) or "
                             "from 2 to 8 bands of lightness, got 1")
        if self.wash_levels == 1:
            raise ValueError("Washes (wash_levels, [watercolour] washes in a preset) must be 0 (no watercolour) or "
                             "from 2 to 8 washes of lightness, got 1")

    def _check_palette(self):
        if self.noise_on and not self.palette:
            raise ValueError("noise needs a palette of at least one colour")
        if self.palette_weights and len(self.palette_weights) != len(self.palette):
            raise ValueError(f"palette has {len(self.palette)} colours but {len(self.palette_weights)} weights")
        if (self.noise_on or self.strokes > 0) and self.palette_weights and not any(self.palette_weights):
            raise ValueError("the palette's weights are all 0, so no colour could be drawn: give at least one "
                             "colour a weight above 0")

    def _check_direction(self):
        if self.direction not in (None, "texture") and not takes_direction(self.mode, self.strokes,
                                                                           self.hatch_spacing):
            raise ValueError(f"direction {self.direction!r} is for the modes {list(DIRECTED_MODES)}, brush strokes "
                             f"and hatching, not {self.mode!r} without either")
        if self.mode == "flow" and self.direction == "texture":
            raise ValueError("mode 'flow' draws along a direction field: direction must be one of "
                             f"{[d for d in DIRECTIONS if d != 'texture']}, not 'texture'")

    @property
    def shading_on(self):
        """Whether the run paints the form's light or edges into the colour (:mod:`cp_stylize.shading`)."""
        return paints_shading(self.shade_light, self.shade_edges)

    @property
    def stylised(self):
        """Whether the run paints a look over the picture (the palette, strokes, contours, oil paint, toon,
        watercolour, hatching, ink lines or the painted light) rather than only filtering it.  A look's run
        heals the texture's UV seams first (:mod:`cp_stylize.seams`): the look would trace the seam's
        colour jump as an edge of the picture.  A filter keeps the texture as it is, seams and all."""
        return (self.noise_on or self.strokes > 0 or self.contours > 0 or self.oil_size > 0
                or bool(self.toon_levels) or bool(self.wash_levels) or self.hatch_spacing > 0
                or self.line_width > 0 or self.shading_on)

    @property
    def noise_on(self):
        """Whether the run paints with the palette: random noise on some points, or tones mapped on all
        (either needs a palette, which the checks ask for)."""
        return self.noise_fraction > 0 or self.noise_mapping == "tone"

    @property
    def stroke_direction(self):
        """What the strokes follow: ``direction``, or the mode's own ("min" for Flow, else "texture").

        Always "texture" for the modes that take no direction (the checks refuse any other)."""
        if self.direction is not None:
            return self.direction
        return "min" if self.mode == "flow" else "texture"

    def __getattr__(self, name):
        """A filter parameter by name (``settings.sigma``): its value, or None if it is not set."""
        if name in FILTER_PARAMETERS:
            return self.params.get(name)
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")

    def diffusion_parameters(self):
        """Keyword arguments for :func:`cp_stylize.diffuse`, without the band and data."""
        return {"mode": self.mode, "T": self.T, **self.params}

    def scaled(self, length):
        """Absolute spacing and diffusion parameters for an object whose diameter is ``length``.

        Lengths scale with ``length / 2`` and times with its square (paper, section 4.5).
        """
        s = length / 2.0
        kw = self.diffusion_parameters()
        for key, value in kw.items():
            if key in _TIMES:
                kw[key] = value * s * s
        return self.spacing * s, kw

    def replace(self, **changes):
        """A copy with ``changes``; filter parameters by name (``sigma=...``) change ``params``."""
        params = {k: changes.pop(k) for k in list(changes) if k in FILTER_PARAMETERS}
        if params:
            changes["params"] = {**changes.get("params", self.params), **params}
        return dataclasses.replace(self, **changes)
