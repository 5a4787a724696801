"""The fluid model against hand-computed values (docs/physics.md)."""

import numpy as np
import pytest

from aquafish_gym.fluid import (
    added_mass_per_length, box_drag, box_faces, caudal_reactive_force, drag_wrench, quat_to_matrix, reactive_force, righting_torque,
)

I3 = np.eye(3)


def one_face(normal, centre, area):
    return np.array([centre], float), np.array([normal], float), np.array([area], float)


def test_quadratic_force_on_one_face_matches_hand_value():
    c, n, a = one_face([1, 0, 0], [0, 0, 0], 2.0)
    f, t = drag_wrench(I3, np.array([3.0, 0, 0]), np.zeros(3), c, n, a, drag_coefficient=0.8, fluid_density=1.5)
    # F = -c_d A (rho v^2 / 2) n = -0.8 * 2 * 0.75 * 9 = -10.8
    np.testing.assert_allclose(f, [-10.8, 0, 0])
    np.testing.assert_allclose(t, 0, atol=1e-15)


def test_linear_law_force_on_one_face():
    c, n, a = one_face([1, 0, 0], [0, 0, 0], 2.0)
    f, _ = drag_wrench(I3, np.array([3.0, 0, 0]), np.zeros(3), c, n, a, drag_coefficient=0.8, fluid_density=1.5, drag_law="linear")
    np.testing.assert_allclose(f, [-4.8, 0, 0])  # -c_d A v


def test_face_moving_out_of_the_water_feels_nothing():
    c, n, a = one_face([1, 0, 0], [0, 0, 0], 2.0)
    f, t = drag_wrench(I3, np.array([-3.0, 0, 0]), np.zeros(3), c, n, a, drag_coefficient=1.0, fluid_density=1.0)
    assert np.all(f == 0) and np.all(t == 0)


def test_rotation_makes_face_velocity_and_torque_at_face_centre():
    # face at r = (0, 1, 0) with normal +x; w = (0, 0, -2) gives w x r = (2, 0, 0)
    c, n, a = one_face([1, 0, 0], [0, 1, 0], 1.0)
    f, t = drag_wrench(I3, np.zeros(3), np.array([0, 0, -2.0]), c, n, a, drag_coefficient=1.0, fluid_density=1.0)
    np.testing.assert_allclose(f, [-2.0, 0, 0])  # 1 * 1 * 0.5 * 2^2
    np.testing.assert_allclose(t, [0, 0, 2.0])  # r x F = (0,1,0) x (-2,0,0)


def test_water_current_is_relative_velocity():
    c, n, a = one_face([1, 0, 0], [0, 0, 0], 1.0)
    # body at rest, water flowing towards -x: the +x face moves into the water at 1
    f, _ = drag_wrench(I3, np.zeros(3), np.zeros(3), c, n, a, drag_coefficient=1.0, fluid_density=1.0, water_current=(-1.0, 0, 0))
    np.testing.assert_allclose(f, [-0.5, 0, 0])


def test_force_is_rotated_with_the_link():
    rot = quat_to_matrix(np.array([0, 0, np.sin(np.pi / 4), np.cos(np.pi / 4)]))  # 90 deg about z: x -> y
    c, n, a = one_face([1, 0, 0], [0, 0, 0], 1.0)
    f, _ = drag_wrench(rot, np.array([0, 2.0, 0]), np.zeros(3), c, n, a, drag_coefficient=1.0, fluid_density=1.0)
    np.testing.assert_allclose(f, [0, -2.0, 0], atol=1e-12)


@pytest.mark.parametrize("law", ["quadratic", "linear"])
def test_box_closed_form_equals_per_face_reference(law):
    rng = np.random.default_rng(3)
    q = rng.normal(size=(5, 4))
    rot = quat_to_matrix(q / np.linalg.norm(q, axis=1, keepdims=True))
    size = rng.uniform(0, 2, size=(5, 3))
    offset = rng.normal(size=(5, 3))
    v, w = rng.normal(size=(5, 3)), rng.normal(size=(5, 3))
    c, n, a = box_faces(size)
    f_ref, t_ref = drag_wrench(rot, v, w, c + offset[:, None], n, a, drag_coefficient=0.9, fluid_density=1.2, drag_law=law, water_current=(0.1, 0.2, 0.3))
    f_loc, t_loc = box_drag(rot, v, w, offset, a[:, ::2], drag_coefficient=0.9, fluid_density=1.2, drag_law=law, water_current=(0.1, 0.2, 0.3))
    np.testing.assert_allclose(np.einsum("nij,nj->ni", rot, f_loc), f_ref, atol=1e-12)
    np.testing.assert_allclose(np.einsum("nij,nj->ni", rot, t_loc), t_ref, atol=1e-12)


def test_zero_size_box_has_no_drag_and_no_nan():
    c, n, a = box_faces(np.zeros((1, 3)))
    f, t = drag_wrench(I3[None], np.ones((1, 3)), np.ones((1, 3)), c, n, a, drag_coefficient=1.0, fluid_density=1.0)
    assert np.all(f == 0) and np.all(t == 0)


def test_righting_torque_of_rolled_body():
    # rolled by 30 deg about +y (right side down): the couple m g h sin(30) turns it back (about -y)
    th = np.radians(30)
    rot = np.array([[np.cos(th), 0, np.sin(th)], [0, 1, 0], [-np.sin(th), 0, np.cos(th)]])
    t = righting_torque(rot, np.array(2.0), gravity=10.0, ballast_offset=0.1)
    np.testing.assert_allclose(t, [0, -2.0 * 10.0 * 0.1 * np.sin(th), 0], atol=1e-12)


