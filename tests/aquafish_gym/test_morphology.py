import numpy as np
import pytest

from aquafish_gym import DAMAGES, MORPHOLOGY_BOUNDS, Morphology, ServoFaults, get_damage


def test_healthy_round_trips_through_array():
    m = Morphology.healthy()
    arr = m.to_array()
    assert arr.shape == (9,)
    np.testing.assert_array_equal(arr, [0.25, 1.0, 0.0625, 0.25, 1.0, 0.0625, 0.25, 0.875, 0.375])
    assert Morphology.from_array(arr) == m


def test_bounds_shape_and_values():
    assert MORPHOLOGY_BOUNDS.shape == (9, 2)
    np.testing.assert_array_equal(MORPHOLOGY_BOUNDS[:, 1], [1, 2, 0.5, 1, 2, 0.5, 0.5, 2, 1])
    np.testing.assert_array_equal(MORPHOLOGY_BOUNDS[:, 0], 0)


@pytest.mark.parametrize("bad, field", [(-0.1, "left_pectoral_x"), (np.nan, "left_pectoral_x"), (1.5, "left_pectoral_x")])
def test_bad_value_names_field_and_range(bad, field):
    arr = Morphology.healthy().to_array()
    arr[0] = bad
    with pytest.raises(ValueError, match=rf"{field}.*\[0.0, 1.0\]"):
        Morphology.from_array(arr)


def test_wrong_shape_raises():
    with pytest.raises(ValueError, match=r"shape \(9,\)"):
        Morphology.from_array(np.zeros(8))


def test_damage_presets():
    healthy = Morphology.healthy()
    assert get_damage("left_pectoral_half").apply().left_pectoral_y == pytest.approx(healthy.left_pectoral_y / 2)
    assert get_damage("left_pectoral_half").apply().right_pectoral_y == healthy.right_pectoral_y
    assert get_damage("left_pectoral_missing").apply().to_array()[:3].sum() == 0
    assert get_damage("seized_left_pectoral").faults.seized == (True, False, False)
    assert get_damage("none").apply() == healthy
    assert {"none", "left_pectoral_half", "right_pectoral_half", "left_pectoral_missing", "caudal_half", "caudal_missing", "seized_left_pectoral"} <= set(DAMAGES)


def test_unknown_damage_lists_valid_names():
    with pytest.raises(ValueError, match="left_pectoral_half"):
        get_damage("tail_gone")


def test_servo_faults_validation():
    with pytest.raises(ValueError, match="speed_scale"):
        ServoFaults(speed_scale=(1.0, 2.0, 1.0))
