"""Expanding and checking the workflow config's study blocks into jobs.

A study block of the workflow config (``config/config.yaml``) expands into the jobs of
:mod:`roughflow.scenes.jobs` with :func:`expand_study` (every study of a config:
:func:`expand_studies`, each shared job once: :func:`pool_jobs`); keys the block leaves out
take :func:`study_defaults` (the workflow schema is tested against it). Every job is built
and the jobs are checked against each other (:func:`check_collisions`) at planning, before
any job runs.
"""

from __future__ import annotations

import itertools
import json
import math
from dataclasses import fields
from pathlib import Path
from typing import TYPE_CHECKING

from roughflow import defaults
from roughflow.defaults import (
    FLOW_STUDIES,
    STUDIES,
    STUDY_FIXED,
    STUDY_ONE_SIZE,
    STUDY_ONE_VALUE,
    THRESHOLD_STUDIES,
)
from roughflow.errors import InputError, check_nu, require_installed
from roughflow.files import require_readable
from roughflow.surface import paper_l_over_lambda_r

from .jobs import (
    ChannelsJob,
    Job,
    LadderJob,
    LeakJob,
    SurfaceParams,
    ThresholdJob,
    field_default,
    question_si,
)

if TYPE_CHECKING:
    from collections.abc import Iterable


def _adhesion_args(adh: dict) -> dict:
    """LadderJob keywords from a config ``adhesion`` block (a Tabor parameter replaces the
    repulsion's default range)."""
    out = {"surface_energy_ratio": float(adh.get("surface_energy_ratio",
                                                 defaults.ADHESION_SURFACE_ENERGY_RATIO)),
           "repulsion": adh.get("repulsion", defaults.ADHESION_REPULSION)}
    if adh.get("tabor") is not None:
        if adh.get("range_over_lambda_s") is not None:
            raise InputError("adhesion: give range_over_lambda_s or tabor, not both "
                             f"(got {adh!r})")
        return {**out, "tabor": float(adh["tabor"])}
    rho = adh.get("range_over_lambda_s")
    return {**out, "range_over_lambda_s": None if rho is None else float(rho)}


def _as_list(v) -> list:
    return list(v) if isinstance(v, (list, tuple)) else [v]


def study_defaults(name: str) -> dict:
    """The value of every optional key of a study block when the config leaves it out."""
    if name == "channels":
        return {f.name: f.default for f in fields(ChannelsJob) if f.init}
    if name == defaults.MEASURED_STUDY:
        return {key: field_default(LeakJob, key) for key in ("detrend", "fill", "boundary")}
    common = {
        "gamma": [defaults.GAMMA], "hurst": [defaults.HURST], "eps_f": [defaults.EPS_F],
        "model": ["elastic"], "seeds_per_job": 1,
        "points_per_lambda_s": defaults.POINTS_PER_LAMBDA_S,
    }
    if name in THRESHOLD_STUDIES:
        return {**common, "l_over_lambda_r": [None],
                "tol": field_default(ThresholdJob, "tol"),
                "contact_tol": field_default(ThresholdJob, "contact_tol"),
                "fit": {"bootstrap": defaults.FIT_BOOTSTRAP, "nu": defaults.NU_PERCOLATION}}
    if name in FLOW_STUDIES:
        return {**common, "l_over_lambda_r": [defaults.FLOW_L_OVER_LAMBDA_R],
                "a_c_star": dict(defaults.A_C_STAR_THEORY),
                "a_c_star_alt": defaults.A_C_STAR_ALT,
                "area_tol": field_default(LadderJob, "area_tol"),
                "adhesion": {"repulsion": defaults.ADHESION_REPULSION,
                             "surface_energy_ratio": defaults.ADHESION_SURFACE_ENERGY_RATIO,
                             "range_over_lambda_s": defaults.ADHESION_RANGE_OVER_LAMBDA_S[
                                 defaults.ADHESION_REPULSION]}}
    raise InputError(f"unknown study {name!r}; known studies: {', '.join(STUDIES)}")


