"""The UR5 MJCF model against its DH parameters: kinematics and static gravity torques."""

from __future__ import annotations

import mujoco
import numpy as np

from mcpilco.systems.ur5_model import (
    CENTRES_OF_MASS,
    DH_A,
    DH_ALPHA,
    DH_D,
    MASSES,
    dh_forward_kinematics,
    dh_transform,
    ur5_mjcf,
)


def model_and_data() -> tuple[mujoco.MjModel, mujoco.MjData]:
    model = mujoco.MjModel.from_xml_string(ur5_mjcf())
    return model, mujoco.MjData(model)


def test_forward_kinematics_matches_the_dh_chain() -> None:
    model, data = model_and_data()
    site = model.site("flange").id
    for q in np.random.default_rng(0).uniform(-np.pi, np.pi, size=(20, 6)):
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        pose = dh_forward_kinematics(q)
        np.testing.assert_allclose(data.site_xpos[site], pose[:3, 3], atol=1e-12)
        np.testing.assert_allclose(data.site_xmat[site].reshape(3, 3), pose[:3, :3], atol=1e-12)
    data.qpos[:] = 0.0  # the published zero pose: flange at x = a2 + a3, y = -(d4 + d6)
    mujoco.mj_kinematics(model, data)
    np.testing.assert_allclose(data.site_xpos[site], [-0.81725, -0.19145, -0.005491], atol=1e-9)


def test_static_torques_equal_the_gradient_of_the_potential_energy() -> None:
    """mj_inverse at rest against τ_j = Σ_k m_k g ẑ·(z_j × (c_k − o_j)) from the DH chain."""
    model, data = model_and_data()
    g = 9.81
    for q in np.random.default_rng(1).uniform(-np.pi, np.pi, size=(5, 6)):
        frames = [np.eye(4)]
        for angle, d, a, alpha in zip(q, DH_D, DH_A, DH_ALPHA, strict=True):
            frames.append(frames[-1] @ dh_transform(angle, d, a, alpha))
        centres = [frames[k + 1] @ np.array([*CENTRES_OF_MASS[k], 1.0]) for k in range(6)]
        expected = np.zeros(6)
        for j in range(6):
            axis, origin = frames[j][:3, 2], frames[j][:3, 3]
            for k in range(j, 6):
                lever = np.cross(axis, centres[k][:3] - origin)
                expected[j] += MASSES[k] * g * lever[2]
        data.qpos[:] = q
        data.qvel[:] = 0.0
        data.qacc[:] = 0.0
        mujoco.mj_inverse(model, data)
        np.testing.assert_allclose(data.qfrc_inverse, expected, atol=1e-9)
    assert abs(model.body_subtreemass[1] - sum(MASSES)) < 1e-12
