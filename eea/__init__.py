"""Estimation-Exploration Algorithm (EEA) for the self-modeling aquatic robot.

Reproduces Rose, Clark, Moore & McKinley, "Just Keep Swimming: Accounting for Uncertainty
in Self-Modeling Aquatic Robots" (ERLARS 2013), sections 3.2-3.4 and 4. The modules here
are pure NumPy; they take the robot's constants (morphology fields and bounds, servo
ranges, the caudal sweep) from ``aquafish_gym`` but never simulate:

* ``eea.encoding``  -- 45-bit model and 18-bit action genomes (section 3.2, Figure 4), and
  the model spaces: the paper's ``morphology`` or ``morphology+servos`` (57 bits: a gain per
  servo too; ``EEAConfig.model_space``, not the paper's).
* ``eea.ga``        -- generational bit-string GA with ask/tell (section 4).
* ``eea.cma_search`` -- CMA-ES over the nine dimensions with the same ask/tell: an
  optional estimation search (``estimation_search="cma"``), not the paper's.
* ``eea.model_search`` -- the ``ModelSearch`` protocol and the registry of searches by name.
* ``eea.behaviour`` -- DFT behaviour summaries and their similarity (equation 2).
* ``eea.fitness``   -- action, model and objective fitness (equations 1, 3, 4).
* ``eea.arc``       -- smallest inclusive arcs of initial angles (section 3.3).

On top of ``aquafish_gym.simulate_batch``:

* ``eea.experiment`` -- experiments on the target and their context (angle ranges).
* ``eea.target``     -- the simulated damaged robot, random initial angles per experiment.
* ``eea.evaluation`` -- batched, cached, parallel simulation of candidate models.
* ``eea.strategy``   -- the interface of a context inference strategy (hooks, order).
* ``eea.inference``  -- the paper's strategies: known, none, in_band, out_of_band, and the
  registry; ``eea.profile`` -- per-model angles (not the paper's).
* ``eea.exploration``, ``eea.estimation`` -- the two phases of a round (section 3.2);
  ``eea.lineages`` -- several independent estimations sharing each round's experiment, one
  selected per round (``lineages`` >= 2; not the paper's).
* ``eea.round``      -- ``run_round``: one round as one function, a frozen ``RoundRecord``.
* ``eea.config``     -- ``EEAConfig``, the paper's defaults (section 4).
* ``eea.run``        -- ``run(config, out_dir)``: a resumable run of rounds; ``eea.record``
  writes and reads it back (``round_row``, ``load_result``), ``eea.checkpoint`` saves its
  state, ``eea.analysis.plot`` draws studies, ``eea.analysis.diagnosis`` tells a search failure from an
  inference failure.
"""

from eea.arc import in_arc, sample_arc, smallest_inclusive_arc, smallest_inclusive_interval
from eea.arc import widen_arc
from eea.behaviour import CHANNELS, MAX_COEFFICIENT, behaviour_summary, similarity
from eea.encoding import ACTION_BITS, ACTION_FIELD_BITS, MODEL_BITS, MODEL_FIELD_BITS
from eea.encoding import decode_actions, decode_fields, decode_models
from eea.encoding import encode_actions, encode_fields, encode_models
from eea.encoding import MODEL_SPACES, ModelSpace, get_model_space
from eea.fitness import action_fitness, model_fitness, objective_fitness
from eea.ga import BitGA
from eea.cma_search import CMAModelSearch
from eea.config import EEAConfig
from eea.estimation import Estimation, EstimationResult
from eea.evaluation import Evaluator
from eea.experiment import Context, Experiment
from eea.exploration import Exploration
from eea.lineages import LineageStrategies, Lineages
from eea.inference import INFERENCE_NAMES, INFERENCE_STRATEGIES, InferenceStrategy, make_inference
from eea.model_search import MODEL_SEARCHES, ModelGA, ModelSearch, make_model_search
from eea.record import ROUND_COLUMNS, RunResult, load_result
from eea.round import RoundParts, RoundRecord, run_round
from eea.run import run
from eea.target import Target