def _series(block: dict) -> list[dict]:
    base = {k: v for k, v in block.items() if k != "series"}
    series = block.get("series") or [{}]
    return [{**base, **s} for s in series]


def expand_study(name: str, block: dict) -> dict[str, Job]:
    """Jobs of one study block (already validated against the schema), keyed by job id.

    Keys the block leaves out take :func:`study_defaults`. List keys expand as a Cartesian
    product per series; seeds are grouped into ``seeds_per_job`` per job. Every job (and
    so every surface spec) is built here and the jobs are checked against each other
    (:func:`check_collisions`), so a bad value or a study whose jobs would overwrite each
    other's cells raises :class:`InputError` naming the study, series and values before any
    job runs.
    """
    _check_keys_apply(name, block)
    block = {**study_defaults(name), **block}
    if name == defaults.MEASURED_STUDY:
        return _expand_measured(block)
    if name == "channels":
        try:
            job = ChannelsJob(**block)
        except InputError as exc:
            raise InputError(f"config studies.{name}: {exc}") from None
        return {job.job_id: job}
    jobs: dict[str, Job] = {}
    for n, s in enumerate(_series(block)):
        where = f"config studies.{name}" + (f".series[{n}]" if block.get("series") else "")
        groups = seed_groups([int(v) for v in _as_list(s["seeds"])], int(s["seeds_per_job"]))
        ppl = float(s["points_per_lambda_s"])
        for model, gamma, hurst, size, eps_f in itertools.product(
            _as_list(s["model"]), _as_list(s["gamma"]), _as_list(s["hurst"]),
            _as_list(s["l_over_lambda_r"]), _as_list(s["eps_f"]),
        ):
            values = (f"model={model}, gamma={gamma:g}, hurst={hurst:g}, l_over_lambda_r="
                      f"{'null' if size is None else format(size, 'g')}, eps_f={eps_f:g}, "
                      f"points_per_lambda_s={ppl:g}")
            try:
                for g in groups:
                    job = _make_job(name, s, model, gamma, hurst, size, eps_f, ppl, g)
                    _add_job(jobs, job)
                if isinstance(job, LadderJob) and job.model == "adhesive":
                    check_adhesion_grid(job)  # one check per parameter set: seeds do not matter
            except InputError as exc:
                raise InputError(f"{where}: {values}: {exc}") from None
    check_collisions(name, jobs.values())
    _check_one_series(name, jobs.values())
    return jobs


#: Study keys that do not change the study's dataset: the fit's options (the fit rule's own
#: params) and a series' label. Left out of what the aggregation records, so that editing
#: them does not re-aggregate (and with a job file deleted, recompute that job).
NOT_AGGREGATED = ("fit", "label")


def aggregated_config(block: dict) -> str:
    """The study block an aggregated dataset records (its ``study_config``, JSON), without
    :data:`NOT_AGGREGATED`: the aggregation's Snakemake params."""
    def strip(d: dict) -> dict:
        return {k: ([strip(v) if isinstance(v, dict) else v for v in val]
                    if k == "series" and isinstance(val, list) else val)
                for k, val in d.items() if k not in NOT_AGGREGATED}

    return json.dumps(strip(block), sort_keys=True)


