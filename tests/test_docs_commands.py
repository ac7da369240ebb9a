"""The command lines the docs quote still parse, and the docs' Python examples still run.

Commands covered (README.md and docs/*.md): every line of a fenced code block (any language
but ``python``; ``\\`` continuations joined, ``#`` comments dropped) and every inline `code`
span (it may wrap lines) that starts, after optional environment assignments
(``ROUGHFLOW_FFT_THREADS=1``), with ``roughflow``, ``python -m roughflow``, ``python
benchmarks/NAME.py`` or ``[benchmarks/]NAME.py ARGS`` (a script of benchmarks/; its name
alone names the file). Each is parsed, nothing runs: by ``roughflow.cli.build_parser()`` or
by the script's ``build_parser()``, abbreviated options refused (the docs spell options out).
A fenced line is a whole command line: its required arguments must be there. An inline span
may name a command ("`roughflow import` reads ...") or end with an option it names
("`stress_flow.py --summarize`"): required arguments, subcommands and that option's value
may be missing, but every subcommand and option it gives must exist and take its values.

Placeholders: ``...`` and a remark in parentheses (``(gfmd)``) are dropped; a word in
capitals (``N``, ``TOL``, ``RESULT.nc``), a word with ``<...>`` in it (``<study>``,
``_<effort>``) and ``$(...)`` stand for a value: accepted wherever a value goes (no type or
choice check), not as an option; as the subcommand (``roughflow COMMAND --help``) one stands
for each subcommand. ``a|b`` in a word and ``[x | y]`` are alternatives, each checked;
``[...]`` (optional) is checked as given. ``NAME="..."`` lines of a block set variables its
later ``$NAME`` lines use.

Deliberately not covered: other programs' command lines (snakemake, pip, sbatch), commands
behind a shell operator (``|``, ``;``, ``&&``, ``>``: a line is read up to its first one),
indented code blocks, spans of options alone (``--crop defined``), and whether a command
would succeed (files, ranges, names a script reads as plain strings).

The ``python`` blocks of docs/*.md run (README.md's: tests/test_readme.py), each in an empty
folder; the one reading ``leak.nc`` gets a file from the test data's scan, the one reading
the Wyko scan ``opd-1.opd`` (not in the repository) is skipped.
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import importlib.util
import io
import itertools
import re
import shlex
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from roughflow.cli import _subparsers, build_parser
from roughflow.cli import main as cli_main

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]

_FENCE = re.compile(r"^\s*(`{3,}|~{3,})\s*([\w+-]*)")
_ASSIGNMENT = re.compile(r"[A-Za-z_]\w*=")
_START = re.compile(r"\s*(?:[A-Za-z_]\w*=\S*\s+)*(?:(?:python3? -m )?roughflow(?=\s|$)|"
                    r"(?P<python>python3? )?(?P<dir>benchmarks/)?(?P<script>\w+)\.py(?=\s|$))")
_OPERATORS = {"|", "||", "&&", ";", "&"}
_PLACEHOLDER = re.compile(r"[A-Z][A-Z0-9_]*(\.\w+)?|.*<[^>]*>.*")
_REMARK = re.compile(r"\(.*\)")
VALUE = "\0placeholder"  # what a placeholder becomes in argv


def _split(page: Path):
    """A page's fenced blocks, [(language, [(line number, line), ...]), ...], and its prose
    lines (fenced lines blanked out, so that line numbers hold)."""
    blocks: list[tuple[str, list[tuple[int, str]]]] = []
    prose: list[str] = []
    fence = None
    for n, line in enumerate(page.read_text().splitlines(), 1):
        bare = line.strip()
        if fence is None and (m := _FENCE.match(line)):
            fence = m.group(1)
            blocks.append((m.group(2), []))
        elif fence is not None and bare and set(bare) == {fence[0]} and len(bare) >= len(fence):
            fence = None
        elif fence is not None:
            blocks[-1][1].append((n, line))
        else:
            prose.append(line)
            continue
        prose.append("")
    return blocks, prose


def _is_command(text: str) -> bool:
    """Whether ``text`` starts a command line of roughflow's or of a benchmark script's (a
    script's name alone, without ``python`` or arguments, names the file)."""
    m = _START.match(text)
    if m is None or not m.group("script"):
        return m is not None
    known = m.group("dir") or (ROOT / "benchmarks" / f"{m.group('script')}.py").exists()
    return bool(known and (m.group("python") or text[m.end():].split("#")[0].strip()))


def _assignments(line: str) -> dict[str, str]:
    """The variables a shell line of assignments only (``A="roughflow ..."``) sets."""
    with contextlib.suppress(ValueError):
        words = shlex.split(line.strip().removeprefix("export "), comments=True)
        if words and all(_ASSIGNMENT.match(w) for w in words):
            return dict(w.split("=", 1) for w in words)
    return {}


def _block_commands(block: list[tuple[int, str]]):
    """(line number, command text) of a fenced block's command lines, variables expanded."""
    variables: dict[str, str] = {}
    logical: list[tuple[int, str]] = []
    for n, line in block:
        if logical and logical[-1][1].endswith("\\"):
            logical[-1] = logical[-1][0], logical[-1][1][:-1] + " " + line.strip()
        else:
            logical.append((n, line))
    for n, line in logical:
        line = re.sub(r"\$\([^)]*\)", "<subst>", line)
        line = re.sub(r"\$\{?([A-Za-z_]\w*)\}?",
                      lambda m: variables.get(m.group(1), m.group(0)), line)
        if assigned := _assignments(line):
            variables.update(assigned)
        elif _is_command(line):
            yield n, line.strip()


def doc_commands() -> list[tuple[str, int, bool, str]]:
    """(page, line, whole command line?, text) of every command the docs quote."""
    found = []
    for page in PAGES:
        rel = page.relative_to(ROOT).as_posix()
        blocks, prose_lines = _split(page)
        for lang, block in blocks:
            if lang != "python":
                found += [(rel, n, True, text) for n, text in _block_commands(block)]
        prose = "\n".join(prose_lines)
        for m in re.finditer(r"(?<!`)`([^`]+)`(?!`)", prose):
            text = " ".join(m.group(1).split())
            if not re.search(r"\n\s*\n", m.group(1)) and _is_command(text) \
                    and not _assignments(text):
                found.append((rel, prose.count("\n", 0, m.start()) + 1, False, text))
    return sorted(set(found), key=lambda c: (PAGES.index(ROOT / c[0]), c[1], c[3]))


def _variants(words: list[str]) -> list[list[str]]:
    """The argv each alternative of ``a|b`` words and ``[x | y]`` groups gives."""
    choices: list[list[list[str]]] = []
    i = 0
    while i < len(words):
        w = words[i]
        if w.startswith("["):
            j = next((k for k in range(i, len(words)) if words[k].endswith("]")), len(words))
            inner = " ".join(words[i:j + 1])[1:-1].split()
            groups = [list(g) for sep, g in itertools.groupby(inner, lambda x: x == "|")
                      if not sep]
            choices.append([v for g in groups for v in _variants(g)])
            i = j + 1
            continue
        if w in _OPERATORS or re.fullmatch(r"\d*(>|>>|<)(&?\d+|[^<>]*)", w):
            break  # a pipeline, a list or a redirection: the rest is not ours
        choices.append([[a] for a in w.split("|")] if "|" in w.strip("|") else [[w]])
        i += 1
    return [sum(c, []) for c in itertools.product(*choices)]


def argvs(text: str) -> tuple[str, list[list[str]]]:
    """The program (``roughflow`` or a benchmark script's name) and its argv lists."""
    words = shlex.split(text, comments=True)
    while _ASSIGNMENT.match(words[0]):
        words.pop(0)
    if words[0].startswith("python"):
        words.pop(0)
    if words[0] == "-m":
        words.pop(0)
    program = words.pop(0)
    program = "roughflow" if program == "roughflow" else Path(program).stem
    out = []
    for argv in _variants(words):
        out.append([VALUE if _PLACEHOLDER.fullmatch(w) else w
                    for w in argv if w not in ("...", "…") and not _REMARK.fullmatch(w)])
    return program, out


class Drift(Exception):
    pass


def _raise(message: str):
    raise Drift(message) from None


class _OrPlaceholder:
    """An action's choices, plus the placeholder."""

    def __init__(self, choices):
        self.choices = choices

    def __contains__(self, value):
        return value == VALUE or value in self.choices

    def __iter__(self):
        return iter(self.choices)


def _or_placeholder(convert):
    def wrapper(text):
        return text if text == VALUE else convert(text)

    wrapper.__name__ = getattr(convert, "__name__", repr(convert))
    return wrapper


def _checking(parser: argparse.ArgumentParser, lenient: bool) -> argparse.ArgumentParser:
    """``parser`` made to raise :class:`Drift` for what it would exit on, to refuse
    abbreviations, to take placeholders as values and (``lenient``) to need nothing."""
    for p in (parser, *_subparsers(parser)):
        p.allow_abbrev = False
        p.error = _raise
        for action in p._actions:
            action.required = action.required and not lenient
            if isinstance(action, argparse._SubParsersAction):
                continue
            if callable(action.type):
                action.type = _or_placeholder(action.type)
            if action.choices is not None:
                action.choices = _OrPlaceholder(action.choices)
    return parser


@functools.cache
def _benchmark(name: str):
    path = ROOT / "benchmarks" / f"{name}.py"
    if not path.exists():
        return None
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules.setdefault(name, module)  # their `from bench_contact import ...`
    # a benchmark puts its folder on sys.path to import its siblings at load time; the
    # path is given back so that later tests import nothing from benchmarks/ by accident
    saved = list(sys.path)
    try:
        spec.loader.exec_module(module)
    finally:
        sys.path[:] = saved
    return module


@functools.cache
def checking_parser(program: str, lenient: bool) -> argparse.ArgumentParser:
    if program == "roughflow":
        return _checking(build_parser(), lenient)
    module = _benchmark(program)
    assert module is not None, f"there is no benchmarks/{program}.py"
    assert hasattr(module, "build_parser"), \
        f"benchmarks/{program}.py has no build_parser() (its main() should call it)"
    return _checking(module.build_parser(), lenient)


def parse(program: str, argv: list[str], lenient: bool) -> None:
    """Parse ``argv`` as the docs' ``program`` would; :class:`Drift` where it does not."""
    parser = checking_parser(program, lenient)
    if program == "roughflow" and argv[:1] == [VALUE]:  # `roughflow COMMAND --help`
        for name in next(a for a in parser._actions
                         if isinstance(a, argparse._SubParsersAction)).choices:
            parse(program, [name, *argv[1:]], lenient)
        return
    try:
        with contextlib.redirect_stdout(io.StringIO()):
            parser.parse_args(argv)
    except SystemExit as exc:  # --help, --version
        if exc.code not in (0, None):
            raise Drift(f"exit status {exc.code}") from None
    except Drift:
        # an inline span may end with an option, naming it: `stress_flow.py --summarize`
        if not (lenient and argv and argv[-1].startswith("-")):
            raise
        with contextlib.suppress(Drift):
            return parse(program, [*argv, VALUE], lenient)
        raise


COMMANDS = doc_commands()


def test_the_docs_quote_commands_of_every_kind():
    # the extraction itself works: commands of both kinds from fenced blocks and prose
    programs = {argvs(text)[0] for *_, text in COMMANDS}
    assert len(COMMANDS) > 50 and "roughflow" in programs and len(programs) > 10
    assert {whole for _, _, whole, _ in COMMANDS} == {True, False}


@pytest.mark.parametrize("page,line,whole,text", COMMANDS,
                         ids=[f"{p}:{n}: {t}" for p, n, _, t in COMMANDS])
def test_doc_command_parses(page, line, whole, text):
    program, variants = argvs(text)
    for argv in variants:
        try:
            parse(program, argv, lenient=not whole)
        except Drift as exc:
            error = str(exc)
        else:
            continue
        shown = " ".join("<placeholder>" if w == VALUE else w for w in argv)
        pytest.fail(f"{page}:{line}: `{text}` does not parse ({program} {shown}): {error}",
                    pytrace=False)


# -- the docs' Python examples (README.md's: tests/test_readme.py) -------------------------

def _python_blocks():
    for page in PAGES[1:]:
        for lang, block in _split(page)[0]:
            if lang == "python":
                code = textwrap.dedent("\n".join(line for _, line in block))
                yield pytest.param(code, id=f"docs/{page.name}:{block[0][0] - 1}")


def _wyko_waves() -> np.ndarray:
    """Heights in wavelengths (577.29 nm) of a generated surface on the Wyko example's
    197 nm pixels, rms slope 0.05 (the measured scan's order), a few points missing (NaN) as
    in the measured scan, whose page example fills them."""
    from roughflow.surface import SurfaceSpec, generate

    s = generate(SurfaceSpec.from_sweep(points_per_lambda_s=2, seed=3))
    pixel = 0.000196733e-3  # m
    waves = s.heights * (pixel * s.shape[0] / s.lx) * 0.05 / 577.2949829e-9
    waves[5, 7] = waves[40, 41] = np.nan
    return waves


@pytest.mark.parametrize("code", list(_python_blocks()))
def test_doc_python_block_runs(code, request, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    if '"opd-1.opd"' in code:  # the Wyko scan is not in the repository: one of its layout
        from test_scan_robustness import write_opd  # (skips without SurfaceTopography)

        write_opd(tmp_path / "opd-1.opd", _wyko_waves())
    if '"leak.nc"' in code:  # the file the page's `roughflow leak` writes
        npy = ROOT / "tests" / "data" / "afm-64.npy"
        assert cli_main(["-q", "import", str(npy), "--size", "500nm", "--unit", "nm",
                         "-o", "scan.nc"]) == 0
        assert cli_main(["-q", "leak", "scan.nc", "--modulus", "200GPa", "--pressures",
                         "1GPa:10GPa:2", "--fluid-pressure", "1MPa", "--viscosity", "1mPa.s",
                         "--seal-width", "2mm", "--seal-length", "60mm", "-o", "leak.nc"]) == 0
    names: dict = {}
    try:
        exec(compile(code, request.node.callspec.id, "exec"), names)
    finally:
        for value in names.values():  # open datasets and figures
            if type(value).__name__ == "Dataset":
                value.close()
        if "matplotlib.pyplot" in sys.modules:
            sys.modules["matplotlib.pyplot"].close("all")