def test_unknown_drag_law_raises():
    c, n, a = one_face([1, 0, 0], [0, 0, 0], 1.0)
    with pytest.raises(ValueError, match="drag_law"):
        drag_wrench(I3, np.ones(3), np.zeros(3), c, n, a, drag_coefficient=1.0, fluid_density=1.0, drag_law="cubic")


# -- Lighthill's reactive force at the trailing edge (Lighthill 1971) ----------------------
T_FIN = np.array([0.0, -1.0, 0.0])  # along the fin, towards the trailing edge
N_FIN = np.array([1.0, 0.0, 0.0])
TE = np.array([0.0, -0.5, 0.0])  # trailing edge 0.5 behind the centre of mass


def test_added_mass_per_length_is_a_water_cylinder_of_the_fin_height():
    assert added_mass_per_length(0.4, 1.0) == pytest.approx(np.pi * 0.04)  # (pi/4) rho s^2
    assert added_mass_per_length(0.4, 2.0) == pytest.approx(2 * np.pi * 0.04)
    assert added_mass_per_length(0.0, 1.0) == 0.0


def test_reactive_force_on_a_fin_pitching_in_still_water_is_pure_thrust():
    # fin turning at 2 rad/s about z: the trailing edge moves at w x r = (1, 0, 0), i.e. w = 1, u = 0
    m = np.pi * 0.04
    f, t = reactive_force(I3, np.zeros(3), np.array([0, 0, 2.0]), TE, T_FIN, N_FIN, m)
    np.testing.assert_allclose(f, [0.0, m / 2, 0.0], atol=1e-15)  # -(1/2) m w^2 t: forward, towards the hinge
    np.testing.assert_allclose(t, 0.0, atol=1e-15)  # along the lever arm: no moment


def test_reactive_force_on_a_swimming_fin_matches_hand_value():
    # swimming forward at 0.3: v_te = (1, 0.3, 0), u = v_te . t = -0.3, w = 1
    m = np.pi * 0.04  # 0.1256637
    f, t = reactive_force(I3, np.array([0, 0.3, 0]), np.array([0, 0, 2.0]), TE, T_FIN, N_FIN, m)
    # F = m w u n - (1/2) m w^2 t = (-0.0376991, 0.0628319, 0); moment (0, -0.5, 0) x F = (0, 0, -0.0188496)
    np.testing.assert_allclose(f, [-0.0376991, 0.0628319, 0.0], atol=1e-7)
    np.testing.assert_allclose(t, [0.0, 0.0, -0.0188496], atol=1e-7)
    # the same relative velocity from a water current instead of the fin's own motion
    f_current, _ = reactive_force(I3, np.zeros(3), np.array([0, 0, 2.0]), TE, T_FIN, N_FIN, m, water_current=(0, -0.3, 0))
    np.testing.assert_allclose(f_current, f, atol=1e-15)


def test_reactive_force_does_not_depend_on_the_normal_sign_and_turns_with_the_link():
    rng = np.random.default_rng(5)
    q = rng.normal(size=(4, 4))
    rot = quat_to_matrix(q / np.linalg.norm(q, axis=1, keepdims=True))
    v, w = rng.normal(size=(4, 3)), rng.normal(size=(4, 3))
    f, t = reactive_force(rot, v, w, np.tile(TE, (4, 1)), T_FIN, N_FIN, np.full(4, 0.1))
    f_flip, t_flip = reactive_force(rot, v, w, np.tile(TE, (4, 1)), T_FIN, -N_FIN, np.full(4, 0.1))
    np.testing.assert_allclose(f_flip, f, atol=1e-15)
    np.testing.assert_allclose(t_flip, t, atol=1e-15)
    # the link-frame result equals the one computed from link-frame velocities with R = I
    v_l, w_l = np.einsum("nji,nj->ni", rot, v), np.einsum("nji,nj->ni", rot, w)
    f_local, _ = reactive_force(np.broadcast_to(I3, (4, 3, 3)), v_l, w_l, np.tile(TE, (4, 1)), T_FIN, N_FIN, np.full(4, 0.1))
    np.testing.assert_allclose(f, f_local, atol=1e-12)


def test_reactive_force_of_a_fin_without_added_mass_is_zero():
    f, t = reactive_force(I3, np.ones(3), np.ones(3), TE, T_FIN, N_FIN, 0.0)
    assert np.all(f == 0) and np.all(t == 0)


def test_caudal_closed_form_equals_the_general_reactive_force():
    rng = np.random.default_rng(7)
    q = rng.normal(size=(6, 4))
    rot = quat_to_matrix(q / np.linalg.norm(q, axis=1, keepdims=True))
    v, w = rng.normal(size=(6, 3)), rng.normal(size=(6, 3))
    half, m = rng.uniform(0, 1, 6), rng.uniform(0, 0.3, 6)
    edge = np.stack([np.zeros(6), -half, np.zeros(6)], axis=1)
    f_ref, t_ref = reactive_force(rot, v, w, edge, T_FIN, N_FIN, m, water_current=(0.1, -0.2, 0.3))
    f, t = caudal_reactive_force(rot, v, w, half, m, water_current=(0.1, -0.2, 0.3))
    np.testing.assert_allclose(f, f_ref, atol=1e-14)
    np.testing.assert_allclose(t, t_ref, atol=1e-14)
