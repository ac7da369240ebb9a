"""Flow studies that sweep gamma, H, L/lambda_r or eps_f (user audit, finding 7): the
planner refused them ("its figure shows one gamma for model elastic, the study has 2"), so
sigma(a_c) for three H took three configs and results folders. The figures now draw one
row of panels per setting, titled with its values; one setting is still the paper's
figure, one untitled row."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import pytest  # noqa: E402
import yaml  # noqa: E402

from roughflow.errors import InputError  # noqa: E402
from roughflow.scenes import expand_study  # noqa: E402

_LADDER = {"seeds": [0], "points_per_lambda_s": 2, "eps_f": [0.25], "l_over_lambda_r": [4],
           "area_fraction": [0.2, 0.4]}


@pytest.fixture(scope="module")
def two_hurst():
    """A tiny real flow dataset: elastic and bearing ladders at H = 0.5 and 0.8, one job
    each, combined as the aggregation combines job files."""
    from roughflow.aggregate import combine
    from roughflow.scenes import LadderJob, SurfaceParams, run_ladder

    parts = []
    for hurst in (0.8, 0.5):
        surface = SurfaceParams(gamma=1.0, hurst=hurst, l_over_lambda_r=2.0, eps_f=0.125,
                                points_per_lambda_s=2)
        for model in ("elastic", "bearing"):
            parts.append(run_ladder(LadderJob(surface=surface, model=model, seeds=(0,),
                                              area_fractions=(0.1, 0.3))))
    ds = combine(parts)
    assert ds.sizes["hurst"] == 2 and ds["sigma"].notnull().all()
    return ds


def _rows(fig):
    """(row title, panel titles) of each row of a flow figure."""
    if not fig.subfigs:
        return [(None, [ax.get_title() for ax in fig.axes])]
    return [(sub._suptitle.get_text(), [ax.get_title() for ax in sub.axes])
            for sub in fig.subfigs]


def test_a_flow_figure_draws_a_row_per_hurst(two_hurst):
    from roughflow.figures import flow_anisotropic, flow_isotropic

    fig = flow_isotropic.draw(two_hurst)
    assert _rows(fig) == [
        ("H = 0.5", ["(a1) elastic, non-adhesive", "(b1) bearing-area model"]),
        ("H = 0.8", ["(a2) elastic, non-adhesive", "(b2) bearing-area model"])]
    assert fig.get_size_inches()[1] == pytest.approx(2 * 4.2)
    # each row draws its own setting's data and theory lines, not the other row's
    for sub, hurst in zip(fig.subfigs, (0.5, 0.8), strict=True):
        ax = sub.axes[0]
        ladder = two_hurst.sel(model="elastic", hurst=hurst).squeeze()
        ref = float(ladder["sigma_ref"].mean())
        (points,) = [ln for ln in ax.get_lines() if ln.get_label() == "full Reynolds"]
        expected = sorted((ladder["sigma"].mean("axis") / ref).values.ravel())
        assert sorted(points.get_ydata()) == pytest.approx(expected)
        (emt,) = [ln for ln in ax.get_lines() if ln.get_label() == "full Bruggeman"]
        line = ladder["sigma_emt"].sel(emt="isotropic").isel(axis=0) / ref
        assert list(emt.get_ydata()) == pytest.approx(list(line.values.ravel()))
    # the rows share each column's axes, so that they compare at a glance
    a1, a2 = fig.subfigs[0].axes[0], fig.subfigs[1].axes[0]
    assert a1.get_ylim() == a2.get_ylim() and a1.get_xlim() == a2.get_xlim()

    fig = flow_anisotropic.draw(two_hurst)
    assert _rows(fig) == [
        ("H = 0.5", ["(a1) elastic, gamma = 1", "(b1) bearing, gamma = 1",
                     "(c1) conductance ratio"]),
        ("H = 0.8", ["(a2) elastic, gamma = 1", "(b2) bearing, gamma = 1",
                     "(c2) conductance ratio"])]


def test_one_setting_is_still_the_papers_single_row(two_hurst):
    from roughflow.figures import flow_anisotropic, flow_isotropic

    one = two_hurst.sel(hurst=[0.8])
    assert _rows(flow_isotropic.draw(one)) == [
        (None, ["(a) elastic, non-adhesive", "(b) bearing-area model"])]
    assert _rows(flow_anisotropic.draw(one)) == [
        (None, ["(a) elastic, gamma = 1", "(b) bearing, gamma = 1", "(c) conductance ratio"])]
    # the bearing model alone at another H (one setting per model, as models at different
    # sizes in config/test.yaml) is one row too
    mixed = two_hurst.copy(deep=True)
    mixed["area_fraction"].loc[{"model": "elastic", "hurst": 0.5}] = float("nan")
    mixed["area_fraction"].loc[{"model": "bearing", "hurst": 0.8}] = float("nan")
    assert len(_rows(flow_isotropic.draw(mixed))) == 1


def test_a_model_that_did_not_run_a_rows_values_leaves_its_panel_empty(two_hurst):
    from roughflow.figures import flow_isotropic

    ds = two_hurst.copy(deep=True)
    ds["area_fraction"].loc[{"model": "bearing", "hurst": 0.5}] = float("nan")
    (first, second) = flow_isotropic.draw(ds).subfigs
    assert not first.axes[1].axison
    assert [t.get_text() for t in first.axes[1].texts] == ["bearing: not run\nat these values"]
    assert second.axes[1].axison


def test_flow_rows():
    from roughflow.scenes.expand import flow_rows

    # per model, its (gamma, H, L/lambda_r, eps_f): a parameter that varies within a model
    # sets the rows; sizes that differ between models only (one each) do not
    assert flow_rows({"elastic": [(1, 0.8, 16, 0.0625)],
                      "bearing": [(1, 0.8, 8, 0.0625)]}) == ((), [()])
    assert flow_rows({"elastic": [(2, 0.8, 16, 0.0625), (4, 0.8, 16, 0.0625)],
                      "bearing": [(2, 0.8, 8, 0.0625)]}) == ((0,), [(2,), (4,)])


@pytest.mark.parametrize("name, sweep, n", [
    ("flow_anisotropic", {"gamma": [2, 4]}, 2),
    ("flow_isotropic", {"hurst": [0.5, 0.8], "model": ["elastic", "bearing"]}, 4),
    ("flow_isotropic", {"l_over_lambda_r": [4, 8]}, 2),
    ("flow_isotropic", {"eps_f": [0.25, 0.125]}, 2),
])
def test_a_flow_study_may_sweep(name, sweep, n):
    assert len(expand_study(name, {**_LADDER, **sweep})) == n


def test_a_flow_figure_of_too_many_rows_is_refused_at_planning():
    from roughflow.scenes.expand import FLOW_FIGURE_MAX_ROWS

    hurst = [round(0.1 + 0.05 * i, 2) for i in range(FLOW_FIGURE_MAX_ROWS + 1)]
    with pytest.raises(InputError, match=f"at most {FLOW_FIGURE_MAX_ROWS}; the study has "
                                         f"{FLOW_FIGURE_MAX_ROWS + 1}"):
        expand_study("flow_isotropic", {**_LADDER, "hurst": hurst})
    with pytest.raises(InputError, match="takes gamma = 1"):  # still the isotropic figure's
        expand_study("flow_isotropic", {**_LADDER, "gamma": [1, 2]})


def test_the_workflow_plans_a_flow_study_of_two_gammas(tmp_path):
    from test_workflow_config import SNAKEMAKE, dry_run, shell_commands, write_case
    from workflow_copy import copy_workflow

    if not SNAKEMAKE.exists():
        pytest.skip("snakemake not installed")
    wd = copy_workflow(tmp_path)
    write_case(wd, studies=("flow_anisotropic",))
    case = wd / "config" / "case.yaml"
    cfg = yaml.safe_load(case.read_text())
    cfg["studies"]["flow_anisotropic"]["gamma"] = [2, 4]
    case.write_text(yaml.safe_dump(cfg))
    run = dry_run(wd)
    assert run.returncode == 0, run.stderr[-2000:]
    output = run.stdout + run.stderr
    gammas = set()
    for cmd in shell_commands(output, "scene ladder"):
        gammas.add(float(cmd[cmd.index("--gamma") + 1]))
    assert gammas == {2.0, 4.0}
    assert "results/flow_anisotropic/figure.png" in output


def test_a_dataset_without_the_size_variable_gets_its_size_from_eps_t(two_hurst):
    # datasets from before l_over_lambda_r was written: the row values took eps_t itself
    # for L/lambda_r (0.5 here instead of 2)
    from roughflow.figures import _flow

    old = two_hurst.drop_vars("l_over_lambda_r")
    for model in ("elastic", "bearing"):
        assert (_flow._settings(old.sel(model=model))
                == _flow._settings(two_hurst.sel(model=model)))
