"""Reports name a run's settings where they are not the thesis's (analysis.thesis)."""

from __future__ import annotations

from pathlib import Path

from hydra import compose, initialize_config_dir
from omegaconf import OmegaConf

from analysis.thesis import budget_tag, configuration_label

CONF = str(Path(__file__).resolve().parent.parent / "conf")


def composed(*overrides: str) -> dict:
    with initialize_config_dir(version_base="1.3", config_dir=CONF):
        config = OmegaConf.to_container(compose("train", overrides=list(overrides)), resolve=True)
    assert isinstance(config, dict)
    return config


def test_the_smoke_preset_is_labelled_by_what_differs_from_the_thesis() -> None:
    tag = budget_tag(composed("+experiment=smoke"))
    # Table 2.1 / §2.5: M 400, N_opt 2000 (trial 1) and 4000, n_b 200, T 3 s
    assert tag == "not the thesis's budget: M 8, N_opt T1 4, N_opt 4, n_b 10, T (s) 1"


def test_the_thesis_settings_and_the_named_quick_protocol_carry_no_budget_tag() -> None:
    assert budget_tag(composed()) is None
    assert budget_tag(composed("kernel=sp")) is None
    assert budget_tag(composed("protocol=quick")) is None  # labelled [quick] instead
    assert configuration_label(composed("protocol=quick")).endswith("[quick]")
    assert budget_tag(composed("optimizer.num_particles=100")) == "not the thesis's budget: M 100"
