"""Write a data set of ``runners.cgpdm mode=generate`` in the CSV layout of the authors'
public CGPDM library (what ``runners.cgpdm data.csv_dir=...`` reads).

``python -m analysis.cloth_csv RUN/datasets/R30.npz OUT_DIR [--shared-increment] [--stem S]``

``--shared-increment`` writes the one 3-D displacement both grips share (the library's
input files have 3 columns) instead of the 6 columns of two end-effectors.
"""

from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path

from mcpilco.cloth.csv_layout import write_csv_sequences
from mcpilco.cloth.dataset import ClothDataset
from mcpilco.errors import ConfigError

log = logging.getLogger("mcpilco.cloth_csv")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("dataset", type=Path, help="a .npz data set (its .json beside it)")
    parser.add_argument("out", type=Path, help="the folder the CSV files go into")
    parser.add_argument("--stem", default="cloth", help="middle of the file names")
    parser.add_argument(
        "--shared-increment", action="store_true", help="3 control columns (both grips share them)"
    )
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    try:
        dataset = ClothDataset.load(args.dataset)
        written = write_csv_sequences(dataset, args.out, args.stem, args.shared_increment)
    except ConfigError as error:
        log.error("%s", error)
        return 2
    log.info("%d sequences written into %s", len(written) // 2, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
