"""What float32 prediction costs a fitted inverse-dynamics model (issue 56, the 1 kHz budget).

    python -m analysis.control_precision MODEL_DIR... [--out FILE.md]

For each model directory (``model.json`` + ``gp.pt``, read as data and tensors): the test
set is collected again from the settings in ``model.json`` (same simulator, seed and
excitation: the same samples as at fitting time), the model predicts it in float64 and in
float32 (``predict_in``), and one row gives the test nMSE % per joint of both and the
largest torque difference between them.
"""

from __future__ import annotations

import argparse
import json
from functools import partial
from pathlib import Path

import numpy as np
import torch

from mcpilco.control import GPInverseDynamics, PyBulletArm, collect, nmse_percent
from mcpilco.kernels import GeometricPolynomial, SquaredExponential
from mcpilco.run_storage import load_tensors

KERNELS = {
    "mcpilco.kernels.SquaredExponential": SquaredExponential,
    "mcpilco.kernels.GeometricPolynomial": GeometricPolynomial,
}
DATA_KEYS = ("duration", "downsample", "cutoff_hz", "reference_std", "kp", "kd", "torque_limit")


def precision_row(model_dir: Path) -> dict[str, object]:
    meta = json.loads((model_dir / "model.json").read_text())
    target = meta["kernel"]["_target_"]
    if target not in KERNELS:
        raise ValueError(f"{model_dir}/model.json: kernel {target!r} is not one of {list(KERNELS)}")
    robot = PyBulletArm()
    data = meta["data"]
    test = collect(
        robot, np.random.default_rng(data["test_seed"]), **{k: data[k] for k in DATA_KEYS}
    )
    model = GPInverseDynamics(partial(KERNELS[target]), robot.num_joints, fit_points=None)
    model.load_state_dict(load_tensors(model_dir / "gp.pt"))
    inputs = torch.as_tensor(test.inputs, dtype=torch.float64)
    predictions = {}
    for dtype in (torch.float64, torch.float32):
        model.predict_in(dtype)
        predictions[dtype] = torch.cat(
            [model.torques(inputs[i : i + 500]) for i in range(0, len(inputs), 500)]
        ).numpy()
    return {
        "model": str(model_dir),
        "nmse_float64": nmse_percent(predictions[torch.float64], test.torques),
        "nmse_float32": nmse_percent(predictions[torch.float32], test.torques),
        "max_difference_nm": float(
            np.abs(predictions[torch.float64] - predictions[torch.float32]).max()
        ),
    }


def precision_markdown(rows: list[dict[str, object]]) -> str:
    lines = [
        "| model | prediction | test nMSE % per joint | largest |τ₆₄ − τ₃₂| [N m] |",
        "|---|---|---|---|",
    ]
    for row in rows:
        for dtype in ("float64", "float32"):
            values = " ".join(f"{v:.3f}" for v in row[f"nmse_{dtype}"])  # type: ignore[attr-defined]
            difference = f"{row['max_difference_nm']:.2e}" if dtype == "float32" else "—"
            lines.append(f"| `{row['model']}` | {dtype} | {values} | {difference} |")
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("models", nargs="+", type=Path, help="model directories")
    parser.add_argument("--out", type=Path, default=None, help="write the table here")
    args = parser.parse_args()
    torch.set_num_threads(1)
    text = precision_markdown([precision_row(m) for m in args.models])
    if args.out is None:
        print(text, end="")  # noqa: T201
    else:
        args.out.write_text(text)


if __name__ == "__main__":
    main()
