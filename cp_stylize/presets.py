"""Presets: a run's settings (:class:`~cp_stylize.settings.StylizeSettings`) in TOML files.

Lengths and times are relative to the object's size: the object is normalised
so that its diameter is 2 (as in the paper: a sphere of radius 1), so a preset
looks the same on a 2 cm object and on a 20 m one.

A preset is a TOML file (see ``presets/`` at the top of the repository and of
the extension)::

    name = "Starry Night"
    description = "..."
    mode = "ced"          # one of cp_stylize.MODES
    T = 1.1e-4            # stop time (object 2 units across)
    spacing = 0.008       # grid spacing (object 2 units across)
    detail = 1.0          # optional: the texture's own detail, finer than the grid, laid back (0 to 1)
    direction = "min"     # optional, CED and Flow: what the strokes follow (cp_stylize.parameters.DIRECTIONS)
    axis = [0, 0, 1]      # directions "axis" and "around": the axis, in the object's space
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

    [oil]                 # optional: oil paint, the anisotropic Kuwahara filter (cp_stylize.kuwahara)
    size = 0.03           # the neighbourhood's radius (object 2 units across); 0: none
    sharpness = 0.5
    eccentricity = 1.0

    [toon]                # optional: toon shading, the lightness in flat bands (cp_stylize.toon)
    levels = 4            # 0: none
    softness = 0.3

    [watercolour]         # optional: watercolour washes on paper (cp_stylize.watercolour)
    washes = 4            # 0: none
    edges = 0.5           # pigment pooled at the washes' borders
    granulation = 0.5
    bleed = 0.3           # the share of borders that ran wet
    wobble = 0.5

    [lines]               # optional: ink lines at the texels (cp_stylize.lines)
    width = 0.006         # the lines' width (object 2 units across); 0: none
    detail = 0.5          # 0: the strongest edges alone; 1: most of them

    [hatching]            # optional: ink hatching, lines of ink on paper (cp_stylize.hatching)
    spacing = 0.016       # the lines' spacing (object 2 units across); 0: none
    layers = 3            # layers of lines in the darkest tones
    angle = 90            # degrees between the first layer and the second
    ink = 0.5             # how much of the tones take ink

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

import os
import tempfile
import tomllib

from .parameters import FILTER_PARAMETERS, RUN
from .settings import StylizeSettings, check_colour, check_fields, check_parameter, is_number

__all__ = ["StylizeSettings", "load_preset", "save_preset", "builtin_presets", "PRESET_DIR", "parse_hex",
           "preset_paths", "find_preset", "preset_key", "preset_label", "save_user_preset", "remove_user_preset"]

#: The longest name a saved preset may have, in characters.
NAME_LENGTH = 64

#: The presets shipped with cp_stylize.
PRESET_DIR = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "presets")


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
    "oil": _run_keys("oil"),
    "toon": _run_keys("toon"),
    "watercolour": _run_keys("watercolour"),
    "lines": _run_keys("lines"),
    "hatching": _run_keys("hatching"),
    "shading": _run_keys("shading"),
    "output": {"size": "image_size", "margin": "margin"},
}

_PALETTE_ENTRY = '"#rrggbb", [r, g, b] or ["#rrggbb", weight] (r, g, b in [0, 1], a weight of at least 0)'


def _palette_colour(value):
    if isinstance(value, str):
        return parse_hex(value)
    return check_colour("colour", value)


def _palette_entry(entry):
    """``(colour, weight)`` of one palette entry of a preset file; ValueError if it is none."""
    if isinstance(entry, list) and len(entry) == 2 and not is_number(entry[0]):
        colour, weight = entry
        if not is_number(weight) or weight < 0:
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
        return {}, [f"params must be a table ([params] with {', '.join(tuple(FILTER_PARAMETERS))}), got {given!r}"]
    problems = []
    unknown = sorted(k for k in given if k not in FILTER_PARAMETERS)
    if unknown:
        problems.append(f"unknown parameter(s) {unknown} in [params]; known: {list(tuple(FILTER_PARAMETERS))}")
    params = {}
    for name in given.keys() & FILTER_PARAMETERS.keys():
        try:
            params[name] = check_parameter(name, f"[params] {name}", given[name])
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
    values, bad = check_fields(values, labels)
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
    lines.append("]")
    for table in _FILE:                                 # the tables of the run's numbers alone
        if table not in (None, "noise", "output"):
            lines += ["", f"[{table}]", *run(table)]
    lines += ["", "[output]", f"size = {int(settings.image_size)}", f"margin = {int(settings.margin)}", ""]
    return "\n".join(lines)


def save_preset(settings, path):
    """Write ``settings`` as a preset TOML file that :func:`load_preset` reads back as they were.

    A failed write leaves the file that was at ``path`` as it was.
    """
    _write_atomically(os.fspath(path), preset_text(settings))
    return path
