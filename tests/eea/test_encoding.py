"""Tests of eea.encoding: model and action genomes (paper section 3.2)."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from aquafish_gym import ACTION_BOUNDS, DAMAGES, get_damage
from aquafish_gym import MORPHOLOGY_BOUNDS as MODEL_BOUNDS
from eea.encoding import (
    ACTION_BITS,
    MODEL_BITS,
    MODEL_FIELD_BITS,
    decode_actions,
    decode_models,
    encode_actions,
    encode_models,
    genome_keys,
    genomes_from_keys,
)


def test_constants_match_paper():
    assert MODEL_BITS == 45 and sum(MODEL_FIELD_BITS) == 45
    assert MODEL_FIELD_BITS == (5, 6, 4, 5, 6, 4, 5, 6, 4)
    assert MODEL_BOUNDS.shape == (9, 2)
    np.testing.assert_array_equal(MODEL_BOUNDS[:, 1], [1, 2, 0.5, 1, 2, 0.5, 0.5, 2, 1])
    np.testing.assert_array_equal(MODEL_BOUNDS[:, 0], 0.0)
    assert ACTION_BITS == 18
    np.testing.assert_array_equal(ACTION_BOUNDS, [[-0.5, 0.5], [-0.5, 0.5], [0.0, 1.0]])


def test_range_ends():
    # Model fields are half-open: all-ones is one step below the high end, which itself
    # encodes onto that top level (its nearest grid point).
    top = MODEL_BOUNDS[:, 1] * (1 - 1 / 2.0 ** np.array(MODEL_FIELD_BITS))
    np.testing.assert_array_equal(decode_models(np.zeros((2, 45), np.uint8)), np.zeros((2, 9)))
    np.testing.assert_array_equal(decode_models(np.ones(45, bool)), top)
    np.testing.assert_array_equal(encode_models(top), np.ones(45, np.uint8))
    np.testing.assert_array_equal(encode_models(MODEL_BOUNDS[:, 1]), np.ones(45, np.uint8))
    np.testing.assert_array_equal(encode_models(MODEL_BOUNDS[:, 0]), np.zeros(45, np.uint8))
    # Action fields are closed: both servo range ends are commands.
    np.testing.assert_array_equal(decode_actions(np.zeros(18)), ACTION_BOUNDS[:, 0])
    np.testing.assert_array_equal(decode_actions(np.ones((1, 18))), ACTION_BOUNDS[:, 1][None])
    np.testing.assert_array_equal(encode_actions(ACTION_BOUNDS.T), [[0] * 18, [1] * 18])


@pytest.mark.parametrize("damage", sorted(DAMAGES))
def test_every_damage_preset_is_a_model_genome(damage):
    # The ideal baseline can only reach OBJ_FIT = 1 (paper Figure 5) if the target itself is
    # a model: the healthy robot and every damage preset decode back exactly.
    dims = get_damage(damage).apply().to_array()
    np.testing.assert_array_equal(decode_models(encode_models(dims)), dims)


def test_hand_computed_decode():
    g = np.zeros(45, np.uint8)
    g[0] = 1            # left pectoral x: 10000 = 16 of 32 steps, range [0, 1) -> 0.5
    g[5:11] = 1         # left pectoral y: 111111 = 63 of 64 steps, range [0, 2) -> 1.96875
    g[11:15] = [0, 0, 1, 1]   # left pectoral z: 0011 = 3 of 16 steps, range [0, 0.5) -> 0.09375
    g[30:35] = [0, 0, 0, 0, 1]  # caudal x: 1 of 32 steps, range [0, 0.5) -> 0.015625
    dims = decode_models(g)
    np.testing.assert_array_equal(dims, [0.5, 1.96875, 0.09375, 0, 0, 0, 0.015625, 0, 0])
    a = decode_actions(np.array([1, 0, 0, 0, 0, 0] + [0] * 11 + [1], np.uint8))
    np.testing.assert_allclose(a, [-0.5 + 32 / 63, -0.5, 1 / 63])
    assert encode_models(dims).dtype == np.uint8
    np.testing.assert_array_equal(encode_models(dims), g)


def test_round_trip_at_every_grid_point_of_a_field():
    ints = np.arange(32)
    g = np.zeros((32, 45), np.uint8)
    g[:, :5] = (ints[:, None] >> np.arange(4, -1, -1)) & 1
    dims = decode_models(g)
    np.testing.assert_array_equal(dims[:, 0], ints / 32)
    np.testing.assert_array_equal(encode_models(dims), g)


def test_encode_picks_nearest_grid_point():
    dims = np.zeros(9)
    dims[0] = 16 / 32 + 0.4 / 32   # nearer 16 than 17
    np.testing.assert_array_equal(encode_models(dims)[:5], [1, 0, 0, 0, 0])
    dims[0] = 16 / 32 + 0.6 / 32
    np.testing.assert_array_equal(encode_models(dims)[:5], [1, 0, 0, 0, 1])


@given(arrays(np.uint8, st.tuples(st.integers(1, 5), st.just(45)), elements=st.integers(0, 1)))
def test_model_round_trip_property(genomes):
    np.testing.assert_array_equal(encode_models(decode_models(genomes)), genomes)


@given(arrays(np.uint8, (18,), elements=st.integers(0, 1)))
def test_action_round_trip_property(genome):
    actions = decode_actions(genome)
    assert np.all((actions >= ACTION_BOUNDS[:, 0]) & (actions <= ACTION_BOUNDS[:, 1]))
    np.testing.assert_array_equal(encode_actions(actions), genome)


@pytest.mark.parametrize(
    "genomes, match",
    [
        (np.zeros(44), "shape"),
        (np.zeros((2, 46)), "shape"),
        (np.zeros((2, 3, 45)), "shape"),
        (np.full(45, 2), "only 0 and 1"),
        (np.r_[np.zeros(44), np.nan], "only 0 and 1"),
        (np.r_[np.zeros(44), 0.5], "only 0 and 1"),
    ],
)
def test_decode_models_rejects_bad_genomes(genomes, match):
    with pytest.raises(ValueError, match=match):
        decode_models(genomes)


def test_decode_actions_rejects_model_width():
    with pytest.raises(ValueError, match=r"genomes must have shape \(18,\)"):
        decode_actions(np.zeros(45))


@pytest.mark.parametrize(
    "dims, match",
    [
        (np.zeros(8), "shape"),
        (np.r_[np.zeros(8), np.nan], "finite"),
        (np.r_[1.1, np.zeros(8)], "outside"),
        (np.r_[np.zeros(8), -0.01], "outside"),
    ],
)
def test_encode_models_rejects_bad_dims(dims, match):
    with pytest.raises(ValueError, match=match):
        encode_models(dims)


def test_encode_actions_rejects_out_of_range_speed():
    with pytest.raises(ValueError, match="outside"):
        encode_actions([0.6, 0.0, 0.5])


def test_genome_keys_round_trip_and_tell_genomes_apart():
    genomes = np.random.default_rng(0).integers(0, 2, (6, MODEL_BITS), dtype=np.uint8)
    genomes[5] = genomes[0]
    keys = genome_keys(genomes)
    assert len(set(keys)) == 5 and keys[5] == keys[0]
    np.testing.assert_array_equal(genomes_from_keys(keys, MODEL_BITS), genomes)
    assert genomes_from_keys([], MODEL_BITS).shape == (0, MODEL_BITS)
    with pytest.raises(ValueError, match="must be 44 bytes"):
        genomes_from_keys(keys, 44)
