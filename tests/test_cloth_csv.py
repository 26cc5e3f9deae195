"""Writing a data set in the authors' CSV layout (``analysis.cloth_csv``): what is written
reads back through ``read_csv_sequences`` (the runner's reader) with the same numbers, the
shared 3-D increment only where both grips' columns are equal, bad input in one line."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from mcpilco.cloth.csv_layout import write_csv_sequences
from mcpilco.cloth.dataset import ClothDataset, read_csv_sequences
from mcpilco.errors import ConfigError


def dataset(shared: bool) -> ClothDataset:
    rng = np.random.default_rng(4)
    grip = rng.normal(size=(3, 7, 3)) * 0.1
    other = grip if shared else grip + 1e-3
    return ClothDataset(
        rng.normal(size=(3, 8, 12)), np.concatenate([grip, other], -1), np.array([0, 5, 11]), {}
    )


@pytest.mark.parametrize("shared", [True, False])
def test_written_files_read_back_exactly(tmp_path: Path, shared: bool) -> None:
    data = dataset(shared=True)
    paths = write_csv_sequences(data, tmp_path, stem="ext", shared_increment=shared)
    assert sorted(p.name for p in paths)[:2] == [
        "input_samples_ext_0.csv",
        "input_samples_ext_11.csv",
    ]
    back = read_csv_sequences(tmp_path)
    np.testing.assert_array_equal(back.indices, [0, 5, 11])
    np.testing.assert_array_equal(back.observations, data.observations)  # %.17g: exact
    np.testing.assert_array_equal(
        back.controls, data.controls[..., :3] if shared else data.controls
    )
    assert not list(tmp_path.glob(".*"))  # no partial file left


def test_a_shared_increment_is_refused_where_the_grips_differ(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="not one 3-D increment"):
        write_csv_sequences(dataset(shared=False), tmp_path, shared_increment=True)
    assert not list(tmp_path.iterdir())


def test_the_command_writes_a_saved_data_set_and_refuses_a_missing_one(tmp_path: Path) -> None:
    dataset(shared=True).save(tmp_path / "R30.npz")
    command = [sys.executable, "-m", "analysis.cloth_csv", str(tmp_path / "R30.npz")]
    done = subprocess.run([*command, str(tmp_path / "csv"), "--shared-increment"],
                          capture_output=True, text=True, timeout=120)  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert read_csv_sequences(tmp_path / "csv").controls.shape == (3, 7, 3)
    missing = subprocess.run(
        [*command[:-1], str(tmp_path / "no.npz"), str(tmp_path / "x")],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert missing.returncode == 2 and "Traceback" not in missing.stderr
    assert len(missing.stderr.strip().splitlines()) == 1 and "no.npz" in missing.stderr
