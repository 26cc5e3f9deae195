"""Writing a cloth data set in the CSV layout of the authors' public CGPDM library (the
layout :func:`mcpilco.cloth.dataset.read_csv_sequences` reads), so that a data set made by
the simulator can be given to that library, or to ``runners.cgpdm data.csv_dir=...``.

Per sequence number k: ``state_samples_<stem>_k.csv`` (N rows: x₁ y₁ z₁ x₂ … of every
point) and ``input_samples_<stem>_k.csv`` (N − 1 rows: the controls). With
``shared_increment`` the controls are written as the one 3-D increment that both held
corners share (the library's layout), which is refused unless the two grips' columns are
equal.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mcpilco.cloth.dataset import ClothDataset
from mcpilco.errors import ConfigError


def write_csv_sequences(
    dataset: ClothDataset, directory: Path, stem: str = "cloth", shared_increment: bool = False
) -> list[Path]:
    """Write every sequence of ``dataset`` into ``directory`` (created); the paths written.

    Args:
        dataset: observations ``[S, N, D]``, controls ``[S, N−1, E]``.
        directory: where the files go; existing files of the same names are replaced.
        stem: the middle of the file names (letters, digits and ``_``).
        shared_increment: write the first 3 control columns only, which must equal the
            other 3 (E = 6: both grips moved by the same displacement).
    """
    if not stem.replace("_", "").isalnum():
        raise ConfigError(f"stem={stem!r} must be letters, digits and _")
    controls = dataset.controls
    if shared_increment:
        if controls.shape[-1] != 6 or not np.array_equal(controls[..., :3], controls[..., 3:]):
            raise ConfigError(
                f"shared_increment: the controls {controls.shape} are not one 3-D increment "
                "repeated for both grips"
            )
        controls = controls[..., :3]
    directory.mkdir(parents=True, exist_ok=True)
    written = []
    for row, number in enumerate(dataset.indices):
        for kind, values in (("state", dataset.observations[row]), ("input", controls[row])):
            path = directory / f"{kind}_samples_{stem}_{int(number)}.csv"
            partial = path.with_name(f".{path.name}.partial")
            np.savetxt(partial, values, delimiter=",", fmt="%.17g")
            partial.replace(path)
            written.append(path)
    return written
