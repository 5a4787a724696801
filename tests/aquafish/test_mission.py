"""``aquafish mission``: damage noticed while swimming, target experiments where the robot stands,
the EEA warm-started at the old self-model, a gait from the old population (aquafish.mission)."""

import json

import imageio.v3 as iio
import numpy as np
import pytest

from aquafish.cli import main
from aquafish.mission import (MISSION_PRESETS, NEW_GAIT_KINDS, STOP_ACTION, MissionTarget, _Mission, load_prior,
                              judge_recovery, make_prior, new_gait_kinds, run_mission, span_speed, stop_robot)
from aquafish.case_study import PRESETS
from aquafish.mission_cli import PRESET_NAMES
from gait import load_controller
from aquafish_gym import Morphology, get_damage, simulate_batch
from aquafish_gym.simulator import AT_REST
from eea.behaviour import behaviour_summary, similarity
from aquafish_gym.params import DT_S
import eea
from eea import EEAConfig
from eea.encoding import get_model_space
from eea.search.cma import CMAModelSearch
from eea.search.lineages import Lineages, make_estimation, warm_start
from gait.robots import Robot

SPACE = get_model_space("morphology+servos")
#: Every servo seized: the robot cannot swim, so the monitor must notice.
ALL_SEIZED = '{"seized": [true, true, true]}'


def _genome(damage="none"):
    return SPACE.encode(SPACE.truth(damage)[None])[0]


@pytest.fixture(scope="module")
def prior_dir(tmp_path_factory):
    """A smoke prior whose self-model is the true healthy robot (so the monitor's range is the
    real robot's and a healthy start does not alarm): its smoke gait and calibration."""
    d = tmp_path_factory.mktemp("prior")
    make_prior(d, _genome(), Robot(Morphology.healthy(), "none", "healthy"), "smoke", 0, workers=1,
               calibration_seeds=6, progress=False)
    return d


@pytest.fixture(scope="module")
def smoke_mission(prior_dir, tmp_path_factory):
    out = tmp_path_factory.mktemp("mission")
    report = run_mission(ALL_SEIZED, out, onset_s=8.0, duration_s=30.0, preset="smoke", seed=0,
                         self_model=prior_dir, workers=1, video=True, oracle=True, progress=False)
    return out, report


