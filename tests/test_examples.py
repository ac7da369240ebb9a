"""The example notebooks run from top to bottom (so that they cannot rot), in a fresh
Jupyter kernel, the way a user opens them."""

from __future__ import annotations

from pathlib import Path

import pytest

nbformat = pytest.importorskip("nbformat")
nbclient = pytest.importorskip("nbclient")

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


@pytest.mark.slow
def test_quickstart_notebook_runs_and_draws(monkeypatch):
    nb = nbformat.read(EXAMPLES / "quickstart.ipynb", as_version=4)
    source = "\n".join(c.source for c in nb.cells if c.cell_type == "code")
    # it shows the library's own dataset builders and theory, not private copies
    for name in ("datasets.contact_dataset", "datasets.threshold_dataset",
                 "datasets.flow_dataset", "theory.gap_theory", "search.threshold"):
        assert name in source, name
    # the kernel's own (inline) backend: the library must not need or force one
    monkeypatch.delenv("MPLBACKEND", raising=False)
    nbclient.NotebookClient(nb, timeout=600, kernel_name="python3",
                            resources={"metadata": {"path": str(EXAMPLES)}}).execute()
    outputs = [o for c in nb.cells if c.cell_type == "code" for o in c.outputs]
    assert not [o for o in outputs if o.output_type == "error"]
    images = [o for o in outputs if "image/png" in o.get("data", {})]
    assert len(images) == 3  # height map, flux fields, sigma(a_c) against the theory
    text = "".join(o.get("text", "") for o in outputs)
    # log_progress shows the threshold search's solves as they happen
    assert "threshold (elastic) solve" in text
