"""First-success tables and paired comparisons of sweeps (analysis.first_success)."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest
from scipy.stats import binomtest

from analysis.first_success import (
    compare_seed,
    first_successes,
    paired,
    paired_markdown,
    solved_by_trial,
)
from analysis.stats import sign_test
from analysis.thesis import configuration_label, precision_tag, thesis_label

ROOT = Path(__file__).resolve().parent.parent


def trials_of(configuration: str, seed: int, successes: list[bool]) -> pd.DataFrame:
    """The rows load_sweep gives for one run: trial 0 (exploration) and the learned trials
    with their success flags."""
    return pd.DataFrame(
        {
            "trial": list(range(len(successes) + 1)),
            "success": [False, *successes],
            "configuration": configuration,
            "seed": seed,
            "run": f"/runs/{configuration}/{seed}",
        }
    )


def sweep() -> pd.DataFrame:
    return pd.concat(
        [
            trials_of("A", 0, [False, True]),  # solved at T2, stopped there
            trials_of("A", 1, [False, False, False]),  # unfinished after T3
            trials_of("A", 2, [False, False, True, False]),  # solved at T3, failed again at T4
            trials_of("B", 0, [False, False, False, True]),  # T4
            trials_of("B", 1, [True]),  # T1
            trials_of("B", 3, [False]),  # a seed A does not have
        ],
        ignore_index=True,
    )


@pytest.mark.parametrize("wins,losses", [(0, 0), (1, 0), (5, 0), (3, 1), (6, 4), (2, 9), (10, 10)])
def test_sign_test_is_scipys_exact_binomial_test(wins: int, losses: int) -> None:
    expected = 1.0 if wins + losses == 0 else binomtest(wins, wins + losses).pvalue
    assert sign_test(wins, losses) == pytest.approx(expected, rel=1e-12)


def test_solved_by_trial_counts_runs_only_as_far_as_they_were_observed() -> None:
    runs = first_successes(sweep())
    firsts = runs.set_index(["configuration", "seed"])["first_success"]
    assert firsts[("A", 0)] == 2 and pd.isna(firsts[("A", 1)]) and firsts[("A", 2)] == 3
    table = solved_by_trial(runs)
    a = table[table["configuration"] == "A"].set_index("trial")
    # seed 1 is unfinished after T3: out of the count at T4; seed 0 stopped at its success
    assert a[["solved", "observed"]].to_dict("index") == {
        1: {"solved": 0, "observed": 3},
        2: {"solved": 1, "observed": 3},
        3: {"solved": 2, "observed": 3},
        4: {"solved": 2, "observed": 2},
    }
    assert a.loc[4, "rate"] == 1.0 and a.loc[4, "wilson_low"] < 1.0
    b = table[table["configuration"] == "B"].set_index("trial")
    assert b.loc[1, ["solved", "observed"]].tolist() == [1, 3]
    assert b.loc[4, ["solved", "observed"]].tolist() == [2, 2]  # seed 3 stopped after T1


@pytest.mark.parametrize(
    "first_a,last_a,first_b,last_b,expected",
    [
        (3, 3, 5, 5, ("a", 3)),
        (5, 5, 2, 2, ("b", 2)),
        (3, 3, 3, 4, ("same", 3)),
        (3, 3, None, 5, ("a", 3)),  # B ran past A's success without solving
        (3, 3, None, 3, ("a", 3)),  # B finished trial 3 unsolved
        (3, 3, None, 2, ("undecided", 2)),  # B stopped before trial 3
        (None, 5, None, 5, ("same", 5)),  # neither solved over the same horizon
        (None, 5, None, 3, ("undecided", 3)),
    ],
)
def test_compare_seed(
    first_a: int | None, last_a: int, first_b: int | None, last_b: int, expected: tuple
) -> None:
    assert compare_seed(first_a, last_a, first_b, last_b) == expected
    swapped = {"a": "b", "b": "a"}.get(expected[0], expected[0])
    assert compare_seed(first_b, last_b, first_a, last_a) == (swapped, expected[1])


def test_paired_uses_the_seeds_both_configurations_ran() -> None:
    runs = first_successes(sweep())
    table = paired(runs, "A", "B").set_index("seed")
    assert list(table.index) == [0, 1]  # seed 2 only in A, seed 3 only in B
    assert table.loc[0, "earlier"] == "a" and table.loc[1, "earlier"] == "b"
    text = paired_markdown(runs)
    assert "A earlier on 1, B earlier on 1" in text and "p = 1" in text


def test_a_precision_or_reduction_of_its_own_is_its_own_configuration() -> None:
    from hydra import compose, initialize_config_dir
    from omegaconf import OmegaConf

    labels = {}
    relative = ["model.reduction_threshold=0.5", "model.reduction_mode=relative"]
    for overrides in (
        [],
        ["rollout_dtype=float32"],
        ["dtype=float32"],
        ["protocol=quick"],
        relative,
        ["model.reduction_threshold=1e-3"],
        ["rollout_dtype=float32", *relative],
        ["+experiment=furuta_pms"],
        ["+experiment=furuta_pms", *relative],
    ):
        with initialize_config_dir(version_base="1.3", config_dir=str(ROOT / "conf")):
            config = OmegaConf.to_container(compose("train", overrides=overrides), resolve=True)
        assert isinstance(config, dict)
        labels[tuple(overrides)] = configuration_label(config)  # type: ignore[arg-type]
    plain = labels[()]
    assert labels[("rollout_dtype=float32",)] == f"{plain} [float32 rollout]"
    assert labels[("dtype=float32",)] == f"{plain} [float32]"
    assert labels[tuple(relative)] == f"{plain} [reduction 0.5σ_n]"
    assert labels[("model.reduction_threshold=1e-3",)] == f"{plain} [reduction β=0.001]"
    assert labels[("rollout_dtype=float32", *relative)] == (
        f"{plain} [float32 rollout] [reduction 0.5σ_n]"
    )
    furuta = labels[("+experiment=furuta_pms",)]  # its preset's β = 1e-3 is the thesis's
    assert furuta == "FurutaPendulum: PMS S.I., SE, dropout, l=()"
    assert labels[("+experiment=furuta_pms", *relative)] == f"{furuta} [reduction 0.5σ_n]"
    assert {thesis_label(label) for label in labels.values()} == {plain, furuta}
    assert precision_tag({}) is None  # configs from before the keys existed: float64
    assert precision_tag({"dtype": "float64", "rollout_dtype": "float64"}) is None
