"""``roughflow fit``: finite-size-scaling fits of a threshold study (paper Fig. 3)."""

from __future__ import annotations

import argparse

from roughflow.defaults import FIT_BOOTSTRAP, NU_PERCOLATION

from ._common import add_input, add_output


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "fit", help="finite-size-scaling fits a_c*(eps) = a_c* + A eps^(1/nu)",
        description="Fit a_c*(eps) = a_c* + A eps^(1/nu) to a threshold study dataset: per "
                    "direction and jointly (shared a_c*), with nu fixed and free, bootstrap "
                    "errors over seeds. Writes a netCDF dataset over (group, fit, nu_mode).")
    add_input(p, "dataset", kinds="threshold_study", what="study dataset",
              metavar="DATASET.nc", help="aggregated threshold dataset (roughflow aggregate)")
    p.add_argument("--bootstrap", type=int, default=FIT_BOOTSTRAP,
                   help=f"bootstrap resamples over seeds ({FIT_BOOTSTRAP}; 0 = none)")
    p.add_argument("--nu", type=float, default=NU_PERCOLATION,
                   help=f"fixed exponent nu ({NU_PERCOLATION:.6g}: 4/3, 2D percolation)")
    p.add_argument("--seed", type=int, default=0, help="seed of the bootstrap (0)")
    add_output(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> None:
    from dataclasses import replace

    from roughflow.fits import fit_dataset
    from roughflow.io import write_dataset
    from roughflow.provenance import settings_of_inputs

    ds = args.data["dataset"]
    res = fit_dataset(ds, n_boot=args.bootstrap, nu=args.nu, seed=args.seed)
    provenance = replace(args.provenance.using("scaling"),
                         study_config=str(ds.attrs.get("study_config", "")),
                         from_inputs=settings_of_inputs(ds))
    write_dataset(res, args.output, provenance=provenance)
