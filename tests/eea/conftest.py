"""Shared fixtures of the EEA tests: tiny configs and experiments that run in milliseconds."""

import numpy as np
import pytest

from eea.behaviour import behaviour_summary
from eea.config import EEAConfig
from eea.experiment import Context, Experiment

#: A run small enough for the default test suite (~0.1-0.3 s per round on one core), in deep
#: water: the physics the golden rounds were recorded with (tests of the surface say so).
TINY = dict(duration_s=0.16, rounds=2, exploration_population=4, exploration_generations=2, exploration_models=3,
            estimation_population=5, estimation_generations=3, k_best=2, oob_period=2, oob_sample=2,
            oob_population=4, oob_generations=2, workers=1, waterline=None)


def _tiny(**changes):  # TINY's fields apply where the config holds their section, as a budget's
    return EEAConfig.from_flat(changes, optional=TINY)


@pytest.fixture
def tiny_config():
    return _tiny


@pytest.fixture(scope="session")
def session_tiny_config():
    """:func:`tiny_config` for fixtures wider than a test."""
    return _tiny


def _make_experiment(index, action=(0.3, -0.2, 0.8), true_angles=(1.0, 2.0, 0.1), steps=16, context=None, seed=0):
    log = np.random.default_rng(seed + index).normal(0, 3, (steps, 3))
    true = np.asarray(true_angles, dtype=float)
    return Experiment(index, np.asarray(action, dtype=float), log, behaviour_summary(log), true,
                      context if context is not None else Context.exact(true))


@pytest.fixture
def make_experiment():
    """Factory of experiments with a synthetic (random) target log, for evaluator bookkeeping."""
    return _make_experiment


class SimulatorSpy:
    """Wraps simulate_batch and records every call's inputs (as copies)."""

    def __init__(self, real):
        self.real, self.calls = real, []

    def __call__(self, morphologies, actions, initial_angles, steps, **kw):
        self.calls.append({"morphologies": np.array(morphologies), "actions": np.array(actions),
                           "initial_angles": np.array(initial_angles), "steps": steps, **kw})
        return self.real(morphologies, actions, initial_angles, steps, **kw)

    @property
    def robots(self):
        return sum(len(c["morphologies"]) for c in self.calls)


@pytest.fixture
def simulator_spy(monkeypatch):
    """Spy on the simulator calls of eea.evaluation (models; workers=1 runs them in-process)."""
    import eea.evaluation

    spy = SimulatorSpy(eea.evaluation.simulate_batch)
    monkeypatch.setattr(eea.evaluation, "simulate_batch", spy)
    return spy


@pytest.fixture(scope="session")
def lph_experiments():
    """Two real 0.64 s experiments on left_pectoral_half from random initial angles (the fits
    under test never see the true angles; their contexts say 0 rad)."""
    from eea.target import Target

    target = Target("left_pectoral_half", 64, np.random.default_rng(5))
    exps = []
    for i, action in enumerate([(0.45, -0.3, 0.6), (-0.4, 0.5, 0.2)]):
        log, true = target.perform(np.array(action))
        exps.append(Experiment(i, np.array(action), log, behaviour_summary(log), true, Context.exact(np.zeros(3))))
    return exps
