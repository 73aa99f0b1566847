"""Shared control fixtures: teachbot6's inertia range and its tuned gains (default spec)."""

from __future__ import annotations

import pytest

from armlab.control import inertia_range, tune_arm


@pytest.fixture(scope="session")
def inertias(teachbot6):
    return inertia_range(teachbot6, n_samples=200, seed=0)


@pytest.fixture(scope="session")
def arm_gains(teachbot6):
    return tune_arm(teachbot6, n_inertia_samples=200)
