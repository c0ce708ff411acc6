"""Stylization settings and presets (TOML files).

All settings of a run travel as one frozen :class:`StylizeSettings`.  Lengths
and times are relative to the object's size: the object is normalised so that
its longest side is 2 (as in the paper), so a preset looks the same on a 2 cm
object and on a 20 m one.

A preset is a TOML file (see ``presets/`` at the top of the repository and of
the extension)::

    name = "Starry Night"
    description = "..."
    mode = "ced"          # one of cp_stylize.MODES
    T = 1.1e-4            # stop time (object 2 units long)
    spacing = 0.008       # grid spacing (object 2 units long)
    detail = 1.0          # optional: the texture's own detail, finer than the grid, laid back (0 to 1)
    direction = "min"     # optional, CED and Flow: what the strokes follow (cp_stylize.parameters.DIRECTIONS)
    axis = [0, 0, 1]      # direction "axis": the axis, in the object's space
    attribute = "flow"    # direction "attribute": the mesh's vector attribute (the add-on reads it)

    [params]              # sigma, rho, alpha, b_rel, lambda_rel (see diffuse)
    sigma = 1e-4

    [strokes]             # optional: brush strokes in the palette's colours (cp_stylize.strokes)
    strength = 1.0
    length = 0.1          # object 2 units long
    width = 0.01

    [noise]               # optional: replace a fraction of band points by palette colours
    fraction = 0.67
    mapping = "tone"      # optional: "random" (the paper's) or "tone" (cp_stylize.parameters.NOISE_MAPPINGS)
    spread = 0.1          # mapping "tone": the jitter of the tones
    seed = 1889
    palette = [["#0b1a3a", 6], ["#f3d54e", 1]]   # sRGB hex colour and relative weight
"""

from __future__ import annotations

import dataclasses
import math
import os
import tomllib
from collections.abc import Mapping

from .parameters import DIRECTED_MODES, DIRECTIONS, FILTER_PARAMETERS, MODES, NOISE_MAPPINGS, RUN, check_value

__all__ = ["StylizeSettings", "load_preset", "save_preset", "builtin_presets", "PRESET_DIR", "parse_hex"]

#: The presets shipped with cp_stylize.
PRESET_DIR = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "presets")

_PARAMS = tuple(FILTER_PARAMETERS)

#: The parameters that are times: they scale with the square of the object's size.
_TIMES = {p.name for p in (*RUN.values(), *FILTER_PARAMETERS.values()) if p.unit == "time"}

#: Output image sizes a run may ask for, in texels a side.
IMAGE_SIZES = (16, 8192)


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


