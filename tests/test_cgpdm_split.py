"""The CGPDM's training/test split keys and the CSV checks (issue 57): indices honoured,
bad ones refused in one line, the split recorded; each malformed CSV data set refused
before training with its file named."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from mcpilco.cloth.dataset import ClothDataset, read_csv_sequences
from mcpilco.errors import ConfigError
from mcpilco.latent.split import SequenceSplit, sequence_numbers
from mcpilco.latent.study import split


def numbered_dataset(numbers: list[int]) -> ClothDataset:
    """Sequences numbered like the authors' CSV files (not 0..S-1), 4 steps, 6 coords."""
    s = len(numbers)
    return ClothDataset(np.zeros((s, 4, 6)), np.zeros((s, 3, 3)), np.asarray(numbers))


def test_the_default_rule_is_the_last_test_sequences_and_a_seeded_draw() -> None:
    """The study's rule, written out independently: test = the last num_test rows, train =
    the first num_train of the permutation seeded by [draw, 0xC10] of the rest."""
    dataset = numbered_dataset(list(range(1, 21)))
    train, test = split(dataset, num_test=5, num_train=4, draw=3)
    order = np.random.default_rng(np.random.SeedSequence([3, 0xC10])).permutation(15)
    assert test == [15, 16, 17, 18, 19]
    assert train == sorted(order[:4].tolist())


def test_explicit_sequence_numbers_are_honoured_and_recorded() -> None:
    dataset = numbered_dataset(list(range(1, 52)))  # files 1..51, as published
    rule = SequenceSplit(10, 10, 0, train=(1, 5, 9), test=tuple(range(41, 51)))
    train, test = rule.rows(dataset)
    assert dataset.indices[train].tolist() == [1, 5, 9]
    assert dataset.indices[test].tolist() == list(range(41, 51))  # not the last ten (42..51)
    record = rule.record(dataset, train, test)
    assert record["train"] == [1, 5, 9] and record["test"] == list(range(41, 51))
    assert record["train_rule"] == "given" and record["test_rule"] == "given"
    # only the test set given: the training set is drawn from the others, never from it
    drawn, test = SequenceSplit(30, 10, 2, test=tuple(range(41, 51))).rows(dataset)
    numbers = set(dataset.indices[drawn].tolist())
    assert len(numbers) == 30 and not numbers & set(range(41, 51))


@pytest.mark.parametrize(
    ("rule", "message"),
    [
        (dict(train=(1, 99)), r"^data\.train_sequences names \[99\], not in the data"),
        (dict(test=(0,)), r"^data\.test_sequences names \[0\], not in the data set"),
        (
            dict(train=(1, 2), test=(2, 3)),
            r"^data\.train_sequences and data\.test_sequen\w+ share \[2\]",
        ),
    ],
)
def test_bad_sequence_numbers_are_refused_in_one_line(rule: dict, message: str) -> None:
    dataset = numbered_dataset(list(range(1, 11)))
    with pytest.raises(ConfigError, match=message) as error:
        SequenceSplit(3, 2, 0, **rule).rows(dataset)
    assert "\n" not in str(error.value)


def test_overlap_only_when_asked_and_malformed_lists() -> None:
    dataset = numbered_dataset(list(range(1, 11)))
    train, test = SequenceSplit(3, 2, 0, (1, 2), (2, 3), allow_overlap=True).rows(dataset)
    assert set(dataset.indices[train]) & set(dataset.indices[test]) == {2}
    for bad in ("abc", [], [1, 1], [-1], [1.5], [True], 5):
        with pytest.raises(ConfigError, match=r"^data\.train_sequences="):
            sequence_numbers("data.train_sequences", bad)


def write_csv_set(folder: Path, count: int = 4, rows: int = 6, points: int = 3) -> None:
    rng = np.random.default_rng(0)
    folder.mkdir(parents=True, exist_ok=True)
    for k in range(1, count + 1):
        np.savetxt(folder / f"state_samples_x_{k}.csv", rng.normal(size=(rows, 3 * points)),
                   delimiter=",")  # fmt: skip
        np.savetxt(folder / f"input_samples_x_{k}.csv", rng.normal(size=(rows, 3)), delimiter=",")


def rewrite(name: str, rows: int, columns: int):  # noqa: ANN201
    return lambda folder: np.savetxt(folder / name, np.ones((rows, columns)), delimiter=",")


