"""The shared argument checks: the bounds and messages every package relies on."""

import json

import numpy as np
import pytest

from aquafish_gym.checks import DuplicateKeyError, check_int, check_weight, check_yaw_deg, json_loads_unique_keys


@pytest.mark.parametrize("value", [0, 3, np.int64(5)])
def test_check_int_accepts_integers_in_range(value):
    assert check_int("n", value, minimum=0, maximum=5) == int(value)
    assert type(check_int("n", value, minimum=0)) is int


@pytest.mark.parametrize("value, message", [
    (True, "n must be an int >= 0 and <= 5, got True"),
    (2.0, "n must be an int >= 0 and <= 5, got 2.0"),
    (-1, "n must be an int >= 0 and <= 5, got -1"),
    (6, "n must be an int >= 0 and <= 5, got 6"),
])
def test_check_int_names_the_argument_and_bounds(value, message):
    with pytest.raises(ValueError, match="^" + message.replace(".", r"\.") + "$"):
        check_int("n", value, minimum=0, maximum=5)


@pytest.mark.parametrize("value", [float("nan"), float("inf"), -0.5, True, "1"])
def test_check_weight_refuses_non_finite_negative_and_non_numbers(value):
    with pytest.raises(ValueError, match="w"):
        check_weight("w", value)


def test_json_loads_unique_keys_reads_json_and_refuses_a_repeated_key_at_any_depth():
    assert json_loads_unique_keys('{"a": 1, "b": {"c": [1, 2]}}') == {"a": 1, "b": {"c": [1, 2]}}
    assert json.loads('{"a": 1, "a": 2}') == {"a": 2}  # what plain json would do silently
    for text, key in (('{"a": 1, "a": 2}', "a"), ('{"b": {"c": 1, "c": 1}}', "c")):
        with pytest.raises(DuplicateKeyError, match=f"^key '{key}' given twice$"):
            json_loads_unique_keys(text)
    with pytest.raises(json.JSONDecodeError):
        json_loads_unique_keys('{"a": }')


def test_check_yaw_deg_accepts_headings_in_range_and_names_the_argument_otherwise():
    assert check_yaw_deg("yaw", -180) == -180.0 and check_yaw_deg("yaw", np.float32(90.5)) == 90.5
    assert check_yaw_deg("yaw", np.int64(180)) == 180.0
    for bad in (180.01, -181, float("nan"), float("inf"), True, np.bool_(False), "10", None):
        with pytest.raises(ValueError, match=r"^yaw must be a number of degrees in \[-180, 180\] \(note\), got "):
            check_yaw_deg("yaw", bad, " (note)")


def test_check_seconds_takes_positive_finite_numbers_and_names_the_rest():
    from aquafish_gym.checks import check_seconds
    assert check_seconds("d", 2) == 2.0 and check_seconds("d", np.float32(0.5)) == 0.5
    for bad in (0, -1.0, float("nan"), float("inf"), True, "3", None):
        with pytest.raises(ValueError, match=r"d must be a positive number of seconds, got"):
            check_seconds("d", bad)


def test_short_json_quotes_a_json_field_as_json_and_cuts_a_long_one():
    from aquafish_gym.checks import short_json

    assert [short_json(v, 40) for v in (None, True, "abc", float("nan"), {"a": [1]})] == \
        ["null", "true", '"abc"', "NaN", '{"a": [1]}']
    long = short_json(list(range(100)), 40)
    assert len(long) == 40 and long.startswith("[0, 1, 2") and long.endswith("...")
