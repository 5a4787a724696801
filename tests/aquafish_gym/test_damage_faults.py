"""Faults as data (aquafish_gym.faults, aquafish_gym.get_damage): a preset name, a JSON fault
(inline or a .json file) or sampled:SEED gives the expected morphology and servo faults; an
invalid fault fails in one line naming the key and its range; a fault crosses pickle,
process pools, EEAConfig and the env as its canonical text."""

from __future__ import annotations

import concurrent.futures
import json
import multiprocessing
import pickle
import subprocess
import sys
from collections import Counter

import gymnasium as gym
import numpy as np
import pytest

from aquafish_gym import DAMAGES, Morphology, ServoFaults, get_damage
from aquafish_gym.argtypes import damage_list
from aquafish_gym.damage import ScaleTransform
from aquafish_gym.faults import SAMPLED_KINDS, Fault, FaultDraw, draw_faults, sampled_fault
from eea.config import EEAConfig
from gait.robots import Robot, parse_robot

HEALTHY = [0.25, 1.0, 0.0625, 0.25, 1.0, 0.0625, 0.25, 0.875, 0.375]
INLINE = '{"scale": {"left_pectoral_y": 0.5, "caudal_x": 0}, "seized": [false, true, false], "gains": [1, -0.5, 0.25]}'
CANONICAL = '{"gains":[1.0,-0.5,0.25],"scale":{"caudal_x":0.0,"left_pectoral_y":0.5},"seized":[false,true,false]}'


def _morph(**changes) -> list[float]:
    names = ["left_pectoral_x", "left_pectoral_y", "left_pectoral_z", "right_pectoral_x", "right_pectoral_y",
             "right_pectoral_z", "caudal_x", "caudal_y", "caudal_z"]
    return [changes.get(n, h) for n, h in zip(names, HEALTHY)]


# -- the three forms --------------------------------------------------------------------------------------

def test_a_preset_name_is_the_preset_as_before():
    d = get_damage("left_pectoral_half")
    assert d is DAMAGES["left_pectoral_half"] and d.name == "left_pectoral_half"
    assert d.apply().to_array().tolist() == _morph(left_pectoral_y=0.5)
    assert d.faults == ServoFaults()
    assert get_damage("reversed_left_pectoral").faults == ServoFaults(speed_scale=(-1.0, 1.0, 1.0))
    assert pickle.loads(pickle.dumps(DAMAGES["left_pectoral_missing"])) == DAMAGES["left_pectoral_missing"]


def test_an_inline_json_fault_gives_its_morphology_faults_and_canonical_name():
    d = get_damage(INLINE)
    assert d.name == CANONICAL
    assert d.apply().to_array().tolist() == _morph(left_pectoral_y=0.5, caudal_x=0.0)
    assert d.faults == ServoFaults(seized=(False, True, False), speed_scale=(1.0, -0.5, 0.25))
    assert d.transform == ScaleTransform((("left_pectoral_y", 0.5), ("caudal_x", 0.0)))
    # applied to another morphology: the factors multiply its dimensions
    base = Morphology.from_array(_morph(left_pectoral_y=1.5, caudal_x=0.4))
    assert d.apply(base).to_array().tolist() == _morph(left_pectoral_y=0.75, caudal_x=0.0)
    assert d.description == ("Left pectoral flipper shortened to 0.5 of its length, caudal_x scaled by 0, right "
                             "pectoral servo seized, right pectoral servo reversed (gain -0.5) and caudal servo weak "
                             "(gain 0.25).")


def test_the_canonical_text_resolves_to_the_same_damage_and_ignores_spelling():
    assert get_damage(CANONICAL) == get_damage(INLINE)
    spelt = ['{"gains": [1, -0.5, 1]}', '  {"gains":[1.0, -0.5, 1.00], "scale": {"caudal_y": 1}} ',
             '{"gains": [1, -0.5, 1], "seized": [false, false, false]}']
    assert {get_damage(t).name for t in spelt} == {'{"gains":[1.0,-0.5,1.0]}'}
    assert get_damage('{"gains": [1, 1, 1]}').name == "{}"     # every part at its default: no fault
    assert get_damage("{}").apply() == Morphology.healthy() and get_damage("{}").faults.healthy
    assert get_damage('{"gains": [-0.0, 1, 1]}').name == '{"gains":[0.0,1.0,1.0]}'


