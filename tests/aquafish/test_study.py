"""Studies: independent resumable runs, skipping finished ones, local and Ray backends."""

import csv
import json
from pathlib import Path

import numpy as np
import pytest

from aquafish.cli import main
from aquafish.study import StudySpec, rounds_done, run_pending, run_study
from eea.config import FLAT_DEFAULTS, EEAConfig
from eea.analysis.plot import find_runs, summarise_runs

#: A study's base is flat (the flags' names): every strategy's settings, each run keeps its own.
TINY = dict(rounds=2, exploration_population=3, exploration_generations=1, exploration_models=2,
            estimation_population=4, estimation_generations=2, k_best=2, oob_period=1, oob_sample=2,
            oob_population=2, oob_generations=1, workers=1)


def tiny_spec(**kw):
    args = dict(conditions=("known", "none"), durations_s=(0.16,), replicates=2, base=TINY)
    args.update(kw)
    return StudySpec(**args)


def test_spec_lists_every_run_with_its_seed(tmp_path):
    runs = tiny_spec(durations_s=(0.16, 0.32)).runs(tmp_path)
    assert len(runs) == 2 * 2 * 2
    assert [c.seed for c, _ in runs] == [0, 0, 0, 0, 1, 1, 1, 1]  # replicate-major: conditions progress together
    assert [(c.inference.name, c.duration_s) for c, _ in runs[:4]] == [("known", 0.16), ("known", 0.32), ("none", 0.16),
                                                                       ("none", 0.32)]
    config, path = runs[-1]
    assert (config.inference.name, config.duration_s, config.seed) == ("none", 0.32, 1)
    assert path == tmp_path / "none" / "0.32s" / "seed1"


@pytest.mark.parametrize("kw, match", [({"conditions": ("telepathy",)}, "inference"), ({"replicates": 0}, "replicates"),
                                       ({"durations_s": ()}, "durations"), ({"conditions": ("none", "none")}, "repeats")])
def test_bad_spec_raises(kw, match):
    with pytest.raises(ValueError, match=match):
        tiny_spec(**kw)


def test_an_unknown_backend_is_refused_by_name_before_anything_is_written(tmp_path):
    from aquafish.backends import run_tasks
    from aquafish.recovery import run_recovery

    for call in (lambda: run_study(tiny_spec(), tmp_path / "s", backend="slurm"),
                 lambda: run_recovery(tmp_path / "r", preset="smoke", damages=["caudal_half"], backend="slurm"),
                 lambda: list(run_tasks([(abs, (-1,))], backend="slurm"))):
        with pytest.raises(ValueError, match=r"backend must be one of \('local', 'ray'\), got 'slurm'"):
            call()
    assert list(tmp_path.iterdir()) == []


def test_each_run_keeps_the_settings_of_its_own_strategy_and_a_given_one_must_be_used():
    spec = tiny_spec(conditions=("known", "out_of_band", "in_band"))
    known, oob, in_band = (c for c, _ in spec.runs(".")[:3])
    assert known.to_dict()["inference"] == {"name": "known"}                # the base's oob_* are not the known runs'
    assert (oob.inference.period, oob.inference.sample, in_band.inference.k_best) == (1, 2, 2)
    one = {k: v for k, v in TINY.items() if k != "k_best"}
    assert tiny_spec(base=EEAConfig.from_flat(one)).base == tiny_spec(base=one).base   # a config: its flat fields
    with pytest.raises(ValueError, match="no run of the study uses EEAConfig.oob_period = 1"):
        tiny_spec(fixed=("oob_period",))                                  # given beside methods that never use it
    tiny_spec(conditions=("known", "out_of_band"), fixed=("oob_period",))   # one of them does
    with pytest.raises(ValueError, match="unknown EEAConfig keys \\['oob_periods'\\]"):
        tiny_spec(base={**TINY, "oob_periods": 3})


def test_local_study_runs_skips_finished_and_plots(tmp_path):
    spec = tiny_spec()
    dirs = run_study(spec, tmp_path, processes=2, progress=False)
    assert len(dirs) == 4 and all(rounds_done(d) == TINY["rounds"] for d in dirs)
    stamps = [(d / "rounds.csv").stat().st_mtime_ns for d in dirs]
    run_study(spec, tmp_path, processes=2, progress=False)  # everything finished: nothing re-run
    assert [(d / "rounds.csv").stat().st_mtime_ns for d in dirs] == stamps
    with pytest.raises(ValueError, match="different study"):
        run_study(tiny_spec(conditions=("known",)), tmp_path, progress=False)
    with pytest.raises(ValueError, match="different study"):
        run_study(tiny_spec(base={**TINY, "rounds": 3}), tmp_path, progress=False)

    summary = summarise_runs(find_runs([tmp_path]))
    assert sorted(summary) == [("known", 0.16), ("none", 0.16)]
    for (inference, duration), s in summary.items():
        runs = [d for d in dirs if d.parts[-3] == inference]
        values = np.array([[float(r["objective_fitness"]) for r in csv.DictReader((d / "rounds.csv").open())] for d in runs])
        np.testing.assert_allclose(s.mean, values.mean(axis=0))
        np.testing.assert_allclose(s.std, values.std(axis=0))
    assert json.loads((tmp_path / "study.json").read_text())["seeds"] == [0, 1]
    assert main(["plot", str(tmp_path)]) == 0
    assert (tmp_path / "objective_fitness.png").stat().st_size > 1000


