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


def _resolve(dotted: str):
    """The object a dotted ``roughflow....`` name stands for (the longest importable module
    prefix, then attributes)."""
    import importlib

    parts = dotted.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except ModuleNotFoundError:
            continue
        for attr in parts[i:]:
            obj = getattr(obj, attr)
        return obj
    raise ModuleNotFoundError(dotted)


def test_dotted_names_in_the_docs_exist():
    # every `roughflow.x.y` a user reads in the README or docs/ can be imported or looked up
    pages = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
    names = {m[1] for page in pages
             for m in re.finditer(r"`(roughflow(?:\.[A-Za-z_]\w*)+)", page.read_text())}
    assert len(names) > 20  # the pattern still finds the docs' names
    missing = []
    for name in sorted(names):
        try:
            _resolve(name)
        except (ImportError, AttributeError):
            missing.append(name)
    assert not missing


def test_paper_sizes_as_the_readme_states():
    # the README's job count and core-hours of config/paper.yaml come from the planner and
    # the cost model (a count of 377 outlived the studies added after it)
    import yaml

    from roughflow.scenes import expand_studies
    from roughflow.scenes.requests import estimated_seconds

    studies = yaml.safe_load((ROOT / "config" / "paper.yaml").read_text())["studies"]
    jobs = [job for job in expand_studies(studies).values() if job.kind != "leak"]
    assert int(re.search(r"\((\d+) simulation jobs\)", README)[1]) == len(jobs)
    hours = sum(map(estimated_seconds, jobs)) / 3600
    # the README quotes the estimate rounded to whole core-hours
    assert abs(hours - float(re.search(r"estimates about (\d+) core-hours", README)[1])) <= 0.5
