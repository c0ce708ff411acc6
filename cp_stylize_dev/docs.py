"""The user guide's parameter tables, written from :mod:`cp_stylize.parameters`.

``python -m cp_stylize docs`` rewrites the block between the two markers in
docs/blender.md (:data:`SETTINGS`); a test checks that the guide holds what
this module writes, and that docs/api.md (:data:`API`) gives the main
functions' signatures as they are.
"""

from __future__ import annotations

import os
import re

from cp_stylize.parameters import FILTER_PARAMETERS, FILTERS, RUN

BEGIN = "<!-- parameters: written by `python -m cp_stylize docs` from cp_stylize/parameters.py -->"
END = "<!-- end of parameters -->"
_DOCS = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "docs")
#: The Blender user guide, which holds the parameter tables, and the library's reference.
SETTINGS = os.path.join(_DOCS, "blender.md")
API = os.path.join(_DOCS, "api.md")

UNITS = {"time": "time (length²)", "length": "length", "ratio": "ratio", "count": "count"}


def _number(value):
    return f"{value:g}"


def _row(cells):
    return "| " + " | ".join(cells) + " |"


def tables():
    """The two Markdown tables: the run's parameters, then the filters' with each mode's default."""
    lines = [_row(["setting", "key", "unit", "limits", "default", "what it does"]), _row(["---"] * 6)]
    for p in RUN.values():
        lines.append(_row([f"**{p.label}**", f"`{p.name}`", UNITS[p.unit],
                           f"{_number(p.minimum)} to {_number(p.maximum)}", _number(p.default), p.description]))
    lines.append("")
    head = ["setting", "key", "unit", "limits"] + [f.label for f in FILTERS.values()] + ["what it does"]
    lines += [_row(head), _row(["---"] * len(head))]
    for p in FILTER_PARAMETERS.values():
        defaults = [_number(f.defaults[p.name]) if p.name in f.defaults else "" for f in FILTERS.values()]
        lines.append(_row([f"**{p.label}**", f"`{p.name}`", UNITS[p.unit],
                           f"{_number(p.minimum)} to {_number(p.maximum)}"] + defaults + [p.description]))
    return "\n".join(lines)


def block():
    """The guide's generated block, markers included."""
    return f"{BEGIN}\n\n{tables()}\n\n{END}"


def written(text):
    """``text`` (the guide) with its generated block replaced by :func:`block`."""
    pattern = re.compile(re.escape(BEGIN) + ".*?" + re.escape(END), re.S)
    if len(pattern.findall(text)) != 1:
        raise ValueError(f"{os.path.basename(SETTINGS)} must hold the parameter block's two markers once")
    return pattern.sub(lambda _: block(), text)


def run(path=SETTINGS, log=print):
    with open(path, encoding="utf-8") as f:
        text = f.read()
    new = written(text)
    if new == text:
        log(f"{path}: the parameter tables are up to date")
        return False
    with open(path, "w", encoding="utf-8") as f:
        f.write(new)
    log(f"{path}: parameter tables written")
    return True
