"""The thesis's published cart-pole numbers (REFERENCE.md §5), matched to our configs."""

from __future__ import annotations

from typing import Any

SUCCESS_RATES: dict[str, list[float]] = {
    # configuration label -> success rate (%) at trials 1..5, 50 seeds (Figs. 2.4-2.8, Table 4.1)
    "S.I., SE, no dropout, l=(0.75,0.25)": [0, 4, 42, 68, 70],
    "S.I., SE, no dropout, l=(3,1)": [0, 6, 54, 72, 82],
    "S.I., SE, dropout, l=(3,1)": [0, 14, 76, 98, 100],
    "S.I., SE+P(2), dropout, l=(3,1)": [0, 36, 88, 98, 100],
    "S.I., PI+SE, dropout, l=(3,1)": [8, 70, 100, 100, 100],
    "F.S., SE, dropout, l=(3,1)": [0, 12, 70, 98, 100],
    "DF m_q=1 m_u=0, SE, dropout, l=(3,1)": [0, 14, 34, 46, 56],
    "DF m_q=2 m_u=0, SE, dropout, l=(3,1)": [0, 10, 18, 28, 52],
    "DF m_q=1 m_u=1, SE, dropout, l=(3,1)": [0, 8, 52, 86, 96],
    "DF m_q=2 m_u=1, SE, dropout, l=(3,1)": [0, 20, 73, 93, 100],
    "PMS S.I., SE, dropout, l=(3,1)": [0, 14, 82, 98, 96],
    "PILCO": [2, 4, 20, 36, 42],  # Fig. 2.8
    "Black-DROPS": [0, 4, 30, 68, 86],
}

PRECISION: dict[str, tuple[float, float, float, float]] = {
    # Table 2.2: distance from the target over the last second, successful runs at trial 5:
    # (position mean, position std [m], angle mean, angle std [rad])
    "S.I., SE+P(2), dropout, l=(3,1)": (0.008, 0.003, 0.011, 0.004),
    "S.I., PI+SE, dropout, l=(3,1)": (0.008, 0.003, 0.011, 0.005),
    "S.I., SE, dropout, l=(3,1)": (0.010, 0.005, 0.011, 0.005),
    "S.I., SE, no dropout, l=(0.75,0.25)": (0.016, 0.009, 0.012, 0.008),
    "S.I., SE, no dropout, l=(3,1)": (0.019, 0.014, 0.015, 0.009),
    "F.S., SE, dropout, l=(3,1)": (0.011, 0.005, 0.011, 0.005),
    "Black-DROPS": (0.025, 0.011, 0.033, 0.019),
    "PILCO": (0.027, 0.012, 0.045, 0.019),
}

INVERSE_DYNAMICS_NMSE: dict[str, list[float]] = {
    # Fig. 5.3: test-set nMSE (%) per joint 1..7 of the iiwa's inverse-dynamics GPs
    "SE": [3.99, 0.48, 4.22, 0.88, 7.95, 10.86, 4.91],
    "GIP": [0.42, 0.12, 0.55, 0.18, 1.21, 1.80, 1.05],
}

REAL_CLOTH_ERRORS: dict[int, tuple[float, float]] = {
    # §6.5: mean point-to-point error (eq. 6.13, m) ± std of the highly-parameterised CGPDM
    # trained on 10 sequences of the real cloth (Barrett WAM); Fig. 6.5's simulated values
    # are only plotted in the thesis.
    30: (0.012, 0.005),
    60: (0.015, 0.006),
}

SEARCH_NAMES = {"PilcoSearch": "PILCO", "BlackDropsSearch": "Black-DROPS"}
"""Policy searches other than MC-PILCO's, named as the thesis's comparison rows."""

MODEL_NAMES = {"SpeedIntegration": "S.I.", "FullState": "F.S.", "DerivativeFree": "DF"}
KERNEL_NAMES = {
    "SquaredExponential": "SE",
    "MultiplicativePolynomial": "P",
    "PhysicalBasis": "PI",
    "GeometricPolynomial": "GIP",
}


def kernel_label(kernel: dict[str, Any]) -> str:
    """A short name for a kernel config: SE, SE+P(2), PI+SE, ..."""
    target = str(kernel["_target_"]).rsplit(".", 1)[-1]
    if target == "Sum":
        return "+".join(kernel_label(term) for term in kernel["terms"])
    if target == "Product":
        return "·".join(kernel_label(term) for term in kernel["terms"])
    name = KERNEL_NAMES.get(target, target)
    return f"P({kernel['degree']})" if name == "P" else name


def _number(value: float) -> str:
    return f"{value:g}"


CART_POLES = {"CartPole", "CartPoleMujoco"}
"""Systems the published numbers are about (the thesis's cart-pole, either backend)."""


def _system_name(config: dict[str, Any]) -> str:
    return str(config["system"]["_target_"]).rsplit(".", 1)[-1]


THESIS_CARTPOLE_BUDGET = {
    "optimizer.num_particles": ("M", 400),
    "optimizer.max_steps_first_trial": ("N_opt T1", 2000),
    "optimizer.max_steps": ("N_opt", 4000),
    "policy.num_basis": ("n_b", 200),
    "system.trial_duration": ("T (s)", 3.0),
}
"""MC-PILCO's cart-pole budget in the thesis (Table 2.1, §2.5): particles, optimisation steps
(trial 1 and after; the reference code's 2000 for trial 1), basis functions, horizon (s)."""


