"""Estimation-Exploration Algorithm (EEA) for the self-modeling aquatic robot.

Reproduces Rose, Clark, Moore & McKinley, "Just Keep Swimming: Accounting for Uncertainty
in Self-Modeling Aquatic Robots" (ERLARS 2013), sections 3.2-3.4 and 4. The algorithm is
pure NumPy; it takes the robot's constants (morphology fields and bounds, servo ranges, the
caudal sweep) from ``aquafish_gym`` and simulates only through ``aquafish_gym.simulate_batch``.

The layout (``tests/eea/test_layering.py`` checks it)::

    eea/                     the paper's core, at the top
      encoding.py              45-bit model and 18-bit action genomes (3.2, Figure 4); the model
                               spaces: ``morphology`` or ``morphology+servos`` (57 bits, not the paper's)
      ga.py                    the paper's bit-string GA with ask/tell (section 4): exploration,
                               the estimation's model GA and out-of-band inference all evolve with it
      behaviour.py             DFT behaviour summaries and their similarity (eq. 2)
      fitness.py               action, model and objective fitness (eqs. 1, 3, 4)
      identification.py        does a model name the truth's faulty servos (not the paper's)
      arc.py                   smallest inclusive arcs of initial angles (3.3)
      diversity.py             distances between model genomes, diverse selections (not the paper's)
      experiment.py            experiments on the target and their context (angle ranges)
      target.py                the simulated damaged robot, random initial angles per experiment
      evaluation.py            batched, cached, parallel simulation of candidate models
      exploration.py           the exploration phase (3.2)
      estimation.py            the estimation phase (3.2), over a model search and a strategy
      round.py                 ``run_round``: one round as one function, a frozen ``RoundRecord``
      config.py, methods.py    ``EEAConfig`` and its sections' one flat-name table, the paper's
                               defaults (4); named methods and budgets
      run.py                   ``run(config, out_dir)``: a resumable run of rounds
      record.py                rounds.csv / config.json written and read back (``load_result``)
      checkpoint.py            the run's state.pkl, and its run_data.npz (no pickle)
      compat.py                what lets runs written by earlier versions load: flat configs,
                               retired fields, moved modules, older checkpoints' states
      replay.py, cli.py        a finished run's experiments rebuilt; the ``aquafish eea`` command
      search/                  the estimation's model searches
        registry.py              the ``ModelSearch`` protocol and the searches by name
        model_ga.py              ``ModelGA``: the paper's GA over model genomes
        cma.py                   ``CMAModelSearch``: CMA-ES over the dimensions (not the paper's)
        lineages.py              N estimations sharing each experiment, one selected per round
                                 (``lineages`` >= 2; not the paper's)
      inference/               context inference: which initial angles the models start from
        strategy.py              the ``InferenceStrategy`` interface (hooks, their order)
        paper.py                 the paper's strategies: known, none, in_band, out_of_band
        profile.py               ``Profile``: per-model angles and their fit (not the paper's)
        registry.py              the strategies by name (``make_inference``)
        selection.py             the equal angle fit that picks one model among candidates
      analysis/                studies of finished runs: plot, compare, diagnosis,
                               lineage report (nothing but the command lines imports it)

The core imports a subpackage only through its face (``eea.search``, ``eea.inference``: the
registries and the interfaces), and the round (and run) import ``eea.search.lineages``, the
estimation phase of a lineage run. ``eea.inference`` imports only the core;
``eea.search`` the core, and its lineages ``eea.inference``.
"""

from importlib.metadata import PackageNotFoundError as _PackageNotFoundError
from importlib.metadata import version as _version

try:  # the installed distribution's version (pyproject.toml); the same in the four packages
    __version__: str = _version("aquafish")
except _PackageNotFoundError:  # run from a source tree that is not installed
    __version__ = "0+unknown"

from eea.arc import in_arc, sample_arc, smallest_inclusive_arc, smallest_inclusive_interval
from eea.arc import widen_arc
from eea.behaviour import (CHANNELS, MAX_COEFFICIENT, MAX_COEFFICIENTS, angular_rates, behaviour_summary, similarity,
                           summarise)
from eea.encoding import ACTION_BITS, ACTION_FIELD_BITS, MODEL_BITS, MODEL_FIELD_BITS
from eea.encoding import decode_actions, decode_fields, decode_models
from eea.encoding import encode_actions, encode_fields, encode_models
from eea.encoding import MODEL_SPACES, ModelSpace, get_model_space
from eea.fitness import action_fitness, model_fitness, objective_fitness
from eea.ga import BitGA
from eea.search.cma import CMAModelSearch
from eea.config import EEAConfig
from eea.estimation import Estimation, EstimationResult
from eea.evaluation import Evaluator
from eea.experiment import Context, Experiment
from eea.exploration import Exploration
from eea.search.lineages import LineageStrategies, Lineages
from eea.inference import INFERENCE_NAMES, INFERENCE_STRATEGIES, InferenceStrategy, make_inference
from eea.search import MODEL_SEARCHES, ModelGA, ModelSearch, make_model_search
from eea.record import ROUND_COLUMNS, RunResult, load_experiments, load_result, save_experiments
from eea.round import RoundParts, RoundRecord, run_round
from eea.run import run
from eea.target import Target
