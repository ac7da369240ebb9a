"""Every default is written once (roughflow.defaults and the job dataclasses); the workflow
schema, the command line and the library entry points must agree with it."""

from __future__ import annotations

import inspect
from pathlib import Path

import pytest
import yaml

from roughflow import defaults
from roughflow.cli import build_parser
from roughflow.scenes import study_defaults

SCHEMA = Path(__file__).resolve().parents[1] / "workflow" / "schemas" / "config.schema.yaml"
STUDY_SCHEMA = {"channels": "channels", "threshold_vs_gamma": "threshold_study",
                "flow_isotropic": "flow_study", "measured": "measured_study"}


def _schema_defaults(node: dict) -> dict:
    """The defaults a JSON schema object declares for its properties (nested objects too)."""
    out = {}
    for key, prop in node.get("properties", {}).items():
        if "default" in prop:
            out[key] = prop["default"]
        elif "properties" in prop:
            nested = _schema_defaults(prop)
            if nested:
                out[key] = nested
    return out


@pytest.mark.parametrize("study", STUDY_SCHEMA)
def test_schema_defaults_equal_roughflow_defaults(study):
    schema = yaml.safe_load(SCHEMA.read_text())["$defs"][STUDY_SCHEMA[study]]
    declared = _schema_defaults(schema)
    ours = study_defaults(study)
    # the schema documents every default roughflow applies, with the same value
    assert set(ours) <= set(declared), sorted(set(ours) - set(declared))
    for key, value in declared.items():
        assert key in ours, f"schema declares a default for {key!r} that roughflow lacks"
        if isinstance(value, dict) and isinstance(ours[key], dict):
            for k, v in value.items():
                assert ours[key][k] == pytest.approx(v), (key, k)
        elif isinstance(value, list):
            assert list(ours[key]) == value, key
        else:
            assert ours[key] == pytest.approx(value) if isinstance(value, float) \
                else ours[key] == value, key


def _defaults_of(argv: list[str]) -> dict:
    return vars(build_parser().parse_args(argv))


def test_threshold_cli_defaults_are_the_search_defaults():
    from roughflow.cli import build_parser
    from roughflow.cli.threshold import _search_options
    from roughflow.search import SearchOptions, first_pressure, threshold

    got = _defaults_of(["threshold", "s.nc", "-o", "t.nc"])
    opts = SearchOptions()
    assert got["tol"] == inspect.signature(threshold).parameters["tol"].default
    assert got["contact_tol"] == opts.contact_tol
    assert got["strategy"] == opts.strategy and got["method"] == opts.method
    # the pressures default to the search's, scaled by the surface's gbar (1 when generated)
    assert got["p_min"] is None and got["p_max"] is None and got["p_guess"] is None
    cli = _search_options(build_parser().parse_args(["threshold", "s.nc", "-o", "t.nc"]), 1.0)
    assert cli.pressure_range == opts.pressure_range
    assert cli.first_pressure == first_pressure() and opts.first_pressure is None


def test_contact_and_flow_cli_defaults_are_the_solver_defaults():
    from roughflow.contact import solve
    from roughflow.flow import solve as flow_solve

    got = _defaults_of(["contact", "s.nc", "-o", "c.nc"])
    assert got["tol"] == inspect.signature(solve).parameters["tol"].default
    assert got["model"] == inspect.signature(solve).parameters["model"].default
    got = _defaults_of(["flow", "c.nc", "-o", "f.nc"])
    assert got["tol"] == inspect.signature(flow_solve).parameters["tol"].default


@pytest.mark.parametrize("argv", [["surface", "-o", "s.nc"], ["theory"]])
def test_surface_options_are_the_spec_defaults(argv):
    from roughflow.surface import SurfaceSpec

    got = _defaults_of(argv)
    sweep = inspect.signature(SurfaceSpec.from_sweep).parameters
    for name in ("hurst", "eps_f", "points_per_lambda_s", "aspect", "rolloff"):
        assert got[name] == sweep[name].default, name
    assert got["gamma"] in (None, sweep["gamma"].default)


def test_theory_lines_default_per_model():
    from roughflow.scenes import LadderJob, SurfaceParams

    for model, a_star in defaults.A_C_STAR_THEORY.items():
        job = LadderJob(surface=SurfaceParams(), model=model, area_fractions=(0.1,))
        assert job.a_c_star == a_star


def test_schema_choices_are_roughflow_choices():
    # A JSON schema cannot import the Python tuples, so its enums copy them: they must stay
    # equal, or the workflow would refuse a mode the library offers (or pass one it refuses)
    schema = yaml.safe_load(SCHEMA.read_text())["$defs"]
    assert schema["scan_options"]["detrend"]["enum"] == list(defaults.DETREND_MODES)
    assert schema["scan_options"]["fill"]["enum"] == list(defaults.FILL_METHODS)
    boundary = schema["measured_study"]["properties"]["boundary"]["enum"]
    assert boundary == list(defaults.BOUNDARY_METHODS)


@pytest.mark.parametrize(("block", "key", "limit"), [
    ("threshold_study", "tol", "THRESHOLD_TOL_MAX"),
    ("threshold_study", "contact_tol", "CONTACT_TOL_MAX"),
    ("flow_study", "area_tol", "LADDER_AREA_TOL_MAX"),
])
def test_schema_limits_are_the_librarys(block, key, limit):
    # a config value the schema lets through must not be refused by the job it becomes,
    # nor one the library takes refused by the schema
    prop = yaml.safe_load(SCHEMA.read_text())["$defs"][block]["properties"][key]
    assert prop["maximum"] == getattr(defaults, limit)


def test_schema_bootstrap_bound_is_the_librarys():
    prop = yaml.safe_load(SCHEMA.read_text())["$defs"]["threshold_study"]["properties"][
        "fit"]["properties"]["bootstrap"]
    assert prop["maximum"] == defaults.FIT_BOOTSTRAP_MAX


def test_schema_contact_tol_floor_is_the_librarys():
    prop = yaml.safe_load(SCHEMA.read_text())["$defs"]["threshold_study"]["properties"][
        "contact_tol"]
    assert prop["minimum"] == defaults.CONTACT_TOL_MIN
