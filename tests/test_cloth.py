"""The simulated cloth (thesis §6.4.1): exact corner tracking, bounded stretch, deterministic
data sets, the authors' CSV layout, and refusal of a data set of another cloth."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mcpilco.cloth import ClothDataset, ClothParameters, ClothSimulation, Excitation, generate
from mcpilco.cloth.dataset import read_csv_sequences
from mcpilco.cloth.store import DatasetKey, check_compatible, load_or_generate, stability_report
from mcpilco.errors import ConfigError

SHORT = Excitation(num_samples=21)  # 1 s instead of 3 s


@pytest.fixture(scope="module")
def simulation() -> ClothSimulation:
    return ClothSimulation(ClothParameters())


def test_corners_follow_the_commands_exactly_and_the_cloth_swings(
    simulation: ClothSimulation,
) -> None:
    draw = {"gamma_deg": 40.0, "f_y": 0.5, "f_z": 0.35}
    displacements = SHORT.displacements(draw, 0.05)
    vertices, commands = simulation.run(np.concatenate([displacements, displacements], axis=1))
    corners = vertices[:, list(simulation.corner_vertices)]
    np.testing.assert_array_equal(corners, commands)  # exact at every sample
    expected = (
        simulation.corner_home
        + np.concatenate([np.zeros((1, 3)), np.cumsum(displacements, 0)])[:, None]
    )
    np.testing.assert_allclose(commands, expected, atol=1e-15)
    # eq. 6.12 by hand at t = 0.1 s
    gamma = np.radians(40.0)
    np.testing.assert_allclose(
        displacements[2],
        [0.0, -0.01 * np.cos(gamma) * np.cos(2 * np.pi * 0.5 * 0.1),
         0.01 * np.sin(gamma) * np.cos(2 * np.pi * 0.35 * 0.1)],
    )  # fmt: skip
    # the free vertices are not carried rigidly: the lower edge lags the grip by millimetres
    rigid = vertices[:1] + (commands.mean(1) - commands[0].mean(0))[:, None]
    lag = np.linalg.norm(vertices - rigid, axis=-1)
    assert lag[:, 0].max() > 2e-3
    # edges stay near their length (MuJoCo edge equality constraints, stiff solref)
    edges = simulation.edges()
    lengths = np.linalg.norm(vertices[:, edges[:, 0]] - vertices[:, edges[:, 1]], axis=-1)
    stretch = lengths / (simulation.parameters.side / 7) - 1
    assert stretch.max() < 0.02 and abs(stretch.mean()) < 0.005


def test_independent_end_effector_commands_are_followed(simulation: ClothSimulation) -> None:
    controls = np.zeros((5, 6))
    controls[:, 1] = 0.004  # only the left grip moves, along +Y
    vertices, commands = simulation.run(controls)
    left, right = simulation.corner_vertices
    np.testing.assert_allclose(vertices[-1, left] - vertices[0, left], [0, 0.02, 0], atol=1e-15)
    np.testing.assert_array_equal(vertices[:, right], vertices[:1, right].repeat(6, 0))
    with pytest.raises(ConfigError, match=r"\[N-1, 6\]"):
        simulation.run(np.zeros((5, 3)))


def test_data_sets_are_deterministic_per_seed_and_any_subset_matches(
    simulation: ClothSimulation,
) -> None:
    whole = generate(simulation, SHORT, 60.0, seed=3, indices=range(3))
    again = generate(simulation, SHORT, 60.0, seed=3, indices=[2])
    np.testing.assert_array_equal(again.observations[0], whole.observations[2])
    other = generate(simulation, SHORT, 60.0, seed=4, indices=[2])
    assert not np.allclose(other.controls, whole.controls[2:])
    assert whole.observations.shape == (3, 21, 192) and whole.controls.shape == (3, 20, 6)
    gammas = [draw["gamma_deg"] for draw in whole.metadata["draws"].values()]
    assert all(-30 <= g <= 30 for g in gammas)
    report = stability_report(whole, simulation)
    # a lower corner hangs sqrt(0.14² + 0.28²) = 0.313 m from the middle of the grip
    assert report["max_edge_stretch"] < 0.02 and report["max_distance_from_grip_m"] < 0.33


def test_saved_data_sets_round_trip_and_another_cloth_is_refused(
    tmp_path: Path, simulation: ClothSimulation
) -> None:
    dataset = generate(simulation, SHORT, 30.0, seed=0, indices=range(2))
    dataset.save(tmp_path / "d.npz")
    loaded = ClothDataset.load(tmp_path / "d.npz")
    np.testing.assert_array_equal(loaded.observations, dataset.observations)
    check_compatible(loaded, simulation.parameters, SHORT, 30.0, "d.npz")
    with pytest.raises(ConfigError, match=r"made with cloth.mass=0.02, the config has 0.05"):
        check_compatible(loaded, ClothParameters(mass=0.05), SHORT, 30.0, "d.npz")
    with pytest.raises(ConfigError, match=r"data.range_deg=30.0, the config has 60.0"):
        check_compatible(loaded, simulation.parameters, SHORT, 60.0, "d.npz")
    (tmp_path / "d.npz").write_bytes(b"not a zip")
    with pytest.raises(ConfigError, match="cannot be read"):
        ClothDataset.load(tmp_path / "d.npz")


def test_the_cache_simulates_once(tmp_path: Path) -> None:
    parameters = ClothParameters(timestep=0.001, edge_timeconst=0.002)
    key = DatasetKey(parameters, SHORT, 30.0, 0, 2)
    first, path = load_or_generate(tmp_path, key)
    stamp = path.stat().st_mtime_ns
    second, same = load_or_generate(tmp_path, key)
    assert same == path and path.stat().st_mtime_ns == stamp
    np.testing.assert_array_equal(first.observations, second.observations)


def test_csv_sequences_in_the_authors_layout(tmp_path: Path) -> None:
    rng = np.random.default_rng(0)
    states = [rng.normal(size=(7, 192)) for _ in range(2)]
    inputs = [rng.normal(size=(7, 3)) for _ in range(2)]  # as many rows as states
    for k, (y, u) in enumerate(zip(states, inputs, strict=True)):
        np.savetxt(tmp_path / f"state_samples_rng_swing_{k + 10}.csv", y, delimiter=",")
        np.savetxt(tmp_path / f"input_samples_rng_swing_{k + 10}.csv", u, delimiter=",")
    dataset = read_csv_sequences(tmp_path, duplicate_controls=True)
    assert dataset.indices.tolist() == [10, 11]
    np.testing.assert_allclose(dataset.observations[1], states[1])
    np.testing.assert_allclose(dataset.controls[0], np.concatenate([inputs[0][:6]] * 2, axis=1))
    (tmp_path / "input_samples_rng_swing_11.csv").unlink()
    with pytest.raises(ConfigError, match="has no input_samples_rng_swing_11.csv"):
        read_csv_sequences(tmp_path)


@pytest.mark.parametrize(
    ("key", "value", "message"),
    [("mass", 0.0, "cloth.mass must be positive"),
     ("vertex_damping", -1.0, "cloth.vertex_damping must be >= 0"),
     ("sample_dt", 0.0507, "whole multiple of cloth.timestep")],
)  # fmt: skip
def test_bad_cloth_parameters_are_refused(key: str, value: float, message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        ClothParameters(**{key: value})
