"""Compare two results folders in every data variable of every netCDF file.

    python workflow/scripts/compare_results.py OLD_RESULTS NEW_RESULTS

Reports, per file, "identical" or the variables that differ (largest absolute difference),
and the number of files with differences. ``wall_time`` and all attributes (provenance:
version, command, creation date, history; roughflow.provenance.PROVENANCE_ATTRS) are
ignored: they differ between any two runs. Used to check that a change keeps the results
of config/test.yaml.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import xarray as xr

IGNORED = ("wall_time",)


def differences(a: xr.Dataset, b: xr.Dataset) -> list[str]:
    out = []
    for name in sorted(set(a.variables) | set(b.variables)):
        if name in IGNORED:
            continue
        if name not in a.variables or name not in b.variables:
            out.append(f"{name}: only in {'new' if name in b.variables else 'old'}")
            continue
        va, vb = a[name].values, b[name].values
        if va.shape != vb.shape or a[name].dims != b[name].dims:
            out.append(f"{name}: shape {va.shape} vs {vb.shape}")
        elif va.dtype.kind in "fc":
            if not np.array_equal(va, vb, equal_nan=True):
                both = np.isfinite(va) & np.isfinite(vb)
                d = float(np.abs(va - vb)[both].max()) if both.any() else float("nan")
                nan = int((np.isnan(va) != np.isnan(vb)).sum())
                out.append(f"{name}: max |diff| {d:.3g}, NaN in one only: {nan}")
        elif not np.array_equal(va, vb):
            out.append(f"{name}: differs")
    return out


def main(old: str, new: str) -> int:
    old_root, new_root = Path(old), Path(new)
    files = sorted(p.relative_to(old_root) for p in old_root.rglob("*.nc"))
    bad = 0
    for rel in files:
        if not (new_root / rel).exists():
            print(f"{rel}: missing in {new}")
            bad += 1
            continue
        with xr.open_dataset(old_root / rel) as a, xr.open_dataset(new_root / rel) as b:
            diff = differences(a, b)
        bad += bool(diff)
        print(f"{rel}: {'; '.join(diff) if diff else 'identical'}")
    print(f"{len(files)} files, {bad} with differences")
    return int(bad > 0)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("old", help="results folder of the reference run")
    parser.add_argument("new", help="results folder of the run to check")
    args = parser.parse_args()
    sys.exit(main(args.old, args.new))
