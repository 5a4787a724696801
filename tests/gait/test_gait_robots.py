"""Robot specs: the forms a native or target robot can be given in."""

import json

import pytest

from aquafish_gym import Morphology, ServoFaults
from gait import Robot, as_robot, parse_robot

NUMBERS = "0.25,1.0,0.0625,0.25,0.5,0.0625,0.25,0.875,0.375"


def test_parse_forms(tmp_path):
    assert parse_robot("healthy") == Robot(Morphology.healthy(), "none", "healthy")
    damaged = parse_robot("left_pectoral_half")
    assert damaged.morphology == Morphology.healthy() and damaged.damage == "left_pectoral_half"
    custom = parse_robot(NUMBERS)
    assert custom.morphology.right_pectoral_y == 0.5 and custom.damage == "none"
    f = tmp_path / "model.json"
    f.write_text(json.dumps({"morphology": custom.morphology.to_array().tolist(), "damage": "caudal_half"}))
    assert parse_robot(str(f)) == Robot(custom.morphology, "caudal_half", "model")
    f2 = tmp_path / "fields.json"
    f2.write_text(json.dumps(dict(zip(Morphology.FIELDS, custom.morphology.to_array().tolist()))))
    assert parse_robot(str(f2)).morphology == custom.morphology
    f3 = tmp_path / "m.txt"
    f3.write_text(NUMBERS.replace(",", " "))
    assert parse_robot(str(f3)).morphology == custom.morphology


@pytest.mark.parametrize("spec, match", [
    ("broken", "unknown robot"),
    ("1,2,3", "shape"),
    ("a,b,c,d,e,f,g,h,i", "9 comma-separated"),
    ("0.25,1.0,0.0625,0.25,5.0,0.0625,0.25,0.875,0.375", "right_pectoral_y"),
])
def test_parse_errors(spec, match):
    with pytest.raises(ValueError, match=match):
        parse_robot(spec)


def test_as_robot():
    healthy = Morphology.healthy()
    assert as_robot(healthy, damage="caudal_half") == Robot(healthy, "caudal_half")
    assert as_robot(healthy.to_array()).morphology == healthy
    assert as_robot("healthy", damage="caudal_half").damage == "caudal_half"
    with pytest.raises(ValueError, match="already has damage"):
        as_robot("left_pectoral_half", damage="caudal_half")
    with pytest.raises(ValueError, match="unknown damage"):
        as_robot(healthy, damage="nope")
    with pytest.raises(ValueError, match="a robot must be"):
        as_robot(3.0)


def test_robot_faults_reach_the_env_and_its_fingerprint(tmp_path):
    faults = ServoFaults(speed_scale=(-1.0, 1.0, 1.0))
    robot = Robot(Morphology.healthy(), faults=faults)
    assert robot.env_kwargs()["faults"] == faults and "servo gains -1, 1, 1" in robot.label
    assert robot.to_dict()["faults"] == {"seized": [False] * 3, "speed_scale": [-1.0, 1.0, 1.0]}
    assert "faults" not in Robot(Morphology.healthy()).to_dict() and "faults" not in Robot(Morphology.healthy()).env_kwargs()
    # a healthy body with a reversed left servo swims as the reversed_left_pectoral preset does
    from gait import ConstantController, rollout

    c = ConstantController([0.5, 0.5, 1.0])
    assert rollout(c, robot, seed=0, episode_duration_s=1.0).distance == \
        rollout(c, "reversed_left_pectoral", seed=0, episode_duration_s=1.0).distance
    f = tmp_path / "model.json"
    f.write_text(json.dumps(robot.to_dict()))
    assert parse_robot(str(f)).faults == faults
    with pytest.raises(ValueError, match="faults"):
        Robot(Morphology.healthy(), faults=(1, 1, 1))


def test_robot_with_random_damage_draws_one_per_seed():
    robot = Robot(Morphology.healthy(), "random")
    assert robot.env_kwargs()["damage"] == "random" and robot.label == "healthy + random"
    from gait import make_env

    with make_env(robot, episode_duration_s=0.1) as env:
        drawn = {env.reset(seed=s)[1]["damage"] for s in range(20)}
        assert len(drawn) > 3 and env.reset(seed=3)[1]["damage"] == env.reset(seed=3)[1]["damage"]


@pytest.mark.parametrize("robot", [
    Robot(Morphology.healthy(), "none"),
    Robot(Morphology.healthy().replace(left_pectoral_y=0.5), "caudal_half", "mine"),
    Robot(Morphology.healthy(), "none", faults=ServoFaults(seized=(False, True, False), speed_scale=(-1.0, 1.0, 0.5))),
])
def test_from_dict_is_the_inverse_of_to_dict_through_json(robot):
    assert Robot.from_dict(json.loads(json.dumps(robot.to_dict()))) == robot