@dataclasses.dataclass(frozen=True)
class StylizeSettings:
    """Everything a stylization run needs, relative to an object whose longest side is 2."""

    mode: str = "ced"
    T: float = 1e-4
    spacing: float = 0.01
    params: Mapping = dataclasses.field(default_factory=dict)   # filter parameters set; the mode's defaults fill in
    noise_fraction: float = 0.0
    noise_mapping: str = "random"   # see NOISE_MAPPINGS
    noise_spread: float = 0.1
    detail: float = 1.0             # the texture's own detail laid back (cp_stylize.baking.lay_detail)
    strokes: float = 0.0            # brush strokes over the result (cp_stylize.strokes)
    stroke_length: float = 0.1
    stroke_width: float = 0.03
    stroke_layers: int = 3
    stroke_jitter: float = 0.3
    swirl: float = 0.0
    fidelity: float = 0.0           # mapping "tone": how much of the picture's own colours (cp_stylize.palette)
    contours: float = 0.0           # lines along the strong edges (cp_stylize.contours)
    relief: float = 0.0             # the strokes' height, as a second image
    palette: tuple = ()             # sRGB colours as (r, g, b) in [0, 1]
    palette_weights: tuple = ()
    seed: int = 0
    direction: str | None = None    # CED and Flow: see DIRECTIONS; None: the mode's own (stroke_direction)
    axis: tuple = (0.0, 0.0, 1.0)   # direction "axis", in the object's space
    attribute: str = ""             # direction "attribute": the mesh's vector attribute, for the add-on
    image_size: int = 1024
    margin: int = 16
    name: str = ""
    description: str = ""

    def __post_init__(self):
        """Check every value against its limits in :mod:`cp_stylize.parameters` (the panel's limits)."""
        if self.mode not in MODES:
            raise ValueError(f"mode must be one of {MODES}, got {self.mode!r}")
        for parameter in RUN.values():
            object.__setattr__(self, parameter.name, parameter.check(getattr(self, parameter.name)))
        unknown = set(self.params) - set(FILTER_PARAMETERS)
        if unknown:
            raise ValueError(f"unknown filter parameter(s) {sorted(unknown)}; known: {list(FILTER_PARAMETERS)}")
        params = {name: FILTER_PARAMETERS[name].check(value) for name, value in self.params.items()
                  if value is not None}
        object.__setattr__(self, "params", _Params(params))
        if self.noise_mapping not in NOISE_MAPPINGS:
            raise ValueError(f"noise mapping must be one of {list(NOISE_MAPPINGS)}, got {self.noise_mapping!r}")
        if (self.noise_fraction > 0 or self.noise_mapping == "tone") and not self.palette:
            raise ValueError("noise needs a palette of at least one colour")
        if self.palette_weights and len(self.palette_weights) != len(self.palette):
            raise ValueError(f"palette has {len(self.palette)} colours but {len(self.palette_weights)} weights")
        check_value("image size", self.image_size, *IMAGE_SIZES)
        self._check_direction()

    def _check_direction(self):
        if self.direction is not None and self.direction not in DIRECTIONS:
            raise ValueError(f"direction must be one of {list(DIRECTIONS)}, got {self.direction!r}")
        if self.direction not in (None, "texture") and self.mode not in DIRECTED_MODES and not self.strokes:
            raise ValueError(f"direction {self.direction!r} is for the modes {list(DIRECTED_MODES)} and for "
                             f"brush strokes, not {self.mode!r} without strokes")
        if self.mode == "flow" and self.direction == "texture":
            raise ValueError("mode 'flow' draws along a direction field: direction must be one of "
                             f"{[d for d in DIRECTIONS if d != 'texture']}, not 'texture'")
        try:
            axis = tuple(float(a) for a in self.axis)
        except (TypeError, ValueError):
            axis = ()
        if len(axis) != 3 or not all(math.isfinite(a) for a in axis) or not any(axis):
            raise ValueError(f"axis must be three finite numbers, not all zero, got {self.axis!r}")
        object.__setattr__(self, "axis", axis)
        if not isinstance(self.attribute, str):
            raise ValueError(f"attribute must be an attribute's name, got {self.attribute!r}")

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
        """Absolute spacing and diffusion parameters for an object whose longest side is ``length``.

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


def parse_hex(colour):
    """``"#rrggbb"`` to an (r, g, b) tuple of floats in [0, 1] (sRGB-encoded)."""
    text = colour.strip().lstrip("#")
    if len(text) != 6 or any(c not in "0123456789abcdefABCDEF" for c in text):
        raise ValueError(f"colour must be '#rrggbb', got {colour!r}")
    return tuple(int(text[i:i + 2], 16) / 255.0 for i in (0, 2, 4))


def _hex(rgb):
    return "#" + "".join(f"{round(min(max(c, 0.0), 1.0) * 255):02x}" for c in rgb)


#: The keys of a preset's [strokes] table, and the settings they set.
_STROKE_KEYS = {"strength": "strokes", "length": "stroke_length", "width": "stroke_width", "layers": "stroke_layers",
                "jitter": "stroke_jitter", "swirl": "swirl", "relief": "relief"}


def settings_from_dict(data, *, source="preset"):
    """:class:`StylizeSettings` from a parsed preset table."""
    known = {"name", "description", "mode", "T", "spacing", "detail", "direction", "axis", "attribute", "params", "noise",
             "strokes", "output", "contours"}
    unknown = set(data) - known
    if unknown:
        raise ValueError(f"{source}: unknown key(s) {sorted(unknown)}")
    params = dict(data.get("params", {}))
    bad = set(params) - set(_PARAMS)
    if bad:
        raise ValueError(f"{source}: unknown parameter(s) {sorted(bad)}; known: {list(_PARAMS)}")
    noise = dict(data.get("noise", {}))
    palette, weights = [], []
    for entry in noise.get("palette", []):
        colour, weight = (entry, 1.0) if isinstance(entry, str) else entry
        palette.append(parse_hex(colour))
        weights.append(float(weight))
    output = dict(data.get("output", {}))
    strokes = dict(data.get("strokes", {}))
    unknown = set(strokes) - set(_STROKE_KEYS)
    if unknown:
        raise ValueError(f"{source}: unknown key(s) {sorted(unknown)} in [strokes]; known: {', '.join(_STROKE_KEYS)}")
    try:
        return StylizeSettings(
            mode=data.get("mode", "ced"), T=data.get("T", 1e-4), spacing=data.get("spacing", 0.01),
            detail=data.get("detail", 1.0), strokes=strokes.get("strength", 0.0),
            stroke_length=strokes.get("length", 0.1), stroke_width=strokes.get("width", 0.03),
            stroke_layers=strokes.get("layers", 3), stroke_jitter=strokes.get("jitter", 0.3),
            swirl=strokes.get("swirl", 0.0), relief=strokes.get("relief", 0.0),
            fidelity=noise.get("fidelity", 0.0), contours=data.get("contours", 0.0),
            noise_fraction=float(noise.get("fraction", 0.0)), palette=tuple(palette),
            noise_mapping=noise.get("mapping", "random"), noise_spread=noise.get("spread", 0.1),
            palette_weights=tuple(weights), seed=int(noise.get("seed", 0)),
            image_size=int(output.get("size", 1024)), margin=int(output.get("margin", 16)),
            direction=data.get("direction"), axis=tuple(data.get("axis", (0.0, 0.0, 1.0))),
            attribute=data.get("attribute", ""),
            name=data.get("name", ""), description=data.get("description", ""), params=params)
    except ValueError as err:
        raise ValueError(f"{source}: {err}") from None


def load_preset(name_or_path):
    """Settings of a preset: a shipped preset's name (e.g. ``"starry_night"``) or a TOML file's path."""
    path = name_or_path
    if not os.path.isfile(path):
        path = os.path.join(PRESET_DIR, f"{name_or_path}.toml")
        if not os.path.isfile(path):
            raise ValueError(f"no preset {name_or_path!r}; shipped presets: {sorted(builtin_presets())}")
    with open(path, "rb") as f:
        try:
            data = tomllib.load(f)
        except tomllib.TOMLDecodeError as err:
            raise ValueError(f"{path}: not valid TOML: {err}") from None
    return settings_from_dict(data, source=path)


def builtin_presets():
    """Shipped presets: ``{name: path}`` sorted by name."""
    if not os.path.isdir(PRESET_DIR):
        return {}
    return {f[:-5]: os.path.join(PRESET_DIR, f) for f in sorted(os.listdir(PRESET_DIR)) if f.endswith(".toml")}


def _toml_value(v):
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    return repr(float(v)) if isinstance(v, float) else str(v)


def save_preset(settings, path):
    """Write ``settings`` as a preset TOML file that :func:`load_preset` reads back."""
    lines = [f"name = {_toml_value(settings.name)}", f"description = {_toml_value(settings.description)}",
             f"mode = {_toml_value(settings.mode)}", f"T = {_toml_value(float(settings.T))}",
             f"spacing = {_toml_value(float(settings.spacing))}", f"detail = {_toml_value(float(settings.detail))}"]
    if settings.contours > 0:
        lines.append(f"contours = {_toml_value(float(settings.contours))}")
    if settings.direction is not None:
        lines.append(f"direction = {_toml_value(settings.direction)}")
    if settings.axis != (0.0, 0.0, 1.0):
        lines.append(f"axis = [{', '.join(_toml_value(a) for a in settings.axis)}]")
    if settings.attribute:
        lines.append(f"attribute = {_toml_value(settings.attribute)}")
    lines += ["", "[params]"]
    lines += [f"{k} = {_toml_value(float(v))}" for k, v in settings.params.items()]
    if settings.noise_on:
        lines += ["", "[noise]", f"fraction = {_toml_value(float(settings.noise_fraction))}",
                  f"mapping = {_toml_value(settings.noise_mapping)}",
                  f"spread = {_toml_value(float(settings.noise_spread))}",
                  f"fidelity = {_toml_value(float(settings.fidelity))}",
                  f"seed = {int(settings.seed)}", "palette = ["]
        weights = settings.palette_weights or (1.0,) * len(settings.palette)
        lines += [f'  ["{_hex(c)}", {_toml_value(float(w))}],' for c, w in zip(settings.palette, weights)]
        lines += ["]"]
    if settings.strokes > 0:
        lines += ["", "[strokes]"] + [f"{key} = {_toml_value(getattr(settings, name))}"
                                      for key, name in _STROKE_KEYS.items()]
    lines += ["", "[output]", f"size = {int(settings.image_size)}", f"margin = {int(settings.margin)}", ""]
    with open(path, "w", encoding="utf-8") as f:
        f.write("\n".join(lines))
    return path
