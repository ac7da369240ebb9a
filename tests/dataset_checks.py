"""Checks of the datasets roughflow writes, shared by the tests of the CLI and the workflow."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr


def assert_yes_no_variables_are_flagged(path: str | Path) -> None:
    """Every integer variable of the file at ``path`` that codes a yes/no ("1 if",
    "1 where", "1:", "mask (1 = ...", "(1/0)") carries CF ``flag_values`` 0, 1 of its own
    stored dtype and one ``flag_meanings`` word per value, and holds no value but those and
    its fill value.
    Read undecoded: xarray turns an integer variable with a fill value into floats."""
    with xr.open_dataset(path, mask_and_scale=False) as ds:
        for name, v in ds.variables.items():
            text = str(v.attrs.get("long_name", ""))
            if v.dtype.kind != "i" or not (text.startswith(("1 if", "1 where", "1:"))
                                           or "(1 =" in text or "(1/0)" in text):
                continue
            where = f"{Path(path).name}: {name}"
            assert "flag_values" in v.attrs, where
            values = np.atleast_1d(v.attrs["flag_values"])
            assert values.dtype == v.dtype, (where, values.dtype, v.dtype)
            assert list(values) == [0, 1], where
            assert len(str(v.attrs["flag_meanings"]).split()) == 2, where
            fill = v.attrs.get("_FillValue")
            allowed = {0, 1} | (set() if fill is None else {int(fill)})
            assert set(np.unique(v.values).tolist()) <= allowed, where