@pytest.mark.slow
def test_the_smoke_mission_writes_its_report_with_sane_relations(smoke_mission):
    out, report = smoke_mission
    assert json.loads((out / "mission.json").read_text()) == report
    for key in ("onset_s", "alarm_s", "recovered_s", "target_experiments", "compute_seconds", "speed_before",
                "speed_damaged", "speed_after", "oracle_speed", "damage", "seed", "preset", "heading"):
        assert key in report, key
    assert report["warm_start"] is True and report["preset"] == "smoke" and report["seed"] == 0
    assert report["self_model_fields"] == {}
    assert report["alarm_s"] is not None and report["alarm_s"] > report["onset_s"]
    assert report["recovered_s"] > report["alarm_s"]
    assert report["target_experiments"] == EEAConfig.from_method("profile_lineages", "smoke").rounds
    assert len(report["experiments"]) == report["target_experiments"]
    assert report["compute_seconds"] > 0
    assert report["speed_before"] > report["speed_damaged"]  # the seized robot slows down
    # the oracles swum from where the new gait started, over speed_after's span
    window = report["oracle_in_window"]
    assert window["after_s"] == pytest.approx(report["recovered_s"] + MISSION_PRESETS["smoke"].warmup_s)
    assert window["best"] == window["straight"] and "procedure" not in window   # no yardstick holds the procedure
    assert report["oracle_speed"] is not None and report["oracle"]["budget"]["runs"] >= 3
    assert min(report["oracle"]["seeds"]) > report["seed"] + 1000
    # the counterfactuals from the onset: carrying on, and the oracle from the alarm
    cf = report["counterfactuals"]
    assert cf["keep_old"]["start_s"] == pytest.approx(report["damage_in_force_s"])
    assert cf["oracle_at_alarm"]["start_s"] == pytest.approx(report["alarm_s"])
    assert report["recovered"] == judge_recovery(report["net_displacement"], report["final_speed"], cf)
    rows = [dict(zip(("time_s", "x", "y"), map(float, r.split(",")[:3])))
            for r in (out / "trajectory.csv").read_text().splitlines()[1:]]
    onset_row = min(rows, key=lambda r: abs(r["time_s"] - report["damage_in_force_s"]))
    assert report["net_displacement"] == pytest.approx(rows[-1]["y"] - onset_row["y"], abs=1e-9)
    # the new gait is the rehearsal's choice: the candidate that swam furthest from the robot's yaw
    rehearsal, smoke = report["rehearsal"], MISSION_PRESETS["smoke"]
    assert rehearsal["start_yaw_deg"] == report["robot_yaw_at_new_gait_deg"]
    assert set(rehearsal["kinds"]) == set(NEW_GAIT_KINDS)
    for kind in rehearsal["kinds"].values():
        assert len(kind["distances_units"]) == kind["candidates"] >= 1
        assert kind["chosen"] == int(np.argmax(kind["distances_units"]))
        assert len(kind["generations"]) == kind["candidates"] and kind["generations"] == sorted(kind["generations"])
        assert kind["generations"][0] == 0 and kind["generations"][-1] <= PRESETS[smoke.case_preset].gait_generations
    furthest = {k: max(v["distances_units"]) for k, v in rehearsal["kinds"].items()}
    assert furthest[rehearsal["kind"]] == max(furthest.values())  # the kind whose candidate went furthest
    assert (rehearsal["seconds"], rehearsal["draws"]) == (smoke.rehearsal_s, smoke.rehearsal_draws)
    assert (out / "timeline.png").stat().st_size > 0
    rows = (out / "trajectory.csv").read_text().splitlines()
    assert rows[0] == ("time_s,x,y,z,yaw_deg,speed_along_heading,phase,damaged,"
                       "left_pectoral_rad,right_pectoral_rad,caudal_rad")
    assert report["files"]["video"] in ("mission.mp4", "mission.gif")
    video = out / report["files"]["video"]
    assert iio.imread(video, index=0, **({"plugin": "FFMPEG"} if video.suffix == ".mp4" else {})).shape == (720, 1280, 3)
    assert {r.split(",")[6] for r in rows[1:]} == {"gait", "stop", "experiment", "new_gait"}
    assert float(rows[-1].split(",")[0]) == pytest.approx(30.0, abs=0.1)
    # what the robot knows afterwards: the model the report names and a gait that loads
    saved = json.loads((out / "recovered" / "self_model.json").read_text())
    values = SPACE.decode(np.asarray(saved["genome"], dtype=np.uint8)[None])[0]
    assert dict(zip(SPACE.fields, np.round(values, 4).tolist())) == report["self_model_after"]
    # the model the rounds' search ended on was checked against fault hypotheses about the design
    check = report["fault_check"]
    assert set(check["final_model"]) == set(SPACE.fields) and check["simulations"] > 0
    sims = report["simulations"]  # the recovery's model simulations, by stage
    assert sims["fault_check"] == check["simulations"] and sims["exploration"] > 0 and sims["estimation"] > 0
    assert (check["final_model"] != report["self_model_after"]) == check["replaced"]
    if check["replaced"]:  # a hypothesis about the design, or the found model with its gains polished
        kept = [report["self_model_after"][f] for f in SPACE.fields[:9]]
        found = [check["final_model"][f] for f in SPACE.fields[:9]]
        design = np.round(SPACE.truth("none")[:9], 4).tolist()
        assert kept == design or (check["polished"] and kept == found)
    assert report["files"]["recovered"] == "recovered"
    load_controller(out / "recovered")
    # the experiments the robot made where it stood, kept as data: the report's actions and angles
    experiments = eea.load_experiments(out / report["files"]["experiments"])
    assert len(experiments) == report["target_experiments"]
    for saved_one, reported in zip(experiments, report["experiments"]):
        np.testing.assert_allclose(saved_one.action, reported["action"], atol=5e-5)
        np.testing.assert_allclose(saved_one.true_angles, reported["true_initial_angles_rad"], atol=5e-5)
        assert saved_one.imu_log.shape == (round(report["experiment_s"] / DT_S), 3)


