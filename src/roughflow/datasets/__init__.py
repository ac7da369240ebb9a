"""How roughflow's datasets look: units, coordinates and the builders of every dataset.

- :mod:`.units`: units strings and grid coordinates;
- :mod:`.results`: datasets of single results (contact, threshold, flow, Persson theory),
  used by the command line, the scenes and notebooks alike;
- :mod:`.leak`: the dataset of a leak question (``roughflow leak``, the measured study);
- :mod:`.sweep`: the layout of the sweep's per-job datasets and the values analyses read.
"""

from .leak import leak_dataset
from .results import (
    AXIS_COORD,
    contact_dataset,
    flow_dataset,
    persson_dataset,
    spec_attrs,
    threshold_dataset,
)

__all__ = ["AXIS_COORD", "contact_dataset", "flow_dataset", "leak_dataset", "persson_dataset",
           "spec_attrs", "threshold_dataset"]
