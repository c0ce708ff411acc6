"""Stylization settings and presets (TOML files).

All settings of a run travel as one frozen :class:`StylizeSettings`.  Lengths
and times are relative to the object's size: the object is normalised so that
its diameter is 2 (as in the paper: a sphere of radius 1), so a preset looks the same on a 2 cm
object and on a 20 m one.

A preset is a TOML file (see ``presets/`` at the top of the repository and of
the extension)::

    name = "Starry Night"
    description = "..."
    mode = "ced"          # one of cp_stylize.MODES
    T = 1.1e-4            # stop time (object 2 units across)
    spacing = 0.008       # grid spacing (object 2 units across)
    detail = 1.0          # optional: the texture's own detail, finer than the grid, laid back (0 to 1)
    direction = "min"     # optional, CED and Flow: what the strokes follow (cp_stylize.parameters.DIRECTIONS)
    axis = [0, 0, 1]      # direction "axis": the axis, in the object's space
    attribute = "flow"    # direction "attribute": the mesh's vector attribute (the add-on reads it)

    [params]              # sigma, rho, alpha, b_rel, lambda_rel (see diffuse)
    sigma = 1e-4

    [strokes]             # optional: brush strokes in the palette's colours (cp_stylize.strokes)
    strength = 1.0
    length = 0.1          # object 2 units across
    width = 0.01

    [noise]               # optional: replace a fraction of band points by palette colours
    fraction = 0.67
    mapping = "tone"      # optional: "random" (the paper's) or "tone" (cp_stylize.parameters.NOISE_MAPPINGS)
    spread = 0.1          # mapping "tone": the jitter of the tones
    seed = 1889
    palette = [["#0b1a3a", 6], ["#f3d54e", 1]]   # sRGB colour ("#rrggbb" or [r, g, b] in [0, 1]) and weight

    [output]              # optional
    size = 1024           # the image's texels a side
    margin = 16           # texels around the islands that repeat their border colours

Every field is checked before anything uses the preset, and a preset with a
bad field is refused as a whole, with one message that names the file and
each bad field.  :func:`save_preset` writes every field, so a saved preset
loads back as it was.

Where presets are found (:func:`find_preset`): a preset is named by its key,
the name of its file without ``.toml`` (``"starry_night"``), or by a file's
path.  The shipped presets come first, so a key always means the same file;
a user's preset is saved under a key of its own (:func:`save_user_preset`)
and never over another preset.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
import os
import tempfile
import tomllib
from collections.abc import Mapping

from .parameters import (DIRECTED_MODES, DIRECTIONS, FILTER_PARAMETERS, MODES, NOISE_MAPPINGS, RUN, SEED_LIMITS,
                         check_value)

__all__ = ["StylizeSettings", "load_preset", "save_preset", "builtin_presets", "PRESET_DIR", "parse_hex",
           "preset_paths", "find_preset", "preset_key", "preset_label", "save_user_preset", "remove_user_preset"]

#: The presets shipped with cp_stylize.
PRESET_DIR = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "presets")

_PARAMS = tuple(FILTER_PARAMETERS)

#: The parameters that are times: they scale with the square of the object's size.
_TIMES = {p.name for p in (*RUN.values(), *FILTER_PARAMETERS.values()) if p.unit == "time"}

#: Output image sizes a run may ask for, in texels a side.
IMAGE_SIZES = (16, 8192)
#: Margins a run may ask for, in texels.
MARGINS = (0, 256)
#: The longest name a saved preset may have, in characters.
NAME_LENGTH = 64


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


def _real(value):
    return not isinstance(value, bool) and isinstance(value, numbers.Real) and math.isfinite(value)


def _axis(label, value):
    try:
        axis = tuple(float(a) for a in value) if not isinstance(value, str) else ()
    except (TypeError, ValueError):
        axis = ()
    if len(axis) != 3 or not all(_real(a) for a in value) or not any(axis):
        raise ValueError(f"{label} must be three finite numbers, not all zero, got {value!r}")
    return axis


def _colours(label, value):
    colours = tuple(tuple(c) if isinstance(c, (tuple, list)) else c for c in value) \
        if isinstance(value, (tuple, list)) else None
    if colours is None or not all(isinstance(c, tuple) and len(c) == 3 and all(_real(x) and 0 <= x <= 1 for x in c)
                                  for c in colours):
        raise ValueError(f"{label} must be colours of three numbers in [0, 1], got {value!r}")
    return tuple(tuple(float(x) for x in c) for c in colours)


def _weights(label, value):
    if not isinstance(value, (tuple, list)) or not all(_real(w) and w >= 0 for w in value):
        raise ValueError(f"{label} must be numbers of at least 0, one a colour, got {value!r}")
    return tuple(float(w) for w in value)


def _params(label, value):
    if not isinstance(value, Mapping):
        raise ValueError(f"{label} must be a table of filter parameters ({', '.join(_PARAMS)}), got {value!r}")
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


def _checked(values, labels):
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
    stroke_jitter: float = RUN["stroke_jitter"].default
    swirl: float = RUN["swirl"].default
    fidelity: float = RUN["fidelity"].default      # mapping "tone": how much of the picture's own colours
    keep_values: float = RUN["keep_values"].default   # mapping "tone": how much of the picture's own lightness
    contours: float = RUN["contours"].default      # lines along the strong edges (cp_stylize.contours)
    relief: float = RUN["relief"].default          # the strokes' height, as a second image
    palette: tuple = ()             # sRGB colours as (r, g, b) in [0, 1]
    palette_weights: tuple = ()     # one a colour, at least 0 (none given: all 1)
    seed: int = 0                   # a whole number in SEED_LIMITS
    direction: str | None = None    # CED and Flow: see DIRECTIONS; None: the mode's own (stroke_direction)
    axis: tuple = (0.0, 0.0, 1.0)   # direction "axis", in the object's space
    attribute: str = ""             # direction "attribute": the mesh's vector attribute, for the add-on
    image_size: int = 1024
    margin: int = 16
    name: str = ""
    description: str = ""

    def __post_init__(self):
        """Check every field (the limits are the panel's, :mod:`cp_stylize.parameters`), then how they fit."""
        values, problems = _checked({f.name: getattr(self, f.name) for f in dataclasses.fields(self)}, {})
        if problems:
            raise ValueError("; ".join(problems))
        if values["palette"] and not values["palette_weights"]:
            values["palette_weights"] = (1.0,) * len(values["palette"])      # all alike
        for field, value in values.items():
            object.__setattr__(self, field, value)
        self._check_palette()
        self._check_direction()

    def _check_palette(self):
        if self.noise_on and not self.palette:
            raise ValueError("noise needs a palette of at least one colour")
        if self.palette_weights and len(self.palette_weights) != len(self.palette):
            raise ValueError(f"palette has {len(self.palette)} colours but {len(self.palette_weights)} weights")
        if (self.noise_on or self.strokes > 0) and self.palette_weights and not any(self.palette_weights):
            raise ValueError("the palette's weights are all 0, so no colour could be drawn: give at least one "
                             "colour a weight above 0")

    def _check_direction(self):
        if self.direction not in (None, "texture") and self.mode not in DIRECTED_MODES and not self.strokes:
            raise ValueError(f"direction {self.direction!r} is for the modes {list(DIRECTED_MODES)} and for "
                             f"brush strokes, not {self.mode!r} without strokes")
        if self.mode == "flow" and self.direction == "texture":
            raise ValueError("mode 'flow' draws along a direction field: direction must be one of "
                             f"{[d for d in DIRECTIONS if d != 'texture']}, not 'texture'")

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


def parse_hex(colour):
    """``"#rrggbb"`` to an (r, g, b) tuple of floats in [0, 1] (sRGB-encoded)."""
    text = colour.strip().removeprefix("#") if isinstance(colour, str) else ""
    if len(text) != 6 or any(c not in "0123456789abcdefABCDEF" for c in text):
        raise ValueError(f"colour must be '#rrggbb', got {colour!r}")
    return tuple(int(text[i:i + 2], 16) / 255.0 for i in (0, 2, 4))


def _hex(rgb):
    return "#" + "".join(f"{round(min(max(c, 0.0), 1.0) * 255):02x}" for c in rgb)


# -- preset files ------------------------------------------------------------------------------------

def _run_keys(table):
    """The run parameters kept in a preset file's ``table`` (None: the top level): ``{key: setting}``, from
    the parameter table (:attr:`cp_stylize.parameters.Parameter.file`)."""
    return {p.file[1]: p.name for p in RUN.values() if p.file[0] == table}


#: The preset file's fields: ``{table: {key: setting}}``, None for the top level (``[params]`` holds the
#: filter parameters by name); the run's numbers take their keys from the parameter table.
_FILE = {
    None: {"name": "name", "description": "description", "mode": "mode", **_run_keys(None),
           "direction": "direction", "axis": "axis", "attribute": "attribute"},
    "noise": {"mapping": "noise_mapping", "seed": "seed", **_run_keys("noise"), "palette": "palette"},
    "strokes": _run_keys("strokes"),
    "output": {"size": "image_size", "margin": "margin"},
}

_PALETTE_ENTRY = '"#rrggbb", [r, g, b] or ["#rrggbb", weight] (r, g, b in [0, 1], a weight of at least 0)'


def _palette_colour(value):
    if isinstance(value, str):
        return parse_hex(value)
    return _colours("colour", [value])[0]


def _palette_entry(entry):
    """``(colour, weight)`` of one palette entry of a preset file; ValueError if it is none."""
    if isinstance(entry, list) and len(entry) == 2 and not _real(entry[0]):
        colour, weight = entry
        if not _real(weight) or weight < 0:
            raise ValueError(weight)
        return _palette_colour(colour), float(weight)
    return _palette_colour(entry), 1.0


def _palette(label, entries):
    """``(colours, weights, problems)`` of a preset file's palette."""
    if not isinstance(entries, list):
        return (), (), [f"{label} must be a list of colours, each {_PALETTE_ENTRY}, got {entries!r}"]
    colours, weights, problems = [], [], []
    for number, entry in enumerate(entries, 1):
        try:
            colour, weight = _palette_entry(entry)
        except (ValueError, TypeError):
            problems.append(f"{label} entry {number} must be {_PALETTE_ENTRY}, got {entry!r}")
            continue
        colours.append(colour)
        weights.append(weight)
    return tuple(colours), tuple(weights), problems


def _fields(data):
    """``(values, labels, problems)``: the settings a preset table gives, each setting's name in the file,
    and what is wrong with its layout (unknown keys, a table that is not one)."""
    values, labels, problems = {}, {}, []
    unknown = sorted(k for k in data if k not in _FILE[None] and k not in _FILE and k != "params")
    if unknown:
        problems.append(f"unknown key(s) {unknown}; known: {[*_FILE[None], 'params', *filter(None, _FILE)]}")
    for table, fields in _FILE.items():
        given = data if table is None else data.get(table, {})
        if not isinstance(given, dict):
            problems.append(f"{table} must be a table ([{table}] with {', '.join(fields)}), got {given!r}")
            continue
        if table is not None:
            unknown = sorted(k for k in given if k not in fields)
            if unknown:
                problems.append(f"unknown key(s) {unknown} in [{table}]; known: {', '.join(fields)}")
        for key, field in fields.items():
            if key in given:
                values[field] = given[key]
                labels[field] = key if table is None else f"[{table}] {key}"
    return values, labels, problems


def _file_params(data):
    """``(params, problems)`` of a preset table's ``[params]``, each checked against its limits."""
    given = data.get("params", {})
    if not isinstance(given, dict):
        return {}, [f"params must be a table ([params] with {', '.join(_PARAMS)}), got {given!r}"]
    problems = []
    unknown = sorted(k for k in given if k not in FILTER_PARAMETERS)
    if unknown:
        problems.append(f"unknown parameter(s) {unknown} in [params]; known: {list(_PARAMS)}")
    params = {}
    for name in given.keys() & FILTER_PARAMETERS.keys():
        try:
            params[name] = _parameter(FILTER_PARAMETERS[name])(f"[params] {name}", given[name])
        except ValueError as err:
            problems.append(str(err))
    return params, problems


def settings_from_dict(data, *, source="preset"):
    """:class:`StylizeSettings` from a parsed preset table, checked as a whole.

    Raises one ValueError that starts with ``source`` (the file) and names
    every bad field as the file spells it (``[noise] seed``), what it must be
    and what it is.
    """
    if not data:
        raise ValueError(f"{source}: the preset is empty: it holds no settings")
    values, labels, problems = _fields(data)
    if "palette" in values:
        values["palette"], values["palette_weights"], bad = _palette(labels["palette"], values["palette"])
        problems += bad
    params, bad = _file_params(data)
    problems += bad
    values, bad = _checked(values, labels)
    problems += bad
    if problems:
        raise ValueError(f"{source}: " + "; ".join(problems))
    try:
        return StylizeSettings(**values, params=params)
    except ValueError as err:
        raise ValueError(f"{source}: {err}") from None


def load_preset(name_or_path, folders=()):
    """Settings of a preset: its key (``"starry_night"``, see :func:`find_preset`) or a TOML file's path.

    ``folders``: the user's preset folders, looked in after the shipped presets.
    Raises ValueError naming the file for a preset that cannot be read or
    holds a bad field.
    """
    path = find_preset(name_or_path, folders)
    try:
        with open(path, "rb") as f:
            data = tomllib.load(f)
    except tomllib.TOMLDecodeError as err:
        raise ValueError(f"{path}: not valid TOML: {err}") from None
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not valid TOML: a preset is a text file in UTF-8") from None
    except OSError as err:
        raise ValueError(f"{path}: the preset could not be read ({err.strerror or err})") from None
    return settings_from_dict(data, source=path)


def builtin_presets():
    """Shipped presets: ``{key: path}`` sorted by key."""
    if not os.path.isdir(PRESET_DIR):
        return {}
    return {f[:-5]: os.path.join(PRESET_DIR, f) for f in sorted(os.listdir(PRESET_DIR)) if f.endswith(".toml")}


def _folder_presets(folder):
    """``{key: path}`` of the preset files in ``folder`` (none if it cannot be read)."""
    try:
        names = sorted(os.listdir(folder)) if folder and os.path.isdir(folder) else []
    except OSError:
        names = []
    return {f[:-5]: os.path.join(folder, f) for f in names
            if f.endswith(".toml") and os.path.isfile(os.path.join(folder, f))}


def preset_paths(folders=()):
    """Every preset: ``{key: path}``, the shipped ones first, then those in the user's ``folders``.

    Keys are unique and always mean the same file: a user's file whose key a
    shipped preset (or an earlier folder) already has is listed under its
    path, which :func:`find_preset` takes as well.
    """
    found = dict(builtin_presets())
    for folder in folders:
        for key, path in _folder_presets(folder).items():
            found[key if key not in found else path] = path
    return found


def find_preset(name, folders=()):
    """The file of preset ``name``: a preset file's path, or a key of :func:`preset_paths`."""
    if isinstance(name, (str, os.PathLike)) and os.path.isfile(name):
        return os.fspath(name)
    paths = preset_paths(folders)
    if isinstance(name, str) and name in paths:
        return paths[name]
    raise ValueError(f"no preset {name!r}; presets: {sorted(k for k in paths if not os.path.isabs(k))}")


_labels = {}


def preset_label(path):
    """What a menu shows for the preset file ``path``: its ``name``, else its key made readable."""
    try:
        stamp = os.stat(path).st_mtime_ns
    except OSError:
        stamp = None
    if _labels.get(path, (None,))[0] != stamp or stamp is None:
        try:
            with open(path, "rb") as f:
                name = tomllib.load(f).get("name")
        except (OSError, ValueError):
            name = None
        if not isinstance(name, str) or not name.strip():
            name = os.path.basename(path)[:-5].replace("_", " ").strip().title()
        _labels[path] = (stamp, name)
    return _labels[path][1]


def preset_menu(folders=()):
    """``[(key, label)]`` of every preset (:func:`preset_paths`), the shipped ones first; a label that an
    earlier entry has is followed by the file's name, so that no two entries look alike."""
    entries, seen = [], set()
    for key, path in preset_paths(folders).items():
        label = preset_label(path)
        if label.casefold() in seen:
            label = f"{label} ({os.path.basename(path)})"
        seen.add(label.casefold())
        entries.append((key, label))
    return entries


#: File names that Windows reserves, whatever their extension.
_RESERVED = {"con", "prn", "aux", "nul", *(f"com{i}" for i in range(1, 10)), *(f"lpt{i}" for i in range(1, 10))}
#: The longest key, in bytes of UTF-8 (file names hold 255).
_KEY_BYTES = 120


def preset_key(name):
    """The key a preset named ``name`` is saved under (its file name without ``.toml``): its letters and
    digits in lower case, ``_`` between them for every other character, at most 120 bytes of UTF-8; ``""``
    for a name without a letter or a digit."""
    key = "".join(c if c.isalnum() else "_" for c in name.strip().casefold()).strip("_")
    key = key.encode("utf-8")[:_KEY_BYTES].decode("utf-8", "ignore")
    return key + "_" if key in _RESERVED else key


def _write_atomically(path, text):
    """Write ``text`` to ``path`` so that a failed write leaves whatever was there as it was."""
    handle, temporary = tempfile.mkstemp(dir=os.path.dirname(path), prefix=".saving_", suffix=".tmp")
    try:
        with os.fdopen(handle, "w", encoding="utf-8") as f:
            f.write(text)
        os.replace(temporary, path)
    except BaseException:
        if os.path.exists(temporary):
            os.remove(temporary)
        raise


def save_user_preset(settings, folder, name):
    """Save ``settings`` as the user's preset ``name`` in ``folder``; returns ``(key, path, replaced)``.

    Saving never overwrites another preset: the user's preset of the same
    name is replaced (``replaced`` is True), a name whose key another file
    has takes the first free key (``wood_grain_2``), and the name of a
    shipped preset is refused, so that one name never shows two presets.
    Raises ValueError with the reason (no name, too long, taken, the folder
    cannot be written).
    """
    if not isinstance(name, str) or not name.strip():
        raise ValueError("a preset needs a name")
    name = name.strip()
    if len(name) > NAME_LENGTH:
        raise ValueError(f"a preset's name may be {NAME_LENGTH} characters long, and this one has {len(name)}: "
                         "choose a shorter name")
    key = preset_key(name)
    if not key:
        raise ValueError(f"a preset's name needs a letter or a digit, got {name!r}")
    shipped = builtin_presets()
    if any(preset_label(path).casefold() == name.casefold() for path in shipped.values()):
        raise ValueError(f"{name!r} is the name of a shipped preset: choose another name")
    own = _folder_presets(folder)
    same = next((k for k, path in own.items() if preset_label(path) == name), None)
    if same is None:
        number, base = 1, key
        while key in own or key in shipped:
            number += 1
            key = f"{base}_{number}"
    else:
        key = same
    path = os.path.join(folder, key + ".toml")
    try:
        os.makedirs(folder, exist_ok=True)
        _write_atomically(path, preset_text(settings.replace(name=name)))
    except OSError as err:
        raise ValueError(f"could not save the preset {name!r} as {path!r}: {err.strerror or err}") from None
    return key, path, same is not None


def remove_user_preset(name, folder):
    """Remove the user's preset ``name`` (a key of :func:`preset_paths`, or its path) from ``folder``."""
    if isinstance(name, str) and name in builtin_presets():
        raise ValueError(f"{name!r} is a shipped preset, not a user preset: it cannot be removed")
    path = preset_paths([folder]).get(name) if isinstance(name, str) else None
    if path is None and isinstance(name, str) and os.path.isabs(name) and os.path.isfile(name):
        path = name
    if path is None or os.path.dirname(os.path.abspath(path)) != os.path.abspath(folder):
        raise ValueError(f"{name!r} is not a user preset")
    try:
        os.remove(path)
    except OSError as err:
        raise ValueError(f"could not remove the preset file {path!r}: {err.strerror or err}") from None
    return path


def _toml_value(v):
    if isinstance(v, str):
        escaped = v.replace("\\", "\\\\").replace('"', '\\"')
        escaped = "".join(c if c.isprintable() else f"\\U{ord(c):08x}" for c in escaped)
        return f'"{escaped}"'
    return repr(float(v)) if isinstance(v, float) else str(v)


def _colour_value(rgb):
    """A palette colour as the file writes it: ``"#rrggbb"`` where that is exact, else ``[r, g, b]``."""
    text = _hex(rgb)
    if all(abs(a - b) < 1e-6 for a, b in zip(parse_hex(text), rgb)):
        return f'"{text}"'
    return "[" + ", ".join(_toml_value(float(c)) for c in rgb) + "]"


def preset_text(settings):
    """The TOML text of a preset file holding every field of ``settings``."""
    def run(table):               # the run's numbers kept in ``table``, as the parameter table places them
        return [f"{key} = {_toml_value(getattr(settings, name))}" for key, name in _run_keys(table).items()]

    lines = [f"name = {_toml_value(settings.name)}", f"description = {_toml_value(settings.description)}",
             f"mode = {_toml_value(settings.mode)}", *run(None)]
    if settings.direction is not None:
        lines.append(f"direction = {_toml_value(settings.direction)}")
    lines.append(f"axis = [{', '.join(_toml_value(float(a)) for a in settings.axis)}]")
    lines.append(f"attribute = {_toml_value(settings.attribute)}")
    lines += ["", "[params]"]
    lines += [f"{k} = {_toml_value(float(v))}" for k, v in settings.params.items()]
    lines += ["", "[noise]", f"mapping = {_toml_value(settings.noise_mapping)}", f"seed = {int(settings.seed)}",
              *run("noise"), "palette = ["]
    weights = settings.palette_weights or (1.0,) * len(settings.palette)
    lines += [f"  [{_colour_value(c)}, {_toml_value(float(w))}]," for c, w in zip(settings.palette, weights)]
    lines += ["]", "", "[strokes]", *run("strokes")]
    lines += ["", "[output]", f"size = {int(settings.image_size)}", f"margin = {int(settings.margin)}", ""]
    return "\n".join(lines)


def save_preset(settings, path):
    """Write ``settings`` as a preset TOML file that :func:`load_preset` reads back as they were.

    A failed write leaves the file that was at ``path`` as it was.
    """
    _write_atomically(os.fspath(path), preset_text(settings))
    return path