@pytest.mark.slow
def test_the_experiments_start_where_the_robot_stopped_not_at_the_origin(smoke_mission):
    out, report = smoke_mission
    rows = [r.split(",") for r in (out / "trajectory.csv").read_text().splitlines()[1:]]
    first = next(i for i, r in enumerate(rows) if r[6] == "experiment")
    stopped = np.array([float(v) for v in rows[first - 1][1:4]])  # the last sample before it: the stop's end
    start = np.array(report["experiments"][0]["start_position"])
    np.testing.assert_allclose(start, stopped, atol=1e-4)
    assert np.linalg.norm(start[:2]) > 0.5  # it swam away from the origin before the damage


class _Sweep:
    """A controller of fixed commands that change with its own time: a gait's interface."""

    def reset(self):
        pass

    def act(self, obs, t):
        return np.array([np.sin(t), np.cos(0.7 * t), 0.5 + 0.5 * np.sin(2 * t)])


def test_a_gait_swum_from_a_snapshot_is_the_missions_own_continuation():
    mission = _Mission("reversed_left_pectoral", 1.0, 20.0, seed=2)
    try:
        for _ in range(25):
            mission.step([0.0, 0.3, 1.0], "gait")
        assert mission.damaged
        snapshot = mission.snapshot()
        sweep = _Sweep()
        while mission.time_s < 6.0 - 1e-9:  # the mission goes on from the snapshot
            mission.step(sweep.act(mission.obs, mission.time_s - snapshot.time_s), "new_gait")
        own = [dict(r) for r in mission.rows]
        again = mission.swim_from(snapshot, sweep, 6.0, "new_gait")
        assert mission.rows == own  # the mission's record is left alone
        assert again == own[snapshot.rows - 1:]  # to the bit: positions, headings, flipper angles
        other = mission.swim_from(snapshot, _Sweep(), 4.0, "oracle")
        assert other[0] == own[snapshot.rows - 1] and other[-1]["time_s"] == pytest.approx(4.0)
        assert span_speed(again, 3.0) == span_speed(own, 3.0)
    finally:
        mission.env.close()


def test_target_experiments_run_in_the_mission_world_from_the_current_state():
    mission = _Mission("none", None, 20.0, seed=3)
    try:
        for _ in range(30):  # swim straight for 3 s: caudal at 1 Hz
            mission.step([0.0, 0.0, 1.0], "gait")
        stop_robot(mission, 3.0)
        stopped, t_stop = mission.position(), mission.time_s
        angles = mission.world.joint_angles()[0]
        target = MissionTarget(mission, "none", steps=50, stop_max_s=1.0)
        imu, true = target.perform(np.array([0.2, -0.2, 0.5]))
        np.testing.assert_allclose(target.starts[0], stopped)
        assert np.linalg.norm(stopped[:2]) > 0.1  # not the origin
        assert imu.shape == (50, 3) and abs(imu[0, 2]) < 5.0  # yaw relative to the start's
        np.testing.assert_allclose(true[:2], np.mod(angles[:2], 2 * np.pi), atol=1e-5)
        assert mission.time_s >= t_stop + 0.5 - 1e-9  # the experiment's simulated time is the mission's
        assert [r["phase"] for r in mission.rows].count("experiment") == 5
        # the models start from what the IMU measured: the healthy robot's simulation from that
        # motion explains the experiment better than one from rest
        motion = target.start_motion
        assert not np.array_equal(motion, AT_REST) and np.linalg.norm(motion[4:]) > 1e-3
        healthy = get_damage("none").apply().to_array()[None]
        sims = [similarity(behaviour_summary(simulate_batch(healthy, [[0.2, -0.2, 0.5]], true[None], 50,
                                                            start_motion=m)[0]), behaviour_summary(imu))
                for m in (None, motion[None])]
        assert sims[1] > sims[0]
    finally:
        mission.env.close()


def test_stop_action_is_zero_pectoral_speed_and_no_caudal_sweep():
    from aquafish_gym.env import AquaFishEnv

    np.testing.assert_allclose(AquaFishEnv.servo_command(STOP_ACTION), [0.0, 0.0, 0.0])


def test_the_warm_start_puts_the_seed_model_in_the_first_estimation_generation():
    config = EEAConfig.from_method("profile_lineages", "smoke", model_space="morphology+servos", cma_flip_gains=1)
    rng = np.random.default_rng(0)
    estimation = make_estimation(config.estimation, config.ga, config.model_space, rng)
    assert isinstance(estimation, Lineages)
    seed = _genome("reversed_left_pectoral")
    warm_start(estimation, seed)
    for member in estimation.members:
        search = member.search
        assert isinstance(search, CMAModelSearch)
        search.restart()  # what the estimation phase does first
        population = search.ask()
        assert any((row == seed).all() for row in population)
        assert np.abs(search._es.mean - search._best_x).max() < 0.01  # centred on it (pycma keeps the mean off the bounds)