def test_a_finished_servo_run_whose_check_is_stale_is_checked_again_and_nothing_else(tmp_path):
    from eea.fault_check import FAULT_CHECK_FILE, FAULT_CHECK_PROCEDURE

    spec = tiny_spec(conditions=("known",), replicates=1, base={**TINY, "model_space": "morphology+servos",
                                                                "damage": "reversed_left_pectoral"})
    (config, run_dir), = spec.runs(tmp_path)
    assert run_pending(config, run_dir)  # not started
    run_study(spec, tmp_path, processes=1, progress=False)
    record = json.loads((run_dir / FAULT_CHECK_FILE).read_text())
    assert not run_pending(config, run_dir) and record["procedure"] == FAULT_CHECK_PROCEDURE
    rounds = (run_dir / "rounds.csv").read_text()
    # a record made before checks named their procedure (or by another one) is stale
    (run_dir / FAULT_CHECK_FILE).write_text(json.dumps({k: v for k, v in record.items() if k != "procedure"}))
    assert run_pending(config, run_dir)
    run_study(spec, tmp_path, processes=1, progress=False)
    again = json.loads((run_dir / FAULT_CHECK_FILE).read_text())
    assert again["procedure"] == FAULT_CHECK_PROCEDURE and again["models"] == record["models"]
    assert (run_dir / "rounds.csv").read_text() == rounds and not run_pending(config, run_dir)
    # a published run (no checkpoint) cannot be checked: the study leaves it as it is
    (run_dir / FAULT_CHECK_FILE).unlink()
    (run_dir / "state.pkl").unlink()
    assert not run_pending(config, run_dir)
    run_study(spec, tmp_path, processes=1, progress=False)
    assert (run_dir / "rounds.csv").read_text() == rounds and not (run_dir / FAULT_CHECK_FILE).exists()


@pytest.mark.cluster
def test_ray_backend_gives_the_same_results_as_local(tmp_path):
    ray = pytest.importorskip("ray")
    spec = tiny_spec(conditions=("none",), replicates=2)
    run_study(spec, tmp_path / "local", processes=1, progress=False)
    try:
        ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
        run_study(spec, tmp_path / "ray", backend="ray", progress=False)
    finally:
        ray.shutdown()
    for seed in range(2):
        rows = [list(csv.DictReader((tmp_path / b / "none" / "0.16s" / f"seed{seed}" / "rounds.csv").open())) for b in ("local", "ray")]
        for a, b in zip(*rows):
            a.pop("wall_seconds"), b.pop("wall_seconds")
            assert a == b


def test_more_replicates_extend_a_study_and_keep_its_finished_seeds(tmp_path):
    spec = tiny_spec(conditions=("none",), replicates=1)
    (first,) = run_study(spec, tmp_path, processes=1, progress=False)
    stamp = (first / "rounds.csv").stat().st_mtime_ns
    dirs = run_study(tiny_spec(conditions=("none",), replicates=2), tmp_path, processes=1, progress=False)
    assert dirs == [first, tmp_path / "none" / "0.16s" / "seed1"]
    assert (first / "rounds.csv").stat().st_mtime_ns == stamp            # seed 0 not run again
    assert rounds_done(dirs[1]) == TINY["rounds"]
    assert json.loads((tmp_path / "study.json").read_text())["seeds"] == [0, 1]
    run_study(spec, tmp_path, processes=1, progress=False)                 # a subset: nothing run, nothing rewritten
    assert json.loads((tmp_path / "study.json").read_text())["seeds"] == [0, 1]


def test_a_shard_of_later_seeds_runs_only_those_and_joins_the_study(tmp_path):
    spec = tiny_spec(conditions=("none",), replicates=2, first_seed=5)
    assert [c.seed for c, _ in spec.runs(tmp_path)] == [5, 6]
    (tmp_path / "study.json").write_text(json.dumps({            # a study written before first_seed existed
        "conditions": ["none"], "durations_s": [0.16], "replicates": 2,
        "base": {k: v for k, v in {**FLAT_DEFAULTS, **TINY}.items() if k != "workers"}}))   # flat, every field
    dirs = run_study(spec, tmp_path, processes=1, progress=False)
    assert dirs == [tmp_path / "none" / "0.16s" / f"seed{s}" for s in (5, 6)]
    assert all(rounds_done(d) == TINY["rounds"] for d in dirs)
    assert not (tmp_path / "none" / "0.16s" / "seed0").exists()
    assert json.loads((tmp_path / "study.json").read_text())["seeds"] == [0, 1, 5, 6]
    with pytest.raises(ValueError, match="first_seed"):
        tiny_spec(first_seed=-1)


def test_every_published_study_json_still_describes_its_study(tmp_path):
    """A study.json written before the sections (its base flat, retired fields at their defaults,
    no waterline in deep water) is the same study as the spec its own fields make: extending it
    is allowed. Left out: the studies that used a retired variant (they run at the commit
    docs/studies/retired_variants.md names), and those whose ``fixed`` names fields no method
    sets (written before ``fixed`` kept only the methods' fields)."""
    from aquafish.study import _write_spec
    from eea.compat import upgrade_flat_fields
    from eea.methods import METHODS

    method_keys = {k for m in METHODS.values() for k in m.fields}
    checked = 0
    for path in sorted((Path(__file__).parents[2] / "docs/results").glob("**/study.json")):
        study = json.loads(path.read_text())
        try:
            base = upgrade_flat_fields(study["base"])
        except ValueError as err:
            assert "retired variant" in str(err)
            continue
        if not set(study.get("fixed", ())) <= method_keys:
            continue
        seeds = study.get("seeds") or list(range(study["replicates"]))
        spec = StudySpec(study["conditions"], study["durations_s"], len(seeds), base, first_seed=min(seeds),
                         fixed=study.get("fixed", ()))
        out = tmp_path / str(checked)
        out.mkdir()
        (out / "study.json").write_text(path.read_text())
        _write_spec(spec, out)                                  # raises "describes a different study" otherwise
        checked += 1
    assert checked > 30
