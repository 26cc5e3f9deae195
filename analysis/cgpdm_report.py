"""The CGPDM study's table and figures (thesis Fig. 6.3–6.5) from its run directories.

    python -m analysis.cgpdm_report SWEEP_OR_RUN... [--out DIR] [--figure-run RUN]
        [--earlier MODELS_CSV...]

Writes ``errors.md`` and ``errors.csv`` (per range R, variant and number of training
sequences: the mean over draws of each model's mean test error, eq. 6.13, with its 95 %
confidence interval (Student t over the draws), the median, the two baselines, training and
prediction times), ``errors.png/.svg`` (Fig. 6.5) and, for ``--figure-run``, ``latent.png``
(the predicted latent trajectories of two test sequences, Fig. 6.3) and ``frames.png`` (true
against predicted cloth at six instants, Fig. 6.4). Nothing is instantiated: runs are read
as data; runs with ``failed.txt`` or an incomplete summary are listed and left out.
``--earlier`` adds the models of earlier reports' ``models.csv`` (runs no longer on disk, or
measured on another machine); a model both hold is refused in one line.
"""

from __future__ import annotations

import argparse
import logging
from pathlib import Path
from zipfile import BadZipFile

import numpy as np
import pandas as pd
from scipy import stats

from analysis.cgpdm_figures import plot_errors, plot_run, units_of
from analysis.cgpdm_leads import combine, signed_rank_p, with_units
from analysis.thesis import REAL_CLOTH_ERRORS
from mcpilco.errors import RunFileError
from mcpilco.run_contract import CGPDM as CGPDM_KIND
from mcpilco.run_contract import find_runs
from mcpilco.run_storage import RunDirectory

log = logging.getLogger("mcpilco.cgpdm_report")
MODEL_COLUMNS = ["range_deg", "variant", "num_train", "draw"]
UNREADABLE = (RunFileError, OSError, ValueError, KeyError, TypeError, EOFError, BadZipFile)
"""What a damaged summary or ``predictions.npz`` raises (the run is left out)."""


def load_models(paths: list[Path]) -> tuple[pd.DataFrame, list[Path]]:
    """One row per trained model (its mean over the test sequences); and the run
    directories left out (failed, incomplete or unreadable: each named in a warning).
    Directories of other kinds of run are skipped with a warning."""
    rows, left_out = [], []
    for run in find_runs(paths, CGPDM_KIND):
        if (run / "failed.txt").exists():
            left_out.append(run)
            continue
        try:
            table = with_units(RunDirectory(run).summary())
            row = table.groupby([*MODEL_COLUMNS, "units"], as_index=False).agg(
                error=("error", "mean"), still_error=("still_error", "mean"),
                rigid_error=("rigid_error", "mean"), fit_seconds=("fit_seconds", "first"),
                predict_seconds=("predict_seconds", "first"), test_sequences=("error", "size"),
            )  # fmt: skip
            row["left_region"] = left_training_region(run / "predictions.npz")
        except (
            RunFileError,
            OSError,
            ValueError,
            KeyError,
            TypeError,
            EOFError,
            BadZipFile,
        ) as error:
            reason = str(error).strip().splitlines()[0] if str(error).strip() else ""
            log.warning("%s: unreadable (%s: %s)", run, type(error).__name__, reason[:200])
            left_out.append(run)
            continue
        row["run"] = str(run)
        rows.append(row)
    for root in paths:
        for failed in Path(root).rglob("failed.txt"):
            if failed.parent not in left_out and not (failed.parent / "summary.csv").exists():
                left_out.append(failed.parent)
    models = pd.concat(rows, ignore_index=True) if rows else pd.DataFrame(columns=MODEL_COLUMNS)
    return models, left_out


def left_training_region(predictions: Path, margin: float = 0.5) -> float:
    """Fraction of the test sequences whose predicted latent trajectory leaves the box of
    the training latent states widened by ``margin`` × its size on every side (where the
    GPs have no data: the prediction then extrapolates); NaN without the file."""
    if not predictions.exists():
        return float("nan")
    with np.load(predictions) as arrays:
        latent, training = arrays["latent"], arrays["training_latent"]
    low, high = training.min(axis=(0, 1)), training.max(axis=(0, 1))
    size = high - low
    outside = (latent < low - margin * size) | (latent > high + margin * size)
    return float(outside.any(axis=(1, 2)).mean())