def test_a_cold_start_does_not_hold_the_seed_model():
    config = EEAConfig.from_method("profile_lineages", "smoke", model_space="morphology+servos")
    estimation = make_estimation(config.estimation, config.ga, config.model_space, np.random.default_rng(0))
    seed = _genome("reversed_left_pectoral")
    assert not any((row == seed).all() for m in estimation.members for row in m.search.population)


def test_the_ga_warm_start_and_bad_genomes():
    config = EEAConfig.from_method("none", "smoke", model_space="morphology+servos")
    estimation = make_estimation(config.estimation, config.ga, config.model_space, np.random.default_rng(0))
    seed = _genome("caudal_half")
    warm_start(estimation, seed)
    assert (estimation.search.ask()[0] == seed).all()
    with pytest.raises(ValueError, match="bits"):
        CMAModelSearch(6, np.random.default_rng(0), model_space="morphology+servos").seed_at(seed[:45])


def test_span_speed_is_displacement_along_the_heading_per_second():
    rows = [{"time_s": t, "x": 5.0 * t, "y": 2.0 * t, "z": 0.0} for t in np.arange(0, 10.05, 0.1)]
    assert span_speed(rows, 2.0, 6.0) == pytest.approx(2.0)
    assert span_speed(rows, 3.0, 3.0) is None


def test_cli_presets_match_the_module():
    assert sorted(PRESET_NAMES) == sorted(MISSION_PRESETS)


class _Stop(Exception):
    pass


@pytest.mark.parametrize("warm", [True, False], ids=["warm", "cold"])
def test_the_recovery_starts_at_the_prior_model_or_with_cold_start_from_scratch(prior_dir, tmp_path, monkeypatch, warm):
    """What the recovery's EEA is seeded with: the self-model from before the damage, or
    nothing (``--cold-start``, the warm start's baseline)."""
    import aquafish.mission as mission_module

    seen = []

    def recover(mission, genome, *args):
        seen.append(genome)
        raise _Stop

    monkeypatch.setattr(mission_module, "_recover_model", recover)
    with pytest.raises(_Stop):
        run_mission(ALL_SEIZED, tmp_path / "m", onset_s=8.0, duration_s=30.0, preset="smoke", seed=0,
                    self_model=prior_dir, workers=1, warm_start=warm, video=False, oracle=False, progress=False)
    assert (seen[0] == _genome()).all() if warm else seen[0] is None


def test_own_self_model_fields_reach_the_recovery_eea_and_bad_ones_are_refused_before_any_work(prior_dir, tmp_path,
                                                                                                 monkeypatch):
    import aquafish.mission as mission_module

    seen = []

    def recover(mission, genome, config, *args):
        seen.append(config)
        raise _Stop

    monkeypatch.setattr(mission_module, "_recover_model", recover)
    with pytest.raises(_Stop):
        run_mission(ALL_SEIZED, tmp_path / "m", onset_s=8.0, duration_s=30.0, preset="smoke", seed=0,
                    self_model=prior_dir, workers=1, self_model_fields={"lineages": 1, "estimation_generations": 3},
                    video=False, oracle=False, progress=False)
    assert seen[0].estimation.lineages == 1 and seen[0].estimation.generations == 3
    with pytest.raises(_Stop):  # another search than the method's CMA-ES: no gain flips asked of it
        run_mission(ALL_SEIZED, tmp_path / "h", onset_s=8.0, duration_s=30.0, preset="smoke", seed=0,
                    self_model=prior_dir, workers=1, self_model_fields={"estimation_search": "hypotheses"},
                    video=False, oracle=False, progress=False)
    assert seen[1].estimation.search.name == "hypotheses"
    for fields, message in (({"damage": "none"}, "may not set 'damage'"),
                            ({"no_such_field": 1}, "self_model_fields: .*no_such_field"),
                            ({"lineages": 0}, "self_model_fields: .*lineages")):
        with pytest.raises(ValueError, match=message):
            run_mission(ALL_SEIZED, tmp_path / "bad", preset="smoke", self_model=prior_dir,
                        self_model_fields=fields, video=False, oracle=False, progress=False)
    assert not (tmp_path / "bad").exists()