def test_a_json_file_gives_the_same_damage_as_inline(tmp_path):
    path = tmp_path / "fault.json"
    path.write_text(json.dumps(json.loads(INLINE), indent=2))
    assert get_damage(str(path)) == get_damage(INLINE)
    assert get_damage(str(path)).name == CANONICAL       # the content, not the path


def test_sampled_seeds_give_the_hand_written_faults():
    """A change of the distribution (docs/simulator.md) or of the draw order fails here."""
    expected = {
        0: ('{"gains":[0.21,1.0,1.0],"scale":{"right_pectoral_x":0.0,"right_pectoral_y":0.0,"right_pectoral_z":0.0}}',
            _morph(right_pectoral_x=0.0, right_pectoral_y=0.0, right_pectoral_z=0.0),
            ServoFaults(speed_scale=(0.21, 1.0, 1.0))),
        1: ('{"gains":[0.7,1.0,0.0]}', HEALTHY, ServoFaults(speed_scale=(0.7, 1.0, 0.0))),
        4: ('{"scale":{"left_pectoral_y":0.65,"right_pectoral_y":0.29}}',
            _morph(left_pectoral_y=0.65, right_pectoral_y=0.29), ServoFaults()),
        5: ('{"gains":[-1.0,1.0,1.0],"scale":{"right_pectoral_x":0.0,"right_pectoral_y":0.0,"right_pectoral_z":0.0}}',
            _morph(right_pectoral_x=0.0, right_pectoral_y=0.0, right_pectoral_z=0.0),
            ServoFaults(speed_scale=(-1.0, 1.0, 1.0))),
        11: ('{"seized":[false,true,false]}', HEALTHY, ServoFaults(seized=(False, True, False))),
    }
    for seed, (text, morph, faults) in expected.items():
        d = get_damage(f"sampled:{seed}")
        assert d.name == f"sampled:{seed}"
        assert sampled_fault(seed).to_json() == text
        assert np.allclose(d.apply().to_array(), morph, rtol=0, atol=1e-12) and d.faults == faults
        assert get_damage(text) == get_damage(text) and get_damage(text).faults == faults  # the same fault as JSON
    assert draw_faults(13) == (FaultDraw("weak", "caudal", 0.36), FaultDraw("reversed", "right_pectoral"))
    assert draw_faults(15) == (FaultDraw("lost", "left_pectoral"), FaultDraw("shortened", "right_pectoral", 0.61))
    assert get_damage("sampled:007").name == "sampled:7" and get_damage("sampled:007") == get_damage("sampled:7")


