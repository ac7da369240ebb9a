"""FFTW wisdom on disk (roughflow.wisdom): a shape is timed once per machine, later processes
read its algorithm, and the file can only ever cost speed, never a result or a run.

Each case plans in a fresh Python process, because plans (roughflow.fft.plan) and FFTW's
in-memory wisdom live as long as the process."""

import json
import os
import subprocess
import sys
import time

import pytest

from roughflow import fft, provenance, wisdom
from roughflow.cli import main
from roughflow.errors import InputError

SHAPE = (48, 40)  # no other test plans it, so it starts with no wisdom

#: Plans SHAPE through roughflow.fft, then asks FFTW for a plan of it from wisdom alone
#: (FFTW_WISDOM_ONLY fails unless this process holds the algorithm timed for it): prints
#: whether the roughflow plan transforms correctly and "timed" or "read".
PLAN = f"""
import logging, sys
import numpy as np, pyfftw
logging.basicConfig(level=logging.WARNING, stream=sys.stdout, format="%(message)s")
from roughflow import fft, wisdom
with wisdom.shared(fft.effort()):
    pass  # the file's wisdom, as the plan below reads it
had = pyfftw.export_wisdom()
p = fft.plan({SHAPE})
a = np.random.default_rng(1).random({SHAPE})
print("exact", bool(np.allclose(p.inverse(p.forward(a).copy()), a, atol=1e-12)))
print("timed" if pyfftw.export_wisdom() != had else "read")
"""


def run_plan(env_extra: dict, timeout: float = 120) -> str:
    env = {**os.environ, **env_extra}
    out = subprocess.run([sys.executable, "-c", PLAN], env=env, capture_output=True,
                         text=True, timeout=timeout)
    assert out.returncode == 0, out.stderr[-2000:]
    return out.stdout


def file_in(d) -> list:
    return sorted(p.name for p in d.iterdir() if p.suffix == ".json")


def test_a_shape_is_timed_once_then_read_from_the_file(tmp_path):
    env = {wisdom.ENV: str(tmp_path), "ROUGHFLOW_FFTW_EFFORT": "FFTW_MEASURE"}
    first = run_plan(env)
    assert "exact True" in first and "timed" in first
    (name,) = file_in(tmp_path)
    assert name == f"wisdom-{wisdom.machine_key()}.json"
    saved = json.loads((tmp_path / name).read_text())
    assert set(saved) == {"double", "single", "long_double"}
    mtime = (tmp_path / name).stat().st_mtime_ns
    second = run_plan(env)
    # the second process found the algorithm in the file: nothing timed, nothing rewritten
    assert "exact True" in second and "read" in second
    assert (tmp_path / name).stat().st_mtime_ns == mtime


def test_estimate_plans_neither_read_nor_write_wisdom(tmp_path):
    out = run_plan({wisdom.ENV: str(tmp_path), "ROUGHFLOW_FFTW_EFFORT": "FFTW_ESTIMATE"})
    assert "exact True" in out
    assert list(tmp_path.iterdir()) == []