def test_the_presets_recovery_fields_reach_the_recovery_eea_under_the_missions_own(prior_dir, tmp_path, monkeypatch):
    """A preset's recovery_fields set the recovery's search; a mission's own self_model_fields
    go over them, field by field (quick and medium: the ranked fault hypotheses)."""
    import dataclasses

    import aquafish.mission as mission_module

    seen = []

    def recover(mission, genome, config, *args):
        seen.append(config)
        raise _Stop

    monkeypatch.setattr(mission_module, "_recover_model", recover)
    smoke = dataclasses.replace(mission_module.MISSION_PRESETS["smoke"],
                                recovery_fields={"lineages": 1, "estimation_generations": 2})
    monkeypatch.setitem(mission_module.MISSION_PRESETS, "smoke", smoke)
    for own, generations in ((None, 2), ({"estimation_generations": 3}, 3)):
        with pytest.raises(_Stop):
            run_mission(ALL_SEIZED, tmp_path / f"m{generations}", onset_s=8.0, duration_s=30.0, preset="smoke",
                        seed=0, self_model=prior_dir, workers=1, self_model_fields=own, video=False, oracle=False,
                        progress=False)
        assert seen[-1].estimation.lineages == 1 and seen[-1].estimation.generations == generations
    # valid alone, refused merged (elitism above the preset's estimation population), before any work
    tight = dataclasses.replace(smoke, recovery_fields={"estimation_population": 2})
    monkeypatch.setitem(mission_module.MISSION_PRESETS, "smoke", tight)
    with pytest.raises(ValueError, match=r"self_model_fields: .*elitism \(3\) must be <= estimation_population \(2\)"):
        run_mission(ALL_SEIZED, tmp_path / "merged", preset="smoke", self_model=prior_dir,
                    self_model_fields={"elitism": 3}, video=False, oracle=False, progress=False)
    assert not (tmp_path / "merged").exists()
    from aquafish.case_study import HYPOTHESES_SELF_MODEL_FIELDS, LEAN_SELF_MODEL_FIELDS, PRESETS, check_self_model_fields
    ranked = dict(HYPOTHESES_SELF_MODEL_FIELDS)
    assert dict(mission_module.RECOVERY_FIELDS) == ranked
    for name in ("quick", "medium"):  # the ranked hypotheses, valid settings at each preset's budget
        preset = mission_module.MISSION_PRESETS[name]
        assert check_self_model_fields(preset.recovery_fields, PRESETS[preset.case_preset].budget) == ranked
        # the recovery's own settings, not the case study's: a change of the case preset leaves them
        case = dataclasses.replace(PRESETS[preset.case_preset], self_model_fields=dict(LEAN_SELF_MODEL_FIELDS))
        monkeypatch.setitem(PRESETS, preset.case_preset, case)
        assert mission_module.recovery_self_model_fields(preset, None) == ranked


def test_the_new_gait_is_scored_along_the_missions_heading_from_the_presets_spread_starts(prior_dir, tmp_path,
                                                                                            monkeypatch):
    import aquafish.mission as mission_module

    seen = []

    def recover(mission, genome, config, *args):
        return [], None, None, None, 0.0

    def evolve(robot, gait_dir, generations, **kwargs):
        seen.append((kwargs["start_yaws_deg"], kwargs["episodes_per_genome"]))
        raise _Stop

    monkeypatch.setattr(mission_module, "_recover_model", recover)
    monkeypatch.setattr(mission_module, "evolve_from_population", evolve)
    with pytest.raises(_Stop):
        run_mission(ALL_SEIZED, tmp_path / "m", onset_s=8.0, duration_s=30.0, preset="smoke", seed=0,
                    self_model=prior_dir, workers=1, video=False, oracle=False, progress=False)
    # one episode a start heading, each turned away from the mission's heading
    assert seen == [(MISSION_PRESETS["smoke"].new_gait_start_yaws_deg, 2)]


