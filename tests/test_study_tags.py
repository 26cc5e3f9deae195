"""Runs that share a thesis-style label but are different experiments get told apart
(analysis.study_tags, through analysis.sweep.load_sweep)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pandas as pd
from hydra import compose, initialize_config_dir
from omegaconf import OmegaConf

from analysis.study_tags import distinguished_labels, flatten
from analysis.sweep import load_sweep
from analysis.thesis import configuration_label

ROOT = Path(__file__).resolve().parent.parent
BASE = "S.I., SE, dropout, l=(3,1)"


def composed(*overrides: str) -> dict[str, Any]:
    with initialize_config_dir(version_base="1.3", config_dir=str(ROOT / "conf")):
        cfg = compose("train", overrides=list(overrides))
    config = OmegaConf.to_container(cfg, resolve=True)
    assert isinstance(config, dict)
    return config


def labelled(
    configs: dict[str, dict[str, Any]], defaults: dict[str, Any] | None = None
) -> dict[str, str]:
    labels = {run: configuration_label(config) for run, config in configs.items()}
    return distinguished_labels(labels, configs, defaults)


def test_seeds_and_machine_settings_do_not_make_another_experiment() -> None:
    configs = {
        "a": composed("seed=0"),
        "b": composed("seed=1", "threads=1", "compile=false", "num_trials=3", "device=cuda"),
        "c": composed("seed=2", "compile_steps=6", "tracking.rerun=save"),
    }
    assert labelled(configs) == {"a": BASE, "b": BASE, "c": BASE}


def test_a_schedule_setting_outside_the_label_splits_the_row() -> None:
    configs = {
        "default": composed("seed=0"),
        "short": composed("seed=0", "optimizer.schedule.window=100"),
        "short_1": composed("seed=1", "optimizer.schedule.window=100"),
        "sp": composed("kernel=sp", "optimizer.num_particles=100"),  # alone under its label
    }
    assert labelled(configs) == {
        "default": f"{BASE} [optimizer.schedule.window=200]",
        "short": f"{BASE} [optimizer.schedule.window=100]",
        "short_1": f"{BASE} [optimizer.schedule.window=100]",
        "sp": "S.I., PI+SE, dropout, l=(3,1)",
    }


def test_every_differing_value_is_named_in_key_order() -> None:
    configs = {
        "a": composed("optimizer.num_particles=100", "optimizer.schedule.threshold=0.1"),
        "b": composed(),
    }
    assert labelled(configs)["a"] == (
        f"{BASE} [optimizer.num_particles=100; optimizer.schedule.threshold=0.1]"
    )
    assert labelled(configs)["b"] == (
        f"{BASE} [optimizer.num_particles=400; optimizer.schedule.threshold=0.08]"
    )


def test_a_key_an_older_config_lacks_is_not_a_difference() -> None:
    new, old = composed(), composed()
    del old["optimizer"]["horizon_stages"]
    assert labelled({"new": new, "old": old}) == {"new": BASE, "old": BASE}


def test_a_newer_key_set_away_from_its_default_sets_its_runs_apart() -> None:
    # Runs written before optimizer.schedule.bias_correction existed say nothing of it: a run
    # that turns it on is told apart from them, and they show "—", not a guessed value.
    older = composed("optimizer.schedule.window=100")
    del older["optimizer"]["schedule"]["bias_correction"]
    corrected = composed("optimizer.schedule.window=100", "optimizer.schedule.bias_correction=true")
    plain = composed("optimizer.schedule.window=100")
    defaults = flatten(composed())
    key = "optimizer.schedule.bias_correction"
    assert labelled({"older": older, "corrected": corrected, "plain": plain}, defaults) == {
        "older": f"{BASE} [{key}=—]",
        "corrected": f"{BASE} [{key}=True]",
        "plain": f"{BASE} [{key}=False]",
    }
    # nobody set it away from today's default: older runs are not set apart
    assert labelled({"older": older, "plain": plain}, defaults) == {"older": BASE, "plain": BASE}
    # without defaults such keys are never compared
    assert labelled({"older": older, "corrected": corrected}) == {
        "older": BASE,
        "corrected": BASE,
    }


def test_a_list_of_kernel_terms_is_compared_term_by_term() -> None:
    plain = composed("kernel=se_linear")
    capped = composed("kernel=se_linear_capped")
    label = configuration_label(plain)
    assert configuration_label(capped) == label  # the thesis's label does not tell them apart
    assert labelled({"plain": plain, "capped": capped}) == {
        "plain": f"{label} [kernel.terms.1.max_weight=None]",
        "capped": f"{label} [kernel.terms.1.max_weight=100.0]",
    }
    # inside a list, a key one run's term lacks is a difference (another kind of term)
    del plain["kernel"]["terms"][1]["max_weight"]
    assert labelled({"plain": plain, "capped": capped})["plain"] == (
        f"{label} [kernel.terms.1.max_weight=—]"
    )
    assert not any(isinstance(value, (dict, list)) for value in flatten(capped).values())


def test_load_sweep_reports_the_two_schedules_as_two_configurations(tmp_path: Path) -> None:
    for name, overrides, success in [
        ("w200_s0", ["seed=0"], True),
        ("w200_s1", ["seed=1"], False),
        ("w100_s0", ["seed=0", "optimizer.schedule.window=100"], False),
    ]:
        run = tmp_path / name
        run.mkdir()
        OmegaConf.save(OmegaConf.create(composed(*overrides)), run / "config.yaml")
        pd.DataFrame({"trial": [0, 1], "success": [False, success]}).to_csv(
            run / "summary.csv", index=False
        )
    trials, failed = load_sweep([tmp_path])
    assert failed == []
    learned = trials[trials["trial"] == 1].set_index("configuration")["success"]
    assert sorted(learned.groupby(level=0).agg(["size", "sum"]).itertuples()) == [
        (f"{BASE} [optimizer.schedule.window=100]", 1, 0),
        (f"{BASE} [optimizer.schedule.window=200]", 2, 1),
    ]