def test_sampled_faults_are_the_same_in_a_fresh_process():
    code = ("from aquafish_gym.faults import sampled_fault\n"
            "print('\\n'.join(sampled_fault(s).to_json() for s in range(30)))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.splitlines() == [sampled_fault(s).to_json() for s in range(30)]


def test_sampled_faults_cover_every_kind_over_seeds_0_to_199():
    kinds, counts = Counter(), Counter()
    for seed in range(200):
        draws = draw_faults(seed)
        counts[len(draws)] += 1
        assert len({d.part for d in draws}) == len(draws)          # two faults: two parts
        for d in draws:
            kinds[d.kind, d.part] += 1
            if d.kind == "weak":
                assert 0.2 <= d.value <= 0.8
            elif d.kind == "shortened":
                assert 0.25 <= d.value <= 0.75
            else:
                assert d.value is None
        fault = sampled_fault(seed)                                 # the draws written as a fault
        for d in draws:
            servo = ("left_pectoral", "right_pectoral", "caudal").index(d.part)
            scale = dict(fault.scale)
            assert {"reversed": fault.gains[servo] == -1.0, "weak": fault.gains[servo] == d.value,
                    "dead": fault.gains[servo] == 0.0, "seized": fault.seized[servo],
                    "shortened": scale.get(f"{d.part}_y") == d.value,
                    "lost": all(scale.get(f"{d.part}_{a}") == 0.0 for a in "xyz")}[d.kind]
    expected = {(k, p) for k, part, _ in SAMPLED_KINDS
                for p in (("left_pectoral", "right_pectoral") if part == "pectoral" else ("caudal",))}
    assert len(expected) == 14 and set(kinds) == expected, set(expected) - set(kinds)
    assert min(kinds.values()) >= 5, kinds
    assert 70 <= counts[1] <= 130 and counts[1] + counts[2] == 200, counts
    actuator = sum(v for (k, _), v in kinds.items() if k not in ("shortened", "lost"))
    assert 0.5 < actuator / sum(kinds.values()) < 0.8                # 65 % expected


# -- invalid faults: one line naming the key and the range ------------------------------------------------

@pytest.mark.parametrize("text, message", [
    ('{"gains": [-2, 1, 1]}', "damage fault: gains[0] must be in [-1, 1], got -2"),
    ('{"gains": [1, 1, -0.5]}', "damage fault: gains[2] must be in [0, 1], got -0.5"),
    ('{"gains": [1, 1]}', "damage fault: gains must be 3 numbers"),
    ('{"gains": [1, "fast", 1]}', 'damage fault: gains[1] must be a number in [-1, 1], got "fast"'),
    ('{"gain": [1, 1, 1]}', "damage fault: unknown key 'gain'; allowed: scale, seized, gains"),
    ('{"scale": {"tail_y": 0.5}}', "damage fault: scale: unknown morphology field 'tail_y'; fields: left_pectoral_x, "),
    ('{"scale": {"caudal_y": -1}}', "damage fault: scale.caudal_y must be in [0, 2.2857]"),
    ('{"scale": {"left_pectoral_y": 3}}', "damage fault: scale.left_pectoral_y must be in [0, 2]"),
    ('{"scale": {"left_pectoral_y": NaN}}', "damage fault: scale.left_pectoral_y must be a number in [0, 2]"),
    ('{"scale": [0.5]}', "damage fault: scale must be an object of morphology field -> factor >= 0"),
    ('{"seized": [true, 0, false]}', "damage fault: seized[1] must be true or false, got 0"),
    ('{"seized": [true]}', "damage fault: seized must be 3 booleans"),
    ('{"gains": [1, 1, 1], "gains": [1, 1, 0]}', "damage fault: key 'gains' given twice"),
    ('{"gains": [1, 1, 1]', "damage fault: not valid JSON"),
    ("[1, 2]", "damage fault: a fault is a JSON object with the keys scale, seized, gains"),
    ("sampled:-1", "damage fault: sampled:SEED needs an int SEED >= 0, got 'sampled:-1'"),
    ("sampled:x", "damage fault: sampled:SEED needs an int SEED >= 0"),
    ("missing.json", "damage fault: cannot read missing.json: No such file or directory"),
    ("dented", "unknown damage 'dented'; valid names: caudal_half, "),
])
def test_an_invalid_fault_fails_in_one_line(text, message):
    with pytest.raises(ValueError) as err:
        get_damage(text)
    assert str(err.value).startswith(message) and "\n" not in str(err.value), str(err.value)


def test_an_invalid_json_file_names_the_file(tmp_path):
    path = tmp_path / "bad.json"
    path.write_text("{not json")
    with pytest.raises(ValueError, match=f"damage fault: {path}: not valid JSON"):
        get_damage(str(path))
    path.write_text('{"gains": [1, 2, 1]}')
    with pytest.raises(ValueError, match=r"damage fault: gains\[1\] must be in \[-1, 1\], got 2"):
        get_damage(str(path))


def test_non_text_is_refused():
    with pytest.raises(ValueError, match="a damage is a preset name, a JSON fault or sampled:SEED"):
        get_damage(3)


# -- crossing processes, configs, robots and the env ------------------------------------------------------

@pytest.mark.parametrize("text", [INLINE, "sampled:5"])
def test_a_fault_pickles(text):
    d = get_damage(text)
    back = pickle.loads(pickle.dumps(d))
    assert back == d and back.apply() == d.apply() and back.faults == d.faults
    assert pickle.loads(pickle.dumps(Fault.from_json(INLINE))) == Fault.from_json(INLINE)


def _rebuild(text: str):
    damage = get_damage(text)
    return damage.name, damage.apply().to_array().tolist(), damage.faults


def test_a_spawned_worker_rebuilds_the_fault_from_its_text():
    texts = [INLINE, "sampled:0", "left_pectoral_half"]
    with concurrent.futures.ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn")) as pool:
        rebuilt = list(pool.map(_rebuild, texts))
    assert rebuilt == [_rebuild(t) for t in texts]


def test_eea_config_records_the_canonical_fault_and_round_trips(tmp_path):
    path = tmp_path / "fault.json"
    path.write_text(INLINE)
    for given, recorded in ((INLINE, CANONICAL), (str(path), CANONICAL), ("sampled:03", "sampled:3"),
                            ("caudal_half", "caudal_half")):
        config = EEAConfig(damage=given)
        assert config.damage == recorded
        data = json.loads(json.dumps(config.to_dict()))              # what config.json holds
        assert data["damage"] == recorded and EEAConfig.from_dict(data) == config
        assert pickle.loads(pickle.dumps(config)) == config
    path.unlink()                                                   # the recorded config no longer needs the file
    assert EEAConfig.from_dict(EEAConfig(damage=CANONICAL).to_dict()).damage == CANONICAL
    with pytest.raises(ValueError, match=r"damage fault: gains\[0\] must be in \[-1, 1\], got 2"):
        EEAConfig(damage='{"gains": [2, 1, 1]}')


def test_robots_keep_the_canonical_fault(tmp_path):
    robot = Robot(Morphology.healthy(), INLINE)
    assert robot.damage == CANONICAL and robot.env_kwargs()["damage"] == CANONICAL
    assert parse_robot(INLINE).damage == CANONICAL and parse_robot("sampled:4").damage == "sampled:4"
    assert pickle.loads(pickle.dumps(robot)) == robot


def test_gym_make_with_a_sampled_fault_reports_it():
    env = gym.make("AquaFish-v0", damage="sampled:3")
    try:
        _, info = env.reset(seed=0)
        assert info["damage"] == "sampled:3"
        assert env.unwrapped.faults == ServoFaults(speed_scale=(1.0, 0.55, 1.0))
        assert env.unwrapped.morphology == Morphology.healthy()
        _, _, _, _, info = env.step(env.action_space.sample())
        assert info["damage"] == "sampled:3"
    finally:
        env.close()


def test_the_env_draws_from_a_list_that_mixes_the_forms(tmp_path):
    path = tmp_path / "fault.json"
    path.write_text('{"scale": {"caudal_y": 0.5}}')
    env = gym.make("AquaFish-v0", damage=["none", INLINE, "sampled:4", str(path)])
    try:
        assert env.unwrapped.damage_names == ("none", CANONICAL, "sampled:4", '{"scale":{"caudal_y":0.5}}')
        seen = set()
        for seed in range(12):
            _, info = env.reset(seed=seed)
            seen.add(info["damage"])
            assert env.unwrapped.morphology == get_damage(info["damage"]).apply()
        assert seen == set(env.unwrapped.damage_names)
        _, info = env.reset(seed=0, options={"damage": "sampled:5"})
        assert info["damage"] == "sampled:5" and env.unwrapped.faults.speed_scale == (-1.0, 1.0, 1.0)
    finally:
        env.close()
    with pytest.raises(ValueError, match=r"damage fault: gains\[2\] must be in \[0, 1\]"):
        gym.make("AquaFish-v0", damage=["none", '{"gains": [1, 1, 2]}'])


def test_damage_lists_split_outside_json():
    assert damage_list('none,{"gains":[1,-0.5,1]},sampled:3, caudal_half') == \
        ("none", '{"gains":[1,-0.5,1]}', "sampled:3", "caudal_half")
    assert damage_list('{"scale": {"left_pectoral_y": 0.5, "caudal_y": 0.5}}') == \
        ('{"scale": {"left_pectoral_y": 0.5, "caudal_y": 0.5}}',)


def test_an_env_made_from_a_fault_file_copies_without_the_file(tmp_path):
    import pickle

    import gymnasium as gym

    path = tmp_path / "fault.json"
    path.write_text('{"gains": [1, -0.5, 1]}')
    env = gym.make("AquaFish-v0", damage=str(path)).unwrapped
    env.reset(seed=0)
    path.unlink()  # the file is read once: a copy carries the fault itself
    copy = pickle.loads(pickle.dumps(env))
    assert copy.reset(seed=0)[1]["damage"] == '{"gains":[1.0,-0.5,1.0]}'
    env.close()
    copy.close()
