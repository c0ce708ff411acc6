"""The user guide's parameter tables are the ones cp_stylize/parameters.py gives, and the library reference's
signatures the code's."""

import importlib
import inspect
import re

import pytest

from cp_stylize.parameters import FILTER_PARAMETERS, FILTERS, RUN
from cp_stylize_dev import docs


def test_the_user_guide_holds_the_tables_of_the_parameter_table():
    with open(docs.SETTINGS, encoding="utf-8") as f:
        text = f.read()
    assert docs.block() in text, "docs/blender.md is out of date: run `python -m cp_stylize docs`"


def test_every_parameter_has_a_row_with_its_limits_and_each_modes_default():
    rows = {line.split(" | ")[1]: line for line in docs.tables().splitlines() if line.startswith("| **")}
    assert set(rows) == {f"`{p}`" for p in (*RUN, *FILTER_PARAMETERS)}
    for p in FILTER_PARAMETERS.values():
        cells = rows[f"`{p.name}`"].strip("| ").split(" | ")
        assert cells[3] == f"{p.minimum:g} to {p.maximum:g}"
        assert cells[4:4 + len(FILTERS)] == [f"{f.defaults[p.name]:g}" if p.name in f.defaults else ""
                                             for f in FILTERS.values()]


def test_writing_replaces_only_the_block():
    text = f"before\n{docs.BEGIN}\nold table\n{docs.END}\nafter\n"
    assert docs.written(text) == f"before\n{docs.block()}\nafter\n"
    with pytest.raises(ValueError, match="markers once"):
        docs.written("no markers")


@pytest.mark.parametrize("name", ["cp_stylize.diffusion.diffuse", "cp_stylize.baking.bake_to_atlas",
                                  "cp_stylize.pipeline.stylize"])
def test_the_library_reference_gives_the_signatures_of_the_main_functions_as_they_are(name):
    module, function = name.rsplit(".", 1)
    signature = str(inspect.signature(getattr(importlib.import_module(module), function))).replace("'", '"')
    with open(docs.API, encoding="utf-8") as f:
        text = re.sub(r"\s+", " ", f.read())          # the reference wraps a signature over its lines
    assert f"{function}{signature}" in text, f"docs/api.md gives an older signature of {name}: {function}{signature}"