def test_both_kinds_of_new_gait_at_once_give_what_they_give_one_after_the_other(prior_dir):
    prior, settings = load_prior(prior_dir), MISSION_PRESETS["smoke"]
    robot = Robot(get_damage("reversed_left_pectoral").apply(), "reversed_left_pectoral", "damaged")
    alone = new_gait_kinds(robot, prior, settings, 3, 1, False, 120.0)
    together = new_gait_kinds(robot, prior, settings, 3, 2, False, 120.0)    # on one shared pool of 2
    assert list(together) == list(alone) == list(NEW_GAIT_KINDS)
    for kind in NEW_GAIT_KINDS:
        (result, rehearsal), (result_alone, rehearsal_alone) = together[kind], alone[kind]
        assert [h["best_fitness"] for h in result.history] == [h["best_fitness"] for h in result_alone.history]
        assert [c.genome.key for c in result.candidates] == [c.genome.key for c in result_alone.candidates]
        np.testing.assert_array_equal(rehearsal.scores, rehearsal_alone.scores)   # bit for bit
        assert rehearsal.index == rehearsal_alone.index


@pytest.mark.parametrize("argv, message", [
    (["--damage", "no_such_damage"], "unknown damage"),
    (["--damage", "caudal_half", "--self-model-fields", "[1]"], "--self-model-fields"),
    (["--damage", "caudal_half", "--onset-s", "-1"], "--onset-s"),
    (["--damage", "caudal_half", "--duration-s", "0"], "--duration-s"),
    (["--damage", "caudal_half", "--onset-s", "50", "--duration-s", "40"], "before the end of the mission"),
    (["--damage", "caudal_half", "--preset", "huge"], "--preset"),
    (["--damage", "caudal_half", "--seed", "-2"], "--seed"),
])
def test_bad_flags_are_refused_with_one_line(argv, message, tmp_path, capsys):
    argv = ["mission", *argv, "--out", str(tmp_path / "m"), *([] if "--preset" in argv else ["--preset", "smoke"])]
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert not (tmp_path / "m").exists()


def test_a_self_model_dir_without_a_self_model_is_refused(tmp_path, capsys):
    (tmp_path / "empty").mkdir()
    with pytest.raises(SystemExit):
        main(["mission", "--damage", "caudal_half", "--preset", "smoke", "--out", str(tmp_path / "m"),
              "--self-model", str(tmp_path / "empty")])
    assert "holds no finished self-model" in capsys.readouterr().err


@pytest.mark.slow
def test_the_example_runs_a_smoke_mission(tmp_path, capsys):
    import importlib.util
    from pathlib import Path

    spec = importlib.util.spec_from_file_location("mission_example", Path(__file__).parents[2] / "examples" / "mission.py")
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)
    example.main(["--preset", "smoke", "--damage", ALL_SEIZED, "--onset-s", "6", "--duration-s", "20",
                  "--out", str(tmp_path)])
    report = json.loads((tmp_path / "mission" / "mission.json").read_text())
    assert report["warm_start"] is True and report["self_model_dir"] == str(tmp_path / "self_model")
    assert "target_experiments" in capsys.readouterr().out


def test_the_onset_follows_the_missions_clock_through_experiments():
    mission = _Mission("reversed_left_pectoral", 1.0, 20.0, seed=0)
    try:
        mission.step([0.0, 0.0, 1.0], "gait")
        target = MissionTarget(mission, "reversed_left_pectoral", steps=150, stop_max_s=0.0)
        target.perform(np.array([0.5, 0.5, 0.0]))  # 1.5 s on the world directly: the env's steps do not advance
        assert mission.damaged
        first = next(r for r in mission.rows if r["damaged"])
        assert first["time_s"] == pytest.approx(1.0) and first["phase"] == "experiment"
        np.testing.assert_allclose(mission.world.speed_scale[0], [-1.0, 1.0, 1.0])
    finally:
        mission.env.close()


def test_the_design_prior_is_the_healthy_robot_and_runs_no_eea(tmp_path):
    from aquafish.mission import prepare_prior

    with pytest.raises(ValueError, match="unknown prior 'blueprint'; valid: design, eea"):
        prepare_prior(tmp_path / "bad", "smoke", 0, prior="blueprint")
    prior = prepare_prior(tmp_path / "design", "smoke", 0, workers=1, progress=False)
    assert np.array_equal(prior.genome, _genome("none"))
    values = SPACE.decode(prior.genome[None])[0]
    assert np.allclose(values[:9], Morphology.healthy().to_array()) and values[9:].tolist() == [1.0, 1.0, 1.0]
    assert prior.robot.damage == "none"
    assert not (tmp_path / "design" / "eea").exists()  # no self-modeling before the mission
    assert (tmp_path / "design" / "monitor_calibration.json").is_file()
    import json
    assert json.loads((tmp_path / "design" / "gait" / "fitness_settings.json").read_text())["spread_headings"] is True


