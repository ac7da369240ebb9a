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
from roughflow.files import STALE_TEMPORARY_S

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
had = wisdom.entries(pyfftw.export_wisdom())
p = fft.plan({SHAPE})
a = np.random.default_rng(1).random({SHAPE})
print("exact", bool(np.allclose(p.inverse(p.forward(a).copy()), a, atol=1e-12)))
print("timed" if wisdom.entries(pyfftw.export_wisdom()) != had else "read")
"""


def measure_file(d):
    """The FFTW_MEASURE wisdom file of this machine in directory ``d``."""
    return d / wisdom.path("FFTW_MEASURE").name


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
    assert name == measure_file(tmp_path).name
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
    assert wisdom.path("FFTW_MEASURE").parent == tmp_path / "roughflow" / "fftw"


def test_an_unreadable_file_is_reported_once_and_replaced(tmp_path):
    name = measure_file(tmp_path).name
    (tmp_path / name).write_text("(not json")
    out = run_plan({wisdom.ENV: str(tmp_path), "ROUGHFLOW_FFTW_EFFORT": "FFTW_MEASURE"})
    assert "exact True" in out
    assert out.count("is not a wisdom file and will be replaced") == 1
    assert set(json.loads((tmp_path / name).read_text())) == {"double", "single", "long_double"}


def test_a_file_with_a_non_ascii_byte_is_replaced_too(tmp_path):
    # json.loads never saw it: the ascii read raised UnicodeDecodeError, and every later
    # FFT command of the machine stopped on it (exit 1) until the file was deleted by hand
    name = measure_file(tmp_path).name
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
    file = measure_file(tmp_path)
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


def test_a_lock_held_too_long_costs_a_warning_not_the_run(tmp_path):
    """A holder that never lets go (stopped with SIGSTOP, a suspended job: in a directory
    a group shares, perhaps another user's, which this one cannot end) held every later
    process for good. After LOCK_WAIT_S a process reads the file and plans without it."""
    env = {wisdom.ENV: str(tmp_path), "ROUGHFLOW_FFTW_EFFORT": "FFTW_MEASURE"}
    file = measure_file(tmp_path)
    code = "from roughflow import wisdom\nwisdom.LOCK_WAIT_S = 1.0\n" + PLAN
    with wisdom._locked(file) as usable:
        assert usable
        proc = subprocess.Popen([sys.executable, "-c", code], env={**os.environ, **env},
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        try:
            out, err = proc.communicate(timeout=120)
        finally:
            proc.kill()
    assert proc.returncode == 0, err[-2000:]
    assert "exact True" in out and "timed" in out
    assert out.count("FFTW wisdom:") == 1 and f"another process holds {file}.lock" in out
    assert not file.exists()  # nothing saved without the lock


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


# --- efforts, sharing between users, damaged files ------------------------------------------

EFFORTS = """
import sys
import pyfftw
from roughflow import fft, wisdom
import os
plans = []
for effort in sys.argv[1:]:
    os.environ["ROUGHFLOW_FFTW_EFFORT"] = effort
    plans.append(fft.plan((36, 30)))
print(" ".join(p.effort for p in plans), len({id(p) for p in plans}))
"""


def test_each_planner_effort_plans_and_keeps_its_own_wisdom(tmp_path):
    """A change of ``ROUGHFLOW_FFTW_EFFORT`` in a process gets a plan of the new effort (the
    cache used to return the first effort's plan while files recorded the new one), and
    FFTW plans at each effort from that effort's wisdom only: it takes wisdom of a higher
    effort in place of planning, so one FFTW_PATIENT run used to decide the algorithms of
    every later FFTW_MEASURE run. Entries record their planner flags, so no entry of the
    PATIENT file may turn up in the MEASURE file, and ESTIMATE saves nothing."""
    env = {**os.environ, wisdom.ENV: str(tmp_path)}
    out = subprocess.run([sys.executable, "-c", EFFORTS, "FFTW_ESTIMATE", "FFTW_PATIENT",
                          "FFTW_MEASURE"], env=env, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.split() == ["FFTW_ESTIMATE", "FFTW_PATIENT", "FFTW_MEASURE", "3"]
    key = wisdom.machine_key()
    assert file_in(tmp_path) == [f"wisdom-{key}-measure.json", f"wisdom-{key}-patient.json"]

    def planned(effort):
        data = json.loads((tmp_path / f"wisdom-{key}-{effort}.json").read_text())
        return {ln for w in data.values() for ln in w.splitlines()[1:-1]}

    assert planned("measure") and planned("patient")
    assert not planned("measure") & planned("patient")


def test_files_can_be_shared_by_a_group(tmp_path):
    """The wisdom file was 0600 (``mkstemp``), so another user of a shared directory could
    not read it, timed every shape again and replaced the file with its own 0600 copy."""
    env = {wisdom.ENV: str(tmp_path), "ROUGHFLOW_FFTW_EFFORT": "FFTW_MEASURE"}
    old = os.umask(0o002)
    try:
        assert "timed" in run_plan(env)
    finally:
        os.umask(old)
    file = measure_file(tmp_path)
    assert file.stat().st_mode & 0o777 == 0o664
    assert (tmp_path / (file.name + ".lock")).stat().st_mode & 0o777 == 0o664


def test_a_file_with_a_field_out_of_range_is_replaced_not_fatal(tmp_path):
    """An entry whose flag field does not fit FFTW's 20 bits made FFTW abort the process on
    an assertion (exit 134) in every later run on the machine. Such a file is refused before
    FFTW reads it, reported and replaced like any unreadable file."""
    env = {wisdom.ENV: str(tmp_path), "ROUGHFLOW_FFTW_EFFORT": "FFTW_MEASURE"}
    run_plan(env)
    file = measure_file(tmp_path)
    data = json.loads(file.read_text())
    lines = data["double"].splitlines()
    fields = lines[1].split()
    fields[3] = "#x7ffffff"  # the upper flags, 27 bits
    lines[1] = " ".join(["", *fields]).replace(" ", "  ", 1)
    data["double"] = "\n".join(lines) + "\n"
    assert not wisdom._valid(data["double"])
    file.write_text(json.dumps(data))
    fresh = tmp_path / "fresh"
    fresh.mkdir()
    file.rename(measure_file(fresh))
    out = run_plan({**env, wisdom.ENV: str(fresh)})
    assert "exact True" in out and "has a field out of range" in out
    assert all(wisdom._valid(w) for w in json.loads(measure_file(fresh).read_text()).values())


def test_without_a_home_directory_the_wisdom_stays_in_the_process(monkeypatch, caplog):
    """HOME unset and a user id unknown to the password database (containers): ``~`` stays
    ``~``, and the file went to a directory named ``~`` inside the working directory."""
    monkeypatch.delenv(wisdom.ENV, raising=False)
    monkeypatch.delenv("XDG_CACHE_HOME", raising=False)
    monkeypatch.setattr(wisdom.os.path, "expanduser", lambda p: p)
    monkeypatch.setattr(wisdom, "_reported", set())
    with caplog.at_level("WARNING", logger="roughflow.wisdom"):
        assert wisdom.directory() is None
    assert "no home directory" in caplog.text
    monkeypatch.setenv(wisdom.ENV, "~/fftw")
    with pytest.raises(InputError, match="'~/fftw'.*without ~"):
        wisdom.directory()


def test_an_unknown_user_in_the_directory_is_an_input_error(monkeypatch):
    monkeypatch.setenv(wisdom.ENV, "~no_such_user_of_roughflow/fftw")
    with pytest.raises(InputError, match="no_such_user_of_roughflow"):
        wisdom.directory()


def test_what_others_saved_meanwhile_is_merged_not_overwritten(tmp_path, monkeypatch):
    """On a file system without working locks two processes can plan at once; the one that
    saves last used to overwrite the other's shapes. A save merges the file first."""
    a, b = tmp_path / "a", tmp_path / "b"
    a.mkdir()
    b.mkdir()
    run_plan({wisdom.ENV: str(a), "ROUGHFLOW_FFTW_EFFORT": "FFTW_MEASURE"})  # SHAPE, in a
    other = json.loads(measure_file(a).read_text())
    script = f"""
import json, os
from pathlib import Path
from roughflow import fft, wisdom
file = wisdom.path("FFTW_MEASURE")
with wisdom.shared("FFTW_MEASURE"):
    pass
real = wisdom.shared
def racing(effort):
    ctx = real(effort)
    class Race:
        def __enter__(self):
            ctx.__enter__()
            # another process (no lock) saves its shape while this one plans
            file.write_text({json.dumps(json.dumps(other))})
        def __exit__(self, *exc):
            return ctx.__exit__(*exc)
    return Race()
fft.wisdom.shared = racing
fft.plan((30, 28))
print(len(json.loads(file.read_text())["double"].splitlines()))
"""
    env = {**os.environ, wisdom.ENV: str(b), "ROUGHFLOW_FFTW_EFFORT": "FFTW_MEASURE"}
    out = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True,
                         text=True, timeout=120)
    assert out.returncode == 0, out.stderr[-2000:]
    merged = json.loads(measure_file(b).read_text())
    for p in ("double",):
        theirs = set(other[p].splitlines())
        mine = set(merged[p].splitlines())
        assert theirs <= mine and len(mine) > len(theirs)


def test_timings_a_failed_save_lost_reach_the_file_later(tmp_path):
    """A save that failed (an interrupt, a full disk) lost the shape's timing for good: the
    process held it, so planning the shape again found nothing new to save, and other
    processes timed the shape again and rounded differently. A plan now saves what the
    process holds and the file lacks."""
    script = """
import json
from roughflow import fft, wisdom
real = wisdom._save
def failing(file, w):
    raise OSError(28, "No space left on device")
wisdom._save = failing
fft.plan((30, 26))
wisdom._save = real
assert not wisdom.path("FFTW_MEASURE").exists()
fft.plan.cache_clear()
fft.plan((30, 26))  # planned again, from the process's wisdom: nothing new to time
print(len(json.loads(wisdom.path("FFTW_MEASURE").read_text())["double"].splitlines()))
"""
    env = {**os.environ, wisdom.ENV: str(tmp_path), "ROUGHFLOW_FFTW_EFFORT": "FFTW_MEASURE"}
    out = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True,
                         text=True, timeout=120)
    assert out.returncode == 0, out.stderr[-2000:]
    # a fresh process that plans (30, 26) reads its timing instead of timing it again
    check = """
import pyfftw
from roughflow import fft, wisdom
with wisdom.shared("FFTW_MEASURE"):
    pass
had = wisdom.entries(pyfftw.export_wisdom())
fft.plan((30, 26))
print("timed" if wisdom.entries(pyfftw.export_wisdom()) != had else "read")
"""
    out = subprocess.run([sys.executable, "-c", check], env=env, capture_output=True,
                         text=True, timeout=120)
    assert out.returncode == 0 and out.stdout.strip() == "read", out.stdout + out.stderr


