"""Robot specs: the forms a native or target robot can be given in."""

import json

import pytest

from aquafish_gym import Morphology
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
