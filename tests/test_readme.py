"""The README stays true: its Python example runs and its set-up commands are what CI runs."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()


def test_python_example_runs():
    blocks = re.findall(r"```python\n(.*?)```", README, flags=re.S)
    assert blocks, "README has no Python example"
    for code in blocks:
        exec(compile(code, "README.md", "exec"), {})


def test_first_two_commands_are_main_job_and_tests():
    commands = re.findall(r"```\n(.*?)\n```", README, flags=re.S)
    main, tests = commands[0], commands[1]
    assert "snakemake --cores all" in main and "pip install" in main
    assert "pytest" in tests and "pip install" in tests
    ci = (ROOT / ".ci" / "run").read_text()
    assert "test-command" in ci  # .ci/run executes the README's test command verbatim


def _requirements(dist: str, extras: frozenset = frozenset()) -> set[str]:
    """Names of the distributions ``dist`` (with ``extras``) needs, transitively."""
    import importlib.metadata as md

    from packaging.requirements import Requirement

    seen: set[str] = set()
    todo = [(dist, extras)]
    while todo:
        name, ex = todo.pop()
        try:
            reqs = md.distribution(name).requires or []
        except md.PackageNotFoundError:
            continue
        for line in reqs:
            req = Requirement(line)
            env = [{"extra": e} for e in ex] or [{"extra": ""}]
            if req.marker is not None and not any(req.marker.evaluate(e) for e in env):
                continue
            key = req.name.lower().replace("_", "-")
            if key not in seen:
                seen.add(key)
                todo.append((key, frozenset(req.extras)))
    return seen


def test_documented_install_can_write_the_report():
    # issue 13 item 16: `snakemake --report` (README) needs pygments, which the plain
    # `pip install -e .` did not bring (only pytest pulled it in for the tests)
    assert "snakemake --report" in README
    assert "pygments" in _requirements("roughflow")