def _leaf(config: dict[str, Any], dotted: str) -> Any:
    node: Any = config
    for part in dotted.split("."):
        if not isinstance(node, dict) or part not in node:
            return None
        node = node[part]
    return node


def budget_tag(config: dict[str, Any]) -> str | None:
    """``not the thesis's budget: M 8, N_opt 4, …`` for an MC-PILCO cart-pole run under the
    paper protocol whose budget differs from the thesis's (e.g. ``+experiment=smoke``), so its
    rates are never read as the thesis's setting; None otherwise (other systems and
    algorithms have their own budgets; ``protocol=quick`` is labelled by its name)."""
    if _system_name(config) not in CART_POLES:
        return None
    if (config.get("protocol") or {}).get("name", "paper") != "paper":
        return None
    if config.get("algorithm_name", "mcpilco") != "mcpilco":
        return None
    differences = []
    for key, (symbol, thesis) in THESIS_CARTPOLE_BUDGET.items():
        value = _leaf(config, key)
        if value is not None and value != thesis:
            differences.append(
                f"{symbol} {value:g}" if isinstance(value, float) else f"{symbol} {value}"
            )
    return f"not the thesis's budget: {', '.join(differences)}" if differences else None


def configuration_label(config: dict[str, Any]) -> str:
    """Thesis-style name of a run's configuration (everything but the seed that matters
    for the published tables): model structure, kernel, dropout, cost length-scales; other
    systems than the cart-pole are named in front, a protocol other than ``paper`` behind
    (``[quick]``), and so are a precision other than float64 (``[float32 rollout]``) and a GP
    reduction (``[reduction 0.5σ_n]``), so that runs of different studies never share a row."""
    system = _system_name(config)
    protocol = (config.get("protocol") or {}).get("name", "paper")
    label = _configuration(config)
    if system not in CART_POLES:
        label = f"{system}: {label}"
    label = label if protocol == "paper" else f"{label} [{protocol}]"
    for tag in (precision_tag(config), reduction_tag(config)):
        label = label if tag is None else f"{label} [{tag}]"
    return label


def precision_tag(config: dict[str, Any]) -> str | None:
    """``float32`` (everything in float32) or ``float32 rollout`` (the mixed setting:
    float64 GP, float32 particles) for a run that is not all float64, else None: runs of
    another precision are another study (configs from before these keys: float64)."""
    dtype = config.get("dtype") or "float64"
    rollout = config.get("rollout_dtype") or dtype
    if dtype != "float64":
        return str(dtype)
    return None if rollout == dtype else f"{rollout} rollout"


def reduction_tag(config: dict[str, Any]) -> str | None:
    """``reduction 0.5σ_n`` for a GP reduction relative to the noise std (the reference
    code's SoD, in no thesis table), ``reduction β=0.001`` for an absolute one on a cart-pole
    (the thesis reduces there nowhere), else None: the absolute β of the other systems'
    presets is the thesis's own setting (§2.3.3) and names no separate study."""
    model = config.get("model") or {}
    threshold = model.get("reduction_threshold")
    if threshold is None:
        return None
    if model.get("reduction_mode", "absolute") == "relative":
        return f"reduction {_number(threshold)}σ_n"
    return f"reduction β={_number(threshold)}" if _system_name(config) in CART_POLES else None


def thesis_label(label: str) -> str:
    """The published row a configuration label is compared with: the protocol and precision
    tags removed (a quick or mixed-precision study is shown beside the paper's numbers for
    the same configuration)."""
    return label.split(" [", 1)[0]


def _configuration(config: dict[str, Any]) -> str:
    search = str(config["optimizer"]["_target_"]).rsplit(".", 1)[-1]
    if search in SEARCH_NAMES:  # PILCO / Black-DROPS: their recipe's model, kernel and cost
        name = SEARCH_NAMES[search]
        if config["optimizer"].get("initialisation", "pilco") == "policy":
            name += " (policy-group init)"
        return name
    model = config["model"]
    target = str(model["_target_"]).rsplit(".", 1)[-1]
    name = MODEL_NAMES.get(target, target)
    if name == "DF":
        name = f"DF m_q={model.get('m_q')} m_u={model.get('m_u')}"
        if model.get("inputs", "differences") != "differences":
            name += f" {model['inputs']}"
    estimator = str(config.get("estimator", {}).get("_target_", "")).rsplit(".", 1)[-1]
    if estimator not in ("", "FullStateMeasurement"):
        name = f"PMS {name}"
        if not config.get("simulate_estimator", True):
            name += " (estimator not simulated)"
    dropout = config["optimizer"]["schedule"]["dropout"] > 0
    scales = [term.get("length_scale") for term in config["cost"].get("terms", [])]
    cost = "l=(" + ",".join(_number(s) for s in scales if s is not None) + ")"
    parts = [name, kernel_label(config["kernel"]), "dropout" if dropout else "no dropout", cost]
    if config["optimizer"].get("horizon_stages"):  # not in the thesis: named wherever it is used
        parts.append("horizon curriculum")
    return ", ".join(parts)
