"""Candidate CGPDM settings against the current default, on the same training sets.

    python -m analysis.cgpdm_leads MODELS_CSV... --group high:high_c2,high_fixed_wy
        [--group low:low_learned_wy] [--out leads.csv]

Each ``MODELS_CSV`` is a report's per-model table (``analysis.cgpdm_report`` writes it as
``models.csv``: one row per trained model, its mean error over the test sequences); several
are concatenated, and a model given twice (the same R, variant, number of sequences and
draw) is refused in one line naming it. A ``--group BASELINE:CANDIDATE,...`` compares each
candidate with the baseline draw by draw over every (R, sequences, draw) that both hold —
the same training and test sequences, so the difference is the setting's alone: how many
pairs the candidate wins, the mean difference (candidate − baseline, in the errors' units),
the two-sided Wilcoxon signed-rank p-value over the pairs, and the mean over the numbers of
sequences of the cell means (what a default is chosen by). Writes the rows as CSV and logs
them as a Markdown table.
"""

from __future__ import annotations

import argparse
import logging
from pathlib import Path

import pandas as pd
from scipy import stats

log = logging.getLogger("mcpilco.cgpdm_leads")
MODEL_KEY = ["range_deg", "variant", "num_train", "draw"]
"""The columns that name one trained model."""


def combine(tables: list[pd.DataFrame], sources: list[str]) -> pd.DataFrame:
    """The per-model tables as one (each with ``error``/``units`` columns, older tables'
    ``error_<units>`` renamed); ValueError naming the first model two of them hold."""
    tables = [with_units(t) if any(c.startswith("error") for c in t) else t for t in tables]
    for table, source in zip(tables, sources, strict=True):
        missing = [c for c in [*MODEL_KEY, "error"] if c not in table]
        if missing:
            raise ValueError(f"{source}: no column {missing[0]!r} (not a models.csv)")
    labelled = [t.assign(_source=s) for t, s in zip(tables, sources, strict=True)]
    models = pd.concat(labelled, ignore_index=True)
    twice = models[models.duplicated(MODEL_KEY, keep=False)]
    if not twice.empty:
        first = twice.iloc[0]
        key = ", ".join(f"{c}={first[c]}" for c in MODEL_KEY)
        holders = sorted(
            set(twice.loc[(twice[MODEL_KEY] == first[MODEL_KEY]).all(axis=1), "_source"])
        )
        raise ValueError(f"the model {key} is given twice ({' and '.join(holders)})")
    return models.drop(columns="_source")


def with_units(table: pd.DataFrame) -> pd.DataFrame:
    """A summary (or a ``models.csv``) with its error columns ``error_<units>``,
    ``still_error_<units>``, ``rigid_error_<units>`` renamed to ``error``, ``still_error``,
    ``rigid_error`` and the units in a ``units`` column (a table that already has them is
    returned as it is)."""
    if "units" in table and "error" in table:
        return table
    suffixes = [c.removeprefix("error_") for c in table.columns if c.startswith("error_")]
    if len(suffixes) != 1:
        raise KeyError(f"no single error_<units> column among {list(table.columns)}")
    units = suffixes[0]
    renamed = table.rename(
        columns={f"{name}_{units}": name for name in ("error", "still_error", "rigid_error")}
    )
    return renamed.assign(units=units)


def signed_rank_p(difference: pd.Series) -> float:
    """Two-sided Wilcoxon signed-rank p of paired differences; NaN for fewer than 5 pairs or
    all differences zero (where the test says nothing)."""
    if len(difference) < 5 or difference.abs().sum() == 0:
        return float("nan")
    return float(stats.wilcoxon(difference).pvalue)


def compare(models: pd.DataFrame, baseline: str, candidates: list[str]) -> pd.DataFrame:
    """One row per candidate: the draw-by-draw comparison with ``baseline`` (see the
    module's text). A candidate or baseline with no model is a one-line ValueError."""
    for name in (baseline, *candidates):
        if name not in set(models["variant"]):
            raise ValueError(
                f"no model of the variant {name!r} (known: {sorted(set(models.variant))})"
            )
    wide = models.pivot_table(
        index=["range_deg", "num_train", "draw"], columns="variant", values="error"
    )
    rows = []
    for candidate in candidates:
        both = wide[[baseline, candidate]].dropna()
        difference = both[candidate] - both[baseline]
        by_size = both.groupby(level=["range_deg", "num_train"]).mean()
        sizes = sorted(set(both.index.get_level_values("num_train")))
        rows.append(
            {"baseline": baseline, "candidate": candidate, "pairs": len(both),
             "candidate_better": int((difference < 0).sum()),
             "mean_difference": float(difference.mean()) if len(both) else float("nan"),
             "wilcoxon_p": signed_rank_p(difference),
             "baseline_mean_of_cells": float(by_size[baseline].mean()),
             "candidate_mean_of_cells": float(by_size[candidate].mean()),
             "sizes": " ".join(str(n) for n in sizes)}
        )  # fmt: skip
    return pd.DataFrame(rows)


def markdown(comparison: pd.DataFrame) -> str:
    lines = [
        "| baseline | candidate | pairs (sequences) | candidate better | mean difference | "
        "Wilcoxon p | mean of cell means: baseline | candidate |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for row in comparison.itertuples():
        lines.append(
            f"| {row.baseline} | {row.candidate} | {row.pairs} ({row.sizes}) | "
            f"{row.candidate_better} | {row.mean_difference:+.4f} | {row.wilcoxon_p:.3g} | "
            f"{row.baseline_mean_of_cells:.4f} | {row.candidate_mean_of_cells:.4f} |"
        )
    return "\n".join(lines) + "\n"


def parse_group(text: str) -> tuple[str, list[str]]:
    """``BASELINE:A,B`` → (baseline, [A, B]); argparse's one-line error otherwise."""
    baseline, _, rest = text.partition(":")
    candidates = [c for c in rest.split(",") if c]
    if not baseline or not candidates:
        raise argparse.ArgumentTypeError(f"--group {text!r}: expected BASELINE:CANDIDATE[,...]")
    return baseline, candidates


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("models", nargs="+", type=Path, help="models.csv files of CGPDM reports")
    parser.add_argument("--group", type=parse_group, action="append", required=True)
    parser.add_argument("--out", type=Path, help="write the comparison here (CSV)")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    try:
        tables = [pd.read_csv(path) for path in args.models]
        models = combine(tables, [str(path) for path in args.models])
        comparison = pd.concat(
            [compare(models, baseline, candidates) for baseline, candidates in args.group],
            ignore_index=True,
        )
    except (OSError, ValueError, pd.errors.ParserError) as error:
        raise SystemExit(f"cgpdm_leads: {str(error).splitlines()[0]}") from None
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        comparison.to_csv(args.out, index=False)
    log.info("%s", markdown(comparison))


if __name__ == "__main__":
    main()