@pytest.mark.parametrize(
    ("damage", "message"),
    [
        (
            lambda f: (f / "state_samples_x_2.csv").write_text("1,2,abc\n"),
            r"^state\w+_2\.csv: not a numeric",
        ),
        (lambda f: (f / "input_samples_x_3.csv").write_text(""), r"^input\w+_3\.csv: no rows"),
        (rewrite("state_samples_x_2.csv", 6, 8), r"^state\w+_2\.csv: 8 columns, not x y z"),
        (rewrite("state_samples_x_3.csv", 6, 12), r"^state\w+_3\.csv: 12 columns, but the first"),
        (rewrite("state_samples_x_4.csv", 5, 9), r"^state\w+_4\.csv: 5 rows, but the first"),
        (rewrite("input_samples_x_2.csv", 6, 6), r"^input\w+_2\.csv: 6 columns, but the first"),
        (rewrite("input_samples_x_2.csv", 4, 3), r"^input\w+_2\.csv: 4 rows, need 5"),
        (rewrite("input_samples_x_9.csv", 6, 3), r"^data\.csv_dir: input\w+_9\.csv has no state"),
        (
            lambda f: (f / "input_samples_x_4.csv").unlink(),
            r"^data\.csv_dir: state\w+_4\.csv has no",
        ),
    ],
)
def test_each_malformed_csv_data_set_is_refused_naming_the_file(
    tmp_path: Path, damage, message: str
) -> None:
    write_csv_set(tmp_path)
    assert read_csv_sequences(tmp_path).controls.shape == (4, 5, 3)  # the file's 3 columns
    damage(tmp_path)
    with pytest.raises(ConfigError, match=message) as error:
        read_csv_sequences(tmp_path)
    assert "\n" not in str(error.value)


TINY = ["excitation.num_samples=6", "train.steps=1", "train.iterations_per_step=3",
        "threads=1", "cgpdm.latent_dim=2", "tracking.mcap=false"]  # fmt: skip


def run_cgpdm(tmp_path: Path, *overrides: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "runners.cgpdm", *TINY, f"data.csv_dir={tmp_path / 'csv'}",
         f"hydra.run.dir={tmp_path / 'run'}", *overrides],
        capture_output=True, text=True, timeout=600,
    )  # fmt: skip


def test_the_runner_trains_on_the_given_sequences_and_records_them(tmp_path: Path) -> None:
    write_csv_set(tmp_path / "csv", count=6, rows=6, points=4)
    done = run_cgpdm(tmp_path, "data.train_sequences=[2,5]", "data.test_sequences=[1,3]")
    assert done.returncode == 0, done.stderr[-3000:]
    record = json.loads((tmp_path / "run" / "training_set.json").read_text())
    assert record["train"] == [2, 5] and record["test"] == [1, 3]
    assert record["units"] == "unitless" and "label" in record["range_deg"]["meaning"]
    summary = pd.read_csv(tmp_path / "run" / "summary.csv")
    assert summary["sequence"].tolist() == [1, 3] and set(summary["num_train"]) == {2}
    assert {"error_unitless", "still_error_unitless", "rigid_error_unitless"} <= set(summary)
    assert not any(column.endswith("_m") for column in summary)  # no metres claimed
    refused = run_cgpdm(tmp_path, "data.train_sequences=[2,7]", "overwrite=true")
    assert refused.returncode != 0
    output = (refused.stdout + refused.stderr).splitlines()
    lines = [line for line in output if "data.train_sequences" in line]
    assert lines and "names [7], not in the data set" in lines[0]


def test_the_report_carries_the_units_and_refuses_to_mix_them() -> None:
    from analysis.cgpdm_report import cells, markdown, with_units

    def models(units: str, draws: range) -> pd.DataFrame:
        return pd.DataFrame(
            {
                "range_deg": 30, "variant": "high", "num_train": 5, "draw": list(draws),
                f"error_{units}": [1.0, 2.0, 3.0][: len(draws)], f"still_error_{units}": 4.0,
                f"rigid_error_{units}": 5.0, "fit_seconds": 1.0, "predict_seconds": 0.1,
                "left_region": 0.0,
            }
        )  # fmt: skip

    text = markdown(cells(models("mm", range(3))))
    assert "error (mm), mean ± 95 % CI" in text and "still (mm)" in text
    assert "| 2.0000 ±" in text  # the mean of 1, 2, 3
    mixed = pd.concat(
        [with_units(models("mm", range(2))), with_units(models("unitless", range(2, 4)))]
    )
    with pytest.raises(ValueError, match=r"different units \['mm', 'unitless'\]"):
        cells(mixed)