def test_off_keeps_wisdom_in_the_process(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    out = run_plan({wisdom.ENV: "off", "HOME": str(tmp_path), "XDG_CACHE_HOME": str(tmp_path)})
    assert "exact True" in out and "timed" in out
    assert list(tmp_path.iterdir()) == []


def test_default_directory_is_the_user_cache(tmp_path, monkeypatch):
    monkeypatch.delenv(wisdom.ENV, raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert wisdom.directory() == tmp_path / "roughflow" / "fftw"
    assert wisdom.path().parent == tmp_path / "roughflow" / "fftw"


def test_an_unreadable_file_is_reported_once_and_replaced(tmp_path):
    name = f"wisdom-{wisdom.machine_key()}.json"
    (tmp_path / name).write_text("(not json")
    out = run_plan({wisdom.ENV: str(tmp_path), "ROUGHFLOW_FFTW_EFFORT": "FFTW_MEASURE"})
    assert "exact True" in out
    assert out.count("is not a wisdom file and will be replaced") == 1
    assert set(json.loads((tmp_path / name).read_text())) == {"double", "single", "long_double"}


def test_a_file_with_a_non_ascii_byte_is_replaced_too(tmp_path):
    # json.loads never saw it: the ascii read raised UnicodeDecodeError, and every later
    # FFT command of the machine stopped on it (exit 1) until the file was deleted by hand
    name = f"wisdom-{wisdom.machine_key()}.json"
    (tmp_path / name).write_bytes(b'{"double": "\xff"}')
    out = run_plan({wisdom.ENV: str(tmp_path), "ROUGHFLOW_FFTW_EFFORT": "FFTW_MEASURE"})
    assert "exact True" in out
    assert out.count("is not a wisdom file and will be replaced") == 1
    assert set(json.loads((tmp_path / name).read_text())) == {"double", "single", "long_double"}


def test_a_directory_that_cannot_be_made_costs_a_warning_not_the_run(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("")
    out = run_plan({wisdom.ENV: str(blocker / "fftw"), "ROUGHFLOW_FFTW_EFFORT": "FFTW_MEASURE"})
    assert "exact True" in out
    assert out.count("FFTW wisdom: cannot write to") == 1
    assert out.count("FFTW wisdom:") == 1  # one warning for one problem


def test_a_second_process_waits_for_the_first_to_finish_timing(tmp_path):
    """The lock: while one process holds the file (as it does while it times a shape), another
    cannot plan, so it reads what the first saved instead of timing the shape itself and the
    two compute with the same algorithms. (What is read is checked by the test above.)"""
    env = {wisdom.ENV: str(tmp_path), "ROUGHFLOW_FFTW_EFFORT": "FFTW_MEASURE"}
    file = tmp_path / f"wisdom-{wisdom.machine_key()}.json"
    with wisdom._locked(file) as usable:
        assert usable
        proc = subprocess.Popen([sys.executable, "-c", PLAN], env={**os.environ, **env},
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        # a fresh process imports roughflow in about a second; it must still be waiting after
        # that, however slow the machine, because the lock cannot be had
        time.sleep(3)
        assert proc.poll() is None
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 0, err[-2000:]
    assert "exact True" in out


@pytest.mark.parametrize("raw", ["", "  "])
def test_an_empty_directory_name_is_refused(raw, monkeypatch):
    monkeypatch.setenv(wisdom.ENV, raw)
    with pytest.raises(InputError, match=wisdom.ENV):
        wisdom.directory()


def test_an_unknown_planner_effort_is_refused(monkeypatch):
    monkeypatch.setenv("ROUGHFLOW_FFTW_EFFORT", "FFTW_FAST")
    with pytest.raises(InputError, match="FFTW_FAST"):
        fft.effort()


def test_datasets_record_the_planner_effort(monkeypatch):
    monkeypatch.setenv("ROUGHFLOW_FFTW_EFFORT", "FFTW_ESTIMATE")
    assert provenance.Provenance().attrs()["fftw_effort"] == "FFTW_ESTIMATE"
    monkeypatch.delenv("ROUGHFLOW_FFTW_EFFORT")
    assert provenance.Provenance().attrs()["fftw_effort"] == fft.DEFAULT_EFFORT


@pytest.mark.parametrize(("var", "value"), [("ROUGHFLOW_FFTW_EFFORT", "FFTW_FAST"),
                                            (wisdom.ENV, ""), ("ROUGHFLOW_FFT_THREADS", "0")])
def test_the_command_line_refuses_bad_fft_settings_before_any_work(var, value, tmp_path,
                                                                   monkeypatch, capsys):
    monkeypatch.setenv(var, value)

    def work(*a, **kw):  # the first FFT would refuse the setting too, but only mid-work
        raise AssertionError("the command started work")

    monkeypatch.setattr("roughflow.surface.generate", work)
    out = tmp_path / "s.nc"
    with pytest.raises(SystemExit) as exc:
        main(["surface", "--l-over-lambda-r", "4", "--eps-f", "0.25",
              "--points-per-lambda-s", "2", "-o", str(out)])
    assert exc.value.code == 2
    assert var in capsys.readouterr().err
    assert not out.exists()
