# SPDX-License-Identifier: Apache-2.0
"""The fuzzing budget and seed shared by tests/*/test_fuzz_*.py.

CI runs a fixed seed and a small budget (the whole fuzz suite in ~30-40 s on 2 cores). A long
run multiplies the number of examples and picks its own seed:

    PHONGSCENE_FUZZ_BUDGET=50 PHONGSCENE_FUZZ_SEED=7 .venv/bin/python -m pytest tests/*/test_fuzz_*.py

The Hypothesis database is off, so a run never writes into the tree; a failure prints the
example, and the same seed and budget reproduce it."""

from __future__ import annotations

import os

from hypothesis import HealthCheck, Phase, settings

BUDGET = max(1, int(os.environ.get("PHONGSCENE_FUZZ_BUDGET", "1")))
SEED = int(os.environ.get("PHONGSCENE_FUZZ_SEED", "20261201"))


def fuzz_settings(examples: int) -> settings:
    """Hypothesis settings for ``examples`` examples per unit of budget: no deadline (POV-Ray and
    child processes take seconds on a loaded machine), no database, and no health check on slow
    data generation (a scene or a mutated file is drawn in one go). Shrinking is off."""
    return settings(
        max_examples=examples * BUDGET,
        deadline=None,
        database=None,
        derandomize=False,
        # No shrinking: each example costs child processes or POV-Ray runs, and shrinking took
        # over five minutes; the first failing example is printed as it is, and reproduces.
        phases=[Phase.explicit, Phase.reuse, Phase.generate],
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
    )