def cells(models: pd.DataFrame) -> pd.DataFrame:
    """Per (R, variant, n): mean, 95 % CI half-width and median over the draws."""

    def half_width(values: pd.Series) -> float:
        if len(values) < 2:
            return float("nan")
        return float(
            stats.t.ppf(0.975, len(values) - 1) * values.std(ddof=1) / np.sqrt(len(values))
        )

    models = with_units(models)
    units = units_of(models)
    grouped = models.groupby(["range_deg", "variant", "num_train"])
    table = grouped.agg(
        draws=("error", "size"), error_mean=("error", "mean"),
        error_median=("error", "median"), still=("still_error", "mean"),
        rigid=("rigid_error", "mean"), fit_seconds=("fit_seconds", "mean"),
        predict_ms=("predict_seconds", lambda s: 1000 * s.mean()),
        left_region=("left_region", "mean"),
    ).reset_index()  # fmt: skip
    table.insert(5, "error_ci95", grouped["error"].apply(half_width).to_numpy())
    return table.assign(units=units)


def paired(models: pd.DataFrame, first: str = "high", second: str = "low") -> pd.DataFrame:
    """Per (R, n): the two variants trained on the same draws compared draw by draw — how
    often ``first`` has the lower error, and the two-sided Wilcoxon signed-rank p-value."""
    rows = []
    for (range_deg, num_train), part in models.groupby(["range_deg", "num_train"]):
        wide = with_units(part).pivot_table(index="draw", columns="variant", values="error")
        if first not in wide or second not in wide:
            continue
        both = wide[[first, second]].dropna()
        if both.empty:
            continue
        difference = both[first] - both[second]
        rows.append(
            {"range_deg": range_deg, "num_train": num_train, "draws": len(both),
             f"{first}_better": int((difference < 0).sum()),
             "wilcoxon_p": signed_rank_p(difference)}
        )  # fmt: skip
    return pd.DataFrame(rows)


def paired_markdown(comparison: pd.DataFrame) -> str:
    lines = [
        "Draw by draw (the same training sets), high against low:",
        "",
        "| R (deg) | sequences | draws | high better | Wilcoxon p |",
        "|---|---|---|---|---|",
    ]
    for row in comparison.itertuples():
        lines.append(
            f"| {row.range_deg:g} | {row.num_train} | {row.draws} | {row.high_better} | "
            f"{row.wilcoxon_p:.3g} |"
        )
    return "\n".join(lines) + "\n"


def markdown(table: pd.DataFrame) -> str:
    units = units_of(table)
    lines = [
        f"| R (deg) | variant | sequences | draws | error ({units}), mean ± 95 % CI | median | "
        f"left the training region | still ({units}) | rigid ({units}) | training (s) | "
        "prediction (ms/seq) |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for row in table.itertuples():
        lines.append(
            f"| {row.range_deg:g} | {row.variant} | {row.num_train} | {row.draws} | "
            f"{row.error_mean:.4f} ± {row.error_ci95:.4f} | {row.error_median:.4f} | "
            f"{100 * row.left_region:.0f} % | {row.still:.4f} | {row.rigid:.4f} | "
            f"{row.fit_seconds:.1f} | {row.predict_ms:.1f} |"
        )
    lines.append("")
    lines.append(
        "Thesis, real cloth (§6.5, highly-parameterised, 10 sequences): "
        + ", ".join(f"R = {r}: {m} ± {s} m" for r, (m, s) in REAL_CLOTH_ERRORS.items())
    )
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("runs", nargs="+", type=Path, help="sweep or run directories")
    parser.add_argument("--out", type=Path, default=Path("cgpdm_report"))
    parser.add_argument("--figure-run", type=Path, help="a run for the latent and frame figures")
    parser.add_argument(
        "--earlier", type=Path, nargs="*", default=[], help="models.csv of earlier reports"
    )
    args = parser.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    args.out.mkdir(parents=True, exist_ok=True)
    models, left_out = load_models(args.runs)
    for run in left_out:
        log.warning("left out (failed or incomplete): %s", run)
    if args.earlier:
        try:
            earlier = [pd.read_csv(path) for path in args.earlier]
            models = combine([models, *earlier], ["the runs", *map(str, args.earlier)])
        except (OSError, ValueError, pd.errors.ParserError) as error:
            raise SystemExit(f"cgpdm_report: {str(error).splitlines()[0]}") from None
    if models.empty:
        raise SystemExit("no finished CGPDM runs under " + " ".join(map(str, args.runs)))
    models.to_csv(args.out / "models.csv", index=False)
    table = cells(models)
    table.to_csv(args.out / "errors.csv", index=False)
    comparison = paired(models)
    comparison.to_csv(args.out / "paired.csv", index=False)
    (args.out / "errors.md").write_text(markdown(table) + "\n" + paired_markdown(comparison))
    plot_errors(table, args.out)
    if args.figure_run is not None:
        plot_run(args.figure_run, args.out)
    log.info("%s", markdown(table))


if __name__ == "__main__":
    main()
