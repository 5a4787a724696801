"""Fixtures for the gait tests."""

import pytest
from gait_helpers import random_controller

from gait import NEATController


@pytest.fixture
def controller() -> NEATController:
    """A random (untrained) NEAT controller; deterministic across test runs."""
    return random_controller(seed=7)
