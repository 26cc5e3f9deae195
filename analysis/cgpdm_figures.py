"""The CGPDM study's figures: Fig. 6.5 from a table of cells, Figs. 6.3 and 6.4 from one run.

Used by ``analysis.cgpdm_report``; nothing is instantiated, runs are read as data.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402


def units_of(table: pd.DataFrame) -> str:
    """The one unit of ``table``'s errors; a one-line ValueError when runs mix units."""
    units = sorted(set(table["units"]))
    if len(units) != 1:
        raise ValueError(f"the runs' errors are in different units {units}: report them apart")
    return str(units[0])


def plot_errors(table: pd.DataFrame, out: Path) -> None:
    """Fig. 6.5: error against the number of training sequences, one panel per R; one
    colour per variant in every panel."""
    ranges = sorted(table.range_deg.unique())
    variants = sorted(table.variant.unique())
    palette = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    colors = dict(zip(variants, palette, strict=False))
    offsets = dict(zip(variants, np.linspace(-0.4, 0.4, len(variants)), strict=True))
    figure, axes = plt.subplots(
        1, len(ranges), figsize=(3.2 * len(ranges), 3.2), sharey=True, squeeze=False
    )
    for axis, range_deg in zip(axes[0], ranges, strict=True):
        part = table[table.range_deg == range_deg]
        for variant, rows in part.groupby("variant"):
            axis.errorbar(
                rows.num_train + offsets[variant], rows.error_mean, yerr=rows.error_ci95,
                fmt="o", capsize=3, color=colors[variant], label=str(variant),
            )  # fmt: skip
        sizes = sorted(part.num_train.unique())
        baselines = part.groupby("num_train")[["still", "rigid"]].mean().loc[sizes]
        axis.plot(sizes, baselines.still, "k:", label="still cloth")
        axis.plot(sizes, baselines.rigid, "k--", label="rigid with grip")
        axis.set_title(f"R = {range_deg:g}°")
        axis.set_xlabel("training sequences")
        axis.set_ylim(bottom=0.0)
        axis.grid(alpha=0.3)
    axes[0][0].set_ylabel(f"mean point distance ({units_of(table)})")
    handles = {}
    for axis in axes[0]:
        for handle, label in zip(*axis.get_legend_handles_labels(), strict=True):
            handles.setdefault(label, handle)
    axes[0][-1].legend(handles.values(), handles.keys(), fontsize=7)
    figure.tight_layout()
    for suffix in ("png", "svg"):
        figure.savefig(out / f"errors.{suffix}", dpi=130)
    plt.close(figure)


def plot_run(run: Path, out: Path, sequences: tuple[int, int] = (0, 1)) -> None:
    """Figs. 6.3 and 6.4 from one run's ``predictions.npz``."""
    with np.load(run / "predictions.npz") as arrays:
        latent, predicted, true = arrays["latent"], arrays["predicted"], arrays["true"]
        training = arrays["training_latent"]
    figure = plt.figure(figsize=(5, 4.5))
    axis = figure.add_subplot(projection="3d")
    for path in training:
        axis.plot(*path.T, color="0.8", lw=0.6)
    for k, color in zip(sequences, ("tab:blue", "tab:red"), strict=True):
        axis.plot(*latent[k].T, color=color, lw=1.8, label=f"test sequence {k}")
    axis.scatter(*latent[sequences[0], 0], color="k", s=20, label="initial state")
    axis.set_xlabel("$x_1$"), axis.set_ylabel("$x_2$"), axis.set_zlabel("$x_3$")
    axis.legend(fontsize=7)
    figure.tight_layout()
    figure.savefig(out / "latent.png", dpi=130)
    plt.close(figure)
    times = np.linspace(0, len(true[0]) - 1, 6).astype(int)
    figure = plt.figure(figsize=(13, 4.6))
    for column, t in enumerate(times):
        for row, (frames, name) in enumerate(((true, "simulated"), (predicted, "CGPDM"))):
            axis = figure.add_subplot(2, len(times), row * len(times) + column + 1, projection="3d")
            points = frames[sequences[0], t].reshape(8, 8, 3)
            axis.plot_wireframe(
                points[..., 0],
                points[..., 1],
                points[..., 2],
                color="tab:blue" if row == 0 else "tab:red",
                lw=0.8,
            )
            axis.set_xlim(-0.2, 0.2), axis.set_ylim(-0.2, 0.2), axis.set_zlim(0.65, 1.05)
            axis.view_init(elev=10, azim=-60)
            axis.set_xticklabels([]), axis.set_yticklabels([]), axis.set_zticklabels([])
            axis.set_title(f"{name}, t = {0.05 * t:.2f} s", fontsize=8)
    figure.tight_layout()
    figure.savefig(out / "frames.png", dpi=110)
    plt.close(figure)
