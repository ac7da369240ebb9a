"""``roughflow aggregate``: combine per-job datasets into one study dataset."""

from __future__ import annotations

import argparse

from roughflow.defaults import JOB_KINDS

from ._common import add_input, add_output


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "aggregate", help="combine per-job netCDF files into one study dataset",
        description="Combine per-job datasets by their coordinates (outer join): missing jobs "
                    "stay NaN, integer variables keep the fill value -1.")
    add_input(p, "inputs", kinds=JOB_KINDS, what="job file", nargs="+",
              metavar="JOB.nc", help="per-job datasets (roughflow scene threshold or ladder, "
                                     "or roughflow leak)")
    p.add_argument("--study", default=None, help="study name stored as an attribute")
    p.add_argument("--study-config", default=None, metavar="JSON",
                   help="the study's config block (JSON), stored as the study_config "
                        "attribute (the workflow passes it)")
    add_output(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> None:
    import json
    from dataclasses import replace

    from roughflow.aggregate import aggregate
    from roughflow.errors import InputError

    provenance = args.provenance
    if args.study_config is not None:
        try:
            config = json.loads(args.study_config)
        except json.JSONDecodeError as exc:
            raise InputError(f"--study-config is not JSON: {exc}") from None
        if not isinstance(config, dict):  # a study's block is a mapping of its keys
            raise InputError(f"--study-config must be a JSON object, got {args.study_config!r}")
        provenance = replace(provenance, study_config=json.dumps(config, sort_keys=True))
    aggregate(args.data["inputs"], args.output, study=args.study,
              sources=[repr(p) for p in args.inputs], provenance=provenance)
