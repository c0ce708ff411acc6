"""The estimate's time factor: measured once, kept, read back on the same computer only."""

import json

import pytest

from cp_stylize import calibration


class _Made(list):
    times: list


@pytest.fixture
def fresh(monkeypatch):
    """No factor kept in memory, and the measurements made (each returns the next of ``times``, then 2.5)."""
    monkeypatch.setattr(calibration, "_speed", {})
    made, times = _Made(), []
    monkeypatch.setattr(calibration, "measure", lambda: made.append(1) or (times.pop(0) if times else 2.5)
                        * calibration.REFERENCE_SECONDS)
    made.times = times
    return made


def test_the_factor_is_measured_once_a_session_and_the_least_is_kept_in_its_file(fresh, tmp_path):
    path = tmp_path / "user" / "calibration.json"
    assert calibration.machine_speed(path) == 2.5 and len(fresh) == 1
    assert calibration.machine_speed(path) == 2.5 and len(fresh) == 1            # once a session
    kept = json.loads(path.read_text())
    assert kept["seconds"] == 2.5 * calibration.REFERENCE_SECONDS and kept["machine"] == calibration._machine()
    # a later session, slowed by other work, keeps the file's faster measure
    calibration._speed.clear()
    fresh.times.append(4.0)
    assert calibration.machine_speed(path) == 2.5 and len(fresh) == 2
    assert json.loads(path.read_text())["seconds"] == 2.5 * calibration.REFERENCE_SECONDS
    # a quieter one lowers it for good
    calibration._speed.clear()
    fresh.times.append(1.5)
    assert calibration.machine_speed(path) == 1.5 and len(fresh) == 3
    assert json.loads(path.read_text())["seconds"] == 1.5 * calibration.REFERENCE_SECONDS
    calibration._speed.clear()
    assert calibration.machine_speed(path) == 1.5 and len(fresh) == 4
    assert calibration.machine_speed() == 2.5 and len(fresh) == 4      # in memory only: this session's measure


@pytest.mark.parametrize("text", ["not json", '{"seconds": -1}', '[1, 2]',
                                  '{"seconds": 0.5, "machine": {"node": "elsewhere"}}'])
def test_a_file_that_cannot_be_used_is_measured_again(fresh, tmp_path, text):
    path = tmp_path / "calibration.json"
    path.write_text(text)
    assert calibration.machine_speed(path) == 2.5 and len(fresh) == 1
    assert json.loads(path.read_text())["seconds"] == 2.5 * calibration.REFERENCE_SECONDS


def test_a_folder_that_cannot_be_written_keeps_the_factor_in_memory(fresh, tmp_path):
    blocked = tmp_path / "file"
    blocked.write_text("")
    assert calibration.machine_speed(blocked / "calibration.json") == 2.5   # its folder is a file
    assert not (blocked / "calibration.json").exists()


def test_the_factor_stays_within_its_limits(monkeypatch):
    monkeypatch.setattr(calibration, "_speed", {})
    monkeypatch.setattr(calibration, "measure", lambda: 1000.0)
    assert calibration.machine_speed() == calibration.SPEED_LIMITS[1]


def test_the_job_is_measured_in_processor_time():
    seconds = calibration.measure(repeat=1)
    assert 0 < seconds < 10


def test_the_estimate_scales_its_time_by_the_factor():
    from cp_stylize.estimate import estimate_run
    from cp_stylize.presets import StylizeSettings

    settings = StylizeSettings(mode="eed", T=1e-4, spacing=0.01)
    slow, nbytes = estimate_run(100_000, settings, triangles=10_000, speed=1.7)
    plain, same = estimate_run(100_000, settings, triangles=10_000)
    assert slow == pytest.approx(1.7 * plain) and nbytes == same