def test_a_calibration_made_with_other_settings_is_made_anew(prior_dir):
    """A prior whose monitor calibration came from other settings (an older preset's) is
    recalibrated by make_prior; one with the preset's settings is reused as it is."""
    from aquafish.monitor import CALIBRATION_FILE, MonitorCalibration

    path = prior_dir / CALIBRATION_FILE
    before, written = MonitorCalibration.load(path), path.stat().st_mtime_ns
    make_prior(prior_dir, _genome(), Robot(Morphology.healthy(), "none", "healthy"), "smoke", 0, workers=1,
               calibration_seeds=6, progress=False)
    assert path.stat().st_mtime_ns == written  # the same settings: reused, not rewritten
    make_prior(prior_dir, _genome(), Robot(Morphology.healthy(), "none", "healthy"), "smoke", 0, workers=1,
               calibration_seeds=3, progress=False)
    assert MonitorCalibration.load(path).episodes == 3
    make_prior(prior_dir, _genome(), Robot(Morphology.healthy(), "none", "healthy"), "smoke", 0, workers=1,
               calibration_seeds=6, progress=False)  # back to the fixture's, for the other tests
    assert MonitorCalibration.load(path) == before


def test_keep_old_from_the_onset_snapshot_repeats_the_mission_to_the_bit_and_a_new_gait_restarts_its_clock():
    import copy

    mission = _Mission("reversed_left_pectoral", 2.0, 10.0, 0)
    swimming = _Sweep()
    while not mission.damaged:
        mission.step(swimming.act(mission.obs, mission.time_s), "gait")
    onset, old_gait = mission.snapshot(), copy.deepcopy(swimming)
    while mission.time_s < 6.0 - 1e-9:
        mission.step(swimming.act(mission.obs, mission.time_s), "gait")
    own = [(r["time_s"], r["x"], r["y"], r["yaw_deg"]) for r in mission.rows[onset.rows - 1:]]
    kept = mission.swim_from(onset, old_gait, 6.0, "keep_old", clock_origin_s=0.0)
    assert [(r["time_s"], r["x"], r["y"], r["yaw_deg"]) for r in kept] == own   # bit for bit
    fresh = mission.swim_from(onset, _Sweep(), 6.0, "new_gait")   # its clock from 0 at the onset: another path
    assert fresh[0]["y"] == kept[0]["y"] and fresh[-1]["y"] != kept[-1]["y"]


def test_net_displacement_final_speed_and_the_recovery_verdict_by_hand():
    from aquafish.mission import final_span_s, final_speed, judge_recovery, net_displacement

    assert final_span_s(900.0) == 120.0 and final_span_s(300.0) == 100.0   # the last third when shorter
    # along +y at 0.5 units/s from 30 s, having stood still before; x does not count
    rows = [{"time_s": t / 10, "x": 0.3 * t, "y": max(0.0, 0.05 * (t - 300)), "z": 0.0} for t in range(0, 3001)]
    assert net_displacement(rows, 30.0) == pytest.approx(0.5 * 270.0)
    assert final_speed(rows, 300.0) == pytest.approx(0.5)
    keep = {"keep_old": {"net_displacement": 100.0, "final_speed": 0.2}}
    oracle = {"oracle_at_alarm": {"net_displacement": 150.0, "final_speed": 0.5}}
    assert judge_recovery(120.0, 0.45, keep | oracle) is True     # beats carrying on, 90 % of the oracle
    assert judge_recovery(99.0, 0.45, keep | oracle) is False     # carrying on went further
    assert judge_recovery(120.0, 0.39, keep | oracle) is False    # below 80 % of the oracle's final speed
    assert judge_recovery(120.0, 0.45, keep | {"oracle_at_alarm": None}) is None
    assert judge_recovery(120.0, 0.45, keep | {"oracle_at_alarm": {"net_displacement": -1.0, "final_speed": -0.1}}) is None