def test_a_precision_the_build_lacks_is_valid_empty_wisdom():
    """pyFFTW exports b"" for a precision its build lacks (long double on some builds); such
    a file was refused as damaged and rewritten by every process, its timings never read."""
    assert wisdom._valid("")
    assert not wisdom._valid("(garbage")


def test_a_time_limit_out_of_range_is_refused_and_the_file_replaced(tmp_path):
    """An entry's time limit is a 9-bit field in FFTW: #x1ff is its largest value, #x200
    (512) is out of range and would make FFTW abort while planning. The file is refused
    before FFTW reads it and replaced; the largest valid value is still accepted."""
    env = {wisdom.ENV: str(tmp_path), "ROUGHFLOW_FFTW_EFFORT": "FFTW_MEASURE"}
    run_plan(env)
    file = measure_file(tmp_path)
    data = json.loads(file.read_text())
    lines = data["double"].splitlines()

    def with_time_limit(value):
        fields = lines[1].split()
        fields[4] = value  # name, rank, two flag fields, the time limit, four hashes
        edited = " ".join(["", *fields]).replace(" ", "  ", 1)
        return "\n".join([lines[0], edited, *lines[2:]]) + "\n"

    assert wisdom._valid(with_time_limit("#x1ff"))
    data["double"] = with_time_limit("#x200")
    assert not wisdom._valid(data["double"])
    fresh = tmp_path / "fresh"
    fresh.mkdir()
    measure_file(fresh).write_text(json.dumps(data))
    out = run_plan({**env, wisdom.ENV: str(fresh)})
    assert "exact True" in out and "has a field out of range" in out
    assert all(wisdom._valid(w) for w in json.loads(measure_file(fresh).read_text()).values())


