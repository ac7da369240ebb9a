"""A temporary copy of the workflow, as a user's fresh checkout has it (shared by the
workflow and SLURM tests)."""

from __future__ import annotations

import shutil
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: What a workflow run reads: tests/data holds the scan of config/test.yaml's measured study.
WORKFLOW_PARTS = ("Snakefile", "workflow", "config", "profiles", "tests/data")


def copy_workflow(dest: Path) -> Path:
    """Copy :data:`WORKFLOW_PARTS` into ``dest`` and return it."""
    for name in WORKFLOW_PARTS:
        src = ROOT / name
        if src.is_dir():
            shutil.copytree(src, dest / name)
        else:
            shutil.copy(src, dest / name)
    return dest