def seed_groups(seeds: list[int], per: int) -> list[tuple[int, ...]]:
    """The seeds of one parameter set, grouped into jobs by value: block ``seed // per``.

    By position (the first ``per`` seeds, then the next), removing one seed moved every later
    seed into another job, so Snakemake recomputed seeds it had (all 80 searches of a study
    for seed 0), and the config's order of seeds gave other jobs for the same seeds. By value,
    adding or removing a seed touches its own block's job only; ``[0, ..., 9]`` with ``per`` 5
    gives the blocks it gave before. Duplicates stay in their block, where the job refuses
    them."""
    blocks: dict[int, list[int]] = {}
    for seed in sorted(seeds):
        blocks.setdefault(seed // per, []).append(seed)
    return [tuple(block) for _, block in sorted(blocks.items())]


def check_adhesion_grid(job: LadderJob) -> None:
    """Refuse an adhesive ladder whose adhesive zone the grid pins
    (:func:`roughflow.contact.adhesion.check_zone`), from its spec's spectrum
    (:func:`roughflow.surface.spec_power`: the adhesion is the same on every seed's
    surface): at planning, not after the job made its surface and its reference flow
    solve. The message gives the range in the config's units."""
    from roughflow.contact.adhesion import ZONE_PINNED, adhesion_for_power, check_zone
    from roughflow.surface import spec_power

    spec = job.surface.spec(job.seeds[0])
    q, power = spec_power(spec)
    rho = None if job.range_over_lambda_s is None else job.range_over_lambda_s * spec.lambda_s
    adhesion = adhesion_for_power(q, power, gamma_over_v_full=job.surface_energy_ratio,
                                  tabor=job.tabor, range=rho, repulsion=job.repulsion)
    try:
        check_zone(adhesion, (spec.nx, spec.ny), spec.lx, spec.ly)
    except InputError as exc:
        spacing = max(spec.lx / spec.nx, spec.ly / spec.ny)
        zone_range = math.pi * math.sqrt(ZONE_PINNED * spacing * adhesion.surface_energy) / 2
        raise InputError(
            f"adhesion (surface_energy_ratio {job.surface_energy_ratio:g}, "
            + (f"tabor {job.tabor:g}" if job.tabor is not None else
               f"range_over_lambda_s {job.range_over_lambda_s:g}")
            + f"): {exc}; in the config's units the range is {adhesion.range / spec.lambda_s:.3g}"
            f" lambda_s and must be at least {zone_range / spec.lambda_s:.3g} lambda_s "
            "(adhesion.range_over_lambda_s), or points_per_lambda_s larger") from None


def _add_job(jobs: dict[str, Job], job: Job) -> None:
    """Add ``job`` under its id; the same job twice is one job, but two different jobs with
    one id (values equal to the 6 digits of the id) would silently drop the second."""
    other = jobs.setdefault(job.job_id, job)
    if other != job:
        raise InputError(f"two different jobs get the id {job.job_id!r} (their values agree "
                         "to the 6 significant digits of job ids): make them differ more")


def _check_one_series(name: str, jobs) -> None:
    """Refuse at planning a study whose figure or fit would refuse its dataset after every
    job ran: several values of a parameter it draws one series of."""
    from roughflow.datasets.sweep import PARAM_DIMS

    if name in STUDY_ONE_SIZE:  # one system size per point
        sizes: dict[tuple, set] = {}
        for job in jobs:
            key = dict(zip(PARAM_DIMS, job.key, strict=True))
            eps_t = key.pop("eps_t")
            sizes.setdefault(tuple(key.items()), set()).add(eps_t)
        for point, found in sizes.items():
            if len(found) > 1:
                shown = ", ".join(f"{d}={v:g}" if isinstance(v, float) else f"{d}={v}"
                                  for d, v in point)
                raise InputError(f"config studies.{name}: its figure shows one system size "
                                 f"per point, {shown} has {len(found)} (eps_t "
                                 f"{', '.join(f'{e:g}' for e in sorted(found))}); "
                                 "threshold_vs_size draws the sizes")
    if name in FLOW_STUDIES:  # one row of panels per setting (flow_rows), up to a limit
        combos: dict[str, set[tuple]] = {}
        for job in jobs:
            combos.setdefault(job.model, set()).add(flow_combo(job))
        params, rows = flow_rows(combos)
        if len(rows) > FLOW_FIGURE_MAX_ROWS:
            raise InputError(f"config studies.{name}: its figure draws one row of panels per "
                             f"combination of {flow_row_names(params)}, at most "
                             f"{FLOW_FIGURE_MAX_ROWS}; the study has {len(rows)}: sweep fewer "
                             "values, or split the sweep over several configs (each with its "
                             "own results folder)")
        return
    dims = STUDY_ONE_VALUE.get(name)
    if dims is None:
        return
    seen: dict[str, set] = {}
    for job in jobs:
        key = dict(zip(PARAM_DIMS, job.key, strict=True))
        for dim in dims:
            seen.setdefault(dim, set()).add(key[dim])
    for dim, found in seen.items():
        if len(found) > 1:
            shown = ", ".join(f"{v:g}" if isinstance(v, float) else str(v)
                              for v in sorted(found, key=str))
            raise InputError(f"config studies.{name}: its figure shows one {dim}, the study "
                             f"has {len(found)}: {shown}")


#: The sweep parameters of the flow figures' rows, as the config names them (the size as
#: L / lambda_r, not the dataset's dimension eps_t, which also moves with gamma), and their
#: labels in the figures' row titles and in messages.
FLOW_ROW_PARAMS = ("gamma", "hurst", "l_over_lambda_r", "eps_f")
FLOW_ROW_LABELS = ("gamma", "H", "L/lambda_r", "eps_f")
#: The most rows of panels a flow figure draws (4.2 inches each).
FLOW_FIGURE_MAX_ROWS = 16


def flow_row_names(params: tuple[int, ...]) -> str:
    """``gamma, H and eps_f``: the labels of the parameters (indices into
    :data:`FLOW_ROW_PARAMS`) that rows differ in, for messages."""
    names = [FLOW_ROW_LABELS[i] for i in params]
    return " and ".join([", ".join(names[:-1]), names[-1]] if len(names) > 1 else names)


def flow_combo(job: LadderJob) -> tuple[float, float, float, float]:
    """The :data:`FLOW_ROW_PARAMS` of a ladder job, rounded as its dataset stores them."""
    from roughflow.datasets.sweep import rnd

    p = job.surface
    return (rnd(p.gamma), rnd(p.hurst), rnd(p.size), rnd(p.eps_f))


def flow_rows(combos: dict[str, Iterable[tuple]]) -> tuple[tuple[int, ...], list[tuple]]:
    """The rows of a flow figure from the settings (values of :data:`FLOW_ROW_PARAMS`) that
    each model ran: (the indices of the parameters the rows differ in, the rows' values of
    them, sorted).

    A parameter sets the rows where some model ran several values of it. One that each model
    runs at a single value, even a different one per model (the bearing model on a smaller
    cell, as in config/test.yaml), sets none: every row then holds each model's panel, as
    the figures did before they drew sweeps. A row shows each model at its setting with
    the row's values; a model that did not run them leaves its panel empty. With no
    parameter that sets rows there is one row, ``[()]``: the paper's figure. The planner
    (:func:`expand_study`) and the figures (:mod:`roughflow.figures._flow`) share this rule.
    """
    combos = {model: set(found) for model, found in combos.items()}
    params = tuple(i for i in range(len(FLOW_ROW_PARAMS))
                   if any(len({c[i] for c in found}) > 1 for found in combos.values()))
    rows = sorted({tuple(c[i] for i in params) for found in combos.values() for c in found})
    return params, rows or [()]


def _check_keys_apply(name: str, block: dict) -> None:
    """Refuse keys of a study block that nothing would use (they were silently ignored)."""
    where = f"config studies.{name}"
    if name in THRESHOLD_STUDIES:
        for n, s in enumerate(block.get("series") or []):
            if "area_fraction" in s:
                raise InputError(f"{where}.series[{n}]: area_fraction is a key of the flow "
                                 "studies (their contact-area ladder); a threshold study "
                                 "searches a_c*")
        if "fit" in block:
            if name != "threshold_vs_size":
                raise InputError(f"{where}: fit applies to threshold_vs_size only (its "
                                 "finite-size-scaling fit); this study runs no fit")
            if "nu" in block["fit"]:
                try:
                    check_nu(block["fit"]["nu"])
                except InputError as exc:
                    raise InputError(f"{where}.fit: {exc}") from None
    if name in FLOW_STUDIES:
        models = set(_as_list(block.get("model", study_defaults(name)["model"])))
        for s in block.get("series") or []:
            models |= set(_as_list(s.get("model", [])))
        if "adhesion" in block and "adhesive" not in models:
            raise InputError(f"{where}: adhesion applies to the adhesive model, which this "
                             f"study does not run (models: {', '.join(sorted(models))})")
        unused = sorted(set(block.get("a_c_star") or {}) - models)
        if unused:
            raise InputError(f"{where}: a_c_star of {', '.join(unused)}, a model this study "
                             f"does not run (models: {', '.join(sorted(models))})")
    fixed, other = STUDY_FIXED.get(name, ({}, None))
    for key, value in fixed.items():
        values = set(_as_list(block.get(key, [value])))
        for s in block.get("series") or []:
            values |= set(_as_list(s.get(key, [])))
        if values - {value}:
            raise InputError(f"{where}: this study takes {key} = {value:g}, got "
                             f"{sorted(values)} (other values: {other})")


def expand_studies(studies: dict) -> dict[str, Job]:
    """Jobs of every study of a config's ``studies`` block, keyed by job id (a job that
    two studies share, such as an H = 0.8 threshold point, appears once)."""
    return pool_jobs({name: expand_study(name, block) for name, block in studies.items()})


def pool_jobs(jobs_by_study: dict[str, dict[str, Job]]) -> dict[str, Job]:
    """The jobs of several studies keyed by job id, each once: a job that two studies
    share runs once. Two different jobs with one id (values that agree to the 6
    significant digits of job ids) raise :class:`InputError` naming both studies and how
    the jobs differ: the second would be dropped."""
    pool: dict[str, Job] = {}
    owner: dict[str, str] = {}
    for study, jobs in jobs_by_study.items():
        for job_id, job in jobs.items():
            other = pool.setdefault(job_id, job)
            owner.setdefault(job_id, study)
            if other != job:
                diff = "; ".join(f"{name} {a!r} vs {b!r}" for name, a, b in _differences(other,
                                                                                          job))
                raise InputError(
                    f"config studies.{owner[job_id]} and studies.{study}: two different jobs "
                    f"get the id {job_id!r} ({diff}; the values agree to the 6 significant "
                    "digits of job ids): make them equal, or differ more")
    return pool


def _differences(a, b, prefix: str = "") -> list[tuple[str, object, object]]:
    """(field, value in a, value in b) where two jobs (dataclasses, nested) differ."""
    if type(a) is not type(b) or not hasattr(a, "__dataclass_fields__"):
        return [(prefix.rstrip(".") or "kind", a, b)] if a != b else []
    out = []
    for f in fields(a):
        x, y = getattr(a, f.name), getattr(b, f.name)
        if x != y:
            out += (_differences(x, y, f"{prefix}{f.name}.")
                    if hasattr(x, "__dataclass_fields__") else [(prefix + f.name, x, y)])
    return out


def _expand_measured(block: dict) -> dict[str, Job]:
    """One :class:`LeakJob` per scan; a scan entry's keys override the study's."""
    study = defaults.MEASURED_STUDY
    shared = {k: v for k, v in block.items() if k != "scans"}
    try:  # a bad study-level value is the study's, not its first scan's
        question_si(shared)
    except InputError as exc:
        raise InputError(f"config studies.{study}: {exc}") from None
    jobs: dict[str, Job] = {}
    if block["scans"]:  # the import jobs would fail on it, after the other studies' jobs
        try:
            require_installed(defaults.SCAN_READER, "reading scans", defaults.SCAN_READER_EXTRA)
        except InputError as exc:
            raise InputError(f"config studies.{study}: {exc}") from None
    for entry in block["scans"]:
        args = {**shared, **entry}
        name = args.get("name") or Path(str(args["file"])).stem
        args["name"] = name
        # the import job would fail on it, after the other studies' jobs
        require_readable(Path(str(args["file"])),
                         f"config studies.{study}, scan {name!r}: file {args['file']!r}",
                         missing=f" (paths are relative to {Path.cwd()})")
        if name in jobs:
            raise InputError(f"config studies.{study}: two scans are named {name!r}")
        try:
            jobs[name] = LeakJob(**args)
        except InputError as exc:
            raise InputError(f"config studies.{study}, scan {name!r}: {exc}") from None
    return jobs



def _make_job(name: str, s: dict, model, gamma, hurst, size, eps_f, ppl, seeds) -> Job:
    size = paper_l_over_lambda_r(float(gamma)) if size is None else float(size)
    p = SurfaceParams(gamma=float(gamma), hurst=float(hurst), l_over_lambda_r=size,
                      eps_f=float(eps_f), points_per_lambda_s=ppl)
    if name in THRESHOLD_STUDIES:
        return ThresholdJob(surface=p, model=model, seeds=seeds, tol=float(s["tol"]),
                            contact_tol=float(s["contact_tol"]))
    stars = {**defaults.A_C_STAR_THEORY, **s["a_c_star"]}
    alt = s["a_c_star_alt"]
    return LadderJob(
        surface=p, model=model, seeds=seeds,
        area_fractions=tuple(sorted(float(a) for a in s["area_fraction"])),
        a_c_star=float(stars[model]), a_c_star_alt=None if alt is None else float(alt),
        area_tol=float(s["area_tol"]), **_adhesion_args(s["adhesion"]),
    )


def _options(args: tuple[str, ...]) -> dict[str, str]:
    """``--flag value ...`` -> {flag: "value ..."} (for messages)."""
    out: dict[str, list[str]] = {}
    flag = ""
    for a in args:
        if a.startswith("--"):
            flag = a
            out[flag] = []
        else:
            out.setdefault(flag, []).append(a)
    return {k: " ".join(v) for k, v in out.items()}


def describe_key(key: tuple) -> str:
    """``model=elastic, gamma=1, ...`` for a :attr:`ThresholdJob.key`."""
    from roughflow.datasets.sweep import PARAM_DIMS

    return ", ".join(f"{d}={v:g}" if isinstance(v, float) else f"{d}={v}"
                     for d, v in zip(PARAM_DIMS, key, strict=True))


def check_collisions(study: str, jobs: Iterable[Job]) -> None:
    """Refuse jobs of one study that would fill the same cells of its dataset.

    Jobs with the same :attr:`~ThresholdJob.key` (model, gamma, hurst, eps_t, eps_f) are
    stacked along ``seed`` by the aggregation; they must have the same settings (grid
    resolution, tolerances, ladder, ...: else the study would mix two computations, and the
    settings that are variables, such as ``points_per_lambda_s``, would collide) and
    distinct seeds (else the aggregation would duplicate or drop a seed).
    """
    seen: dict[tuple, list] = {}
    for job in jobs:
        if isinstance(job, ChannelsJob):
            continue
        for other in seen.get(job.key, []):
            if other.settings() != job.settings():
                a, b = _options(other.settings()), _options(job.settings())
                diff = "; ".join(f"{k} {a.get(k, '(none)')} vs {b.get(k, '(none)')}"
                                 for k in sorted(set(a) | set(b)) if a.get(k) != b.get(k))
                raise InputError(
                    f"config studies.{study}: two jobs fill the same cells "
                    f"({describe_key(job.key)}) with different settings ({diff}); the "
                    "dataset has no dimension for them: put them in different studies or "
                    "give them different parameters")
            common = sorted(set(job.seeds) & set(other.seeds))
            if common:
                raise InputError(
                    f"config studies.{study}: seeds {common} of {describe_key(job.key)} are "
                    f"computed by two jobs ({other.job_id} and {job.job_id}); every seed "
                    "may appear once per parameter set (check overlapping series)")
        seen.setdefault(job.key, []).append(job)