def test_the_machine_key_changes_with_the_cpu(monkeypatch):
    """Wisdom timed on one CPU is not another's: the file name's key hashes the CPU's
    description (a node of another CPU model sharing the home directory read it)."""
    wisdom.machine_key.cache_clear()
    try:
        monkeypatch.setattr(wisdom, "_cpu_description", lambda: "model name=CPU A")
        a = wisdom.machine_key()
        wisdom.machine_key.cache_clear()
        monkeypatch.setattr(wisdom, "_cpu_description", lambda: "model name=CPU B")
        b = wisdom.machine_key()
        wisdom.machine_key.cache_clear()
        assert wisdom.machine_key() == b  # the key is a function of the description
    finally:
        wisdom.machine_key.cache_clear()
    assert a != b


def test_a_killed_jobs_temporary_file_is_removed_by_a_later_save(tmp_path):
    # a job killed while writing (SIGKILL, out of memory) left its temporary file for good,
    # one per killed job
    file = measure_file(tmp_path)
    stale = tmp_path / f"{file.name}abc123.tmp"
    fresh = tmp_path / f"{file.name}def456.tmp"  # another job's, being written now
    for tmp in (stale, fresh):
        tmp.write_text("{")
    old = time.time() - STALE_TEMPORARY_S - 60
    os.utime(stale, (old, old))
    wisdom._save(file, (b"", b"", b""))
    assert not stale.exists() and fresh.exists()
    assert set(json.loads(file.read_text())) == {"double", "single", "long_double"}


