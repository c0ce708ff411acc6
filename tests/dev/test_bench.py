"""The benchmark's smoke run: every figure is there and the fast scheme agrees with the reference.

Speed is reported by ``python -m cp_stylize bench``, never asserted here.
"""

import json

import pytest

from cp_stylize_dev import bench


@pytest.mark.slow
def test_quick_benchmark_reports_every_figure(tmp_path):
    path = tmp_path / "bench.json"
    lines = []
    report = bench.run(quick=True, json_path=str(path), log=lines.append)
    assert json.loads(path.read_text()) == json.loads(json.dumps(report))
    assert report["cores"] >= 1 and report["quick"] is True
    assert set(report["cases"]) == {"torus", "suzanne"}  # the bpy wheel makes Suzanne in CI
    for case, figures in report["cases"].items():
        runs = {r["scheme"]: r for r in report["runs"] if r["case"] == case}
        assert set(runs) == {"fast", "reference"}
        for r in runs.values():
            assert r["points"] == figures["points"] > 10_000
            assert {"band", "bake_in", "diffusion", "bake_out", "total"} <= set(r["seconds"])
            assert all(v >= 0 for v in r["seconds"].values()) and r["peak_mb"] > 0
        assert figures["steps"] >= 10 and figures["limit_seconds"] > 0
        assert figures["psnr_fast_vs_reference"] >= 30.0, case
    text = "\n".join(lines)
    assert "limit: one band.extend" in text and "PSNR" in text
