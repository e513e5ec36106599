"""Re-export of :mod:`fcsweep.model.observables` (the declared observable table moved
beside the parameter table, where every layer may read it)."""

from fcsweep.model.observables import *  # noqa: F401,F403
from fcsweep.model.observables import (CURVES, KINDS, LABELS, OBSERVABLES, REPLICATE_REDUCED, RUN_SCALARS,  # noqa: F401
                                       TEXTS, UNTIL_OBSERVABLES, Observable, markdown_table)