def test_a_sticky_shared_folder_is_named_when_the_save_is_refused(tmp_path, monkeypatch,
                                                                  caplog):
    """A group's wisdom folder with the sticky bit (like /tmp): only a file's owner may
    replace it, so a second user's save failed with 'Operation not permitted' and no hint
    of why. The warning now names the owner and the setgid folder that works. The other
    user is a user id that owns neither the file nor the folder (as root, the rename itself
    would pass: it is refused as the kernel refuses it to that user)."""
    import errno

    folder = tmp_path / "fftw"
    folder.mkdir()
    folder.chmod(0o1777)
    monkeypatch.setenv(wisdom.ENV, str(folder))
    monkeypatch.setenv("ROUGHFLOW_FFTW_EFFORT", "FFTW_MEASURE")
    fft.RealFFT2((26, 22), 1)  # the first user's save: the file is theirs
    assert wisdom.path("FFTW_MEASURE").exists()
    monkeypatch.setattr(os, "geteuid", lambda: 4242)

    def refused(*_):
        raise PermissionError(errno.EPERM, "Operation not permitted")

    monkeypatch.setattr(wisdom, "_save", refused)
    with caplog.at_level("WARNING", logger="roughflow.wisdom"):
        fft.RealFFT2((34, 38), 1)  # a shape the file lacks: a save
    assert "Operation not permitted" in caplog.text
    assert "sticky bit" in caplog.text and "setgid folder" in caplog.text
