"""Move a study's bulky run files out of the work tree into the git history, and back.

``python -m analysis.study_archive restore docs/results/<study> [--to DIR]``
``python -m analysis.study_archive archive docs/results/<study>`` (after committing it)

A study folder under ``docs/results`` keeps in the work tree what a reader needs (its
README, tables, figures, logs and each run's ``config.yaml`` and ``summary.csv``). The
bulk of its run directories (checkpoints, optimisation traces, trajectories: what
``resume=``, ``analysis.evaluate`` and the model-based reports read) left the tree in one
commit and stays in the history at the commit its ``archived.json`` names. This command
writes those files back, byte for byte, into the study folder (or into ``--to``, a copy of
the study elsewhere), so a run can be resumed or re-evaluated::

    python -m analysis.study_archive restore docs/results/cartpole_thesis_settings --to runs/thesis
    python -m runners.train resume=runs/thesis/se/seed_3 num_trials=6

It needs the clone's history (not a ``--depth 1`` clone: ``git fetch --unshallow`` first).
Nothing read from the history is executed; members are written with tarfile's ``data``
filter, so none lands outside the target folder.
"""

from __future__ import annotations

import argparse
import io
import json
import logging
import subprocess
import sys
import tarfile
from dataclasses import dataclass
from pathlib import Path

from mcpilco.errors import RunFileError

log = logging.getLogger("mcpilco.restore")

MANIFEST = "archived.json"
"""The file in each study folder that names the commit and the archived files."""


@dataclass(frozen=True)
class Manifest:
    """What left a study folder: ``commit`` (40 hex digits) holds ``paths`` (relative to the
    study folder, POSIX) under ``prefix`` (the study folder's path in the repository)."""

    commit: str
    prefix: str
    paths: tuple[str, ...]
    total_bytes: int

    @classmethod
    def read(cls, study: Path) -> Manifest:
        """Parse ``study/archived.json``; one-line :class:`RunFileError` if it is absent or
        not what :func:`write_manifest` wrote."""
        file = study / MANIFEST
        try:
            data = json.loads(file.read_text())
            commit, prefix = str(data["commit"]), str(data["prefix"])
            paths = tuple(str(p) for p in data["paths"])
            total = int(data["total_bytes"])
        except FileNotFoundError:
            raise RunFileError(
                f"{study}: no {MANIFEST} (nothing of this folder was archived)"
            ) from None
        except (ValueError, KeyError, TypeError) as error:
            raise RunFileError(f"{file}: not a study manifest ({error})") from None
        if len(commit) != 40 or any(c not in "0123456789abcdef" for c in commit):
            raise RunFileError(f"{file}: commit={commit!r} is not a 40-digit git commit id")
        if any(p.startswith("/") or ".." in Path(p).parts for p in paths):
            raise RunFileError(f"{file}: a path leaves the study folder")
        return cls(commit, prefix.rstrip("/"), paths, total)


def write_manifest(
    study: Path, commit: str, prefix: str, paths: list[str], total_bytes: int
) -> None:
    """Record that ``paths`` (relative to ``study``) are kept at ``commit`` only."""
    data = {
        "commit": commit,
        "prefix": prefix,
        "files": len(paths),
        "total_bytes": total_bytes,
        "how": f"python -m analysis.study_archive restore {prefix}",
        "paths": sorted(paths),
    }
    (study / MANIFEST).write_text(json.dumps(data, indent=1) + "\n")


def repository_root(study: Path) -> Path:
    """The git work tree holding ``study``; RunFileError where there is none."""
    done = subprocess.run(
        ["git", "-C", str(study), "rev-parse", "--show-toplevel"], capture_output=True, text=True
    )
    if done.returncode != 0:
        raise RunFileError(f"{study}: not inside a git clone (the archive is its history)")
    return Path(done.stdout.strip())


def history_tar(root: Path, manifest: Manifest) -> bytes:
    """``git archive`` of the study folder at the manifest's commit (a tar, in memory)."""
    done = subprocess.run(
        ["git", "-C", str(root), "archive", "--format=tar", manifest.commit, "--", manifest.prefix],
        capture_output=True,
    )
    if done.returncode != 0:
        reason = done.stderr.decode(errors="replace").strip().splitlines()[-1:] or ["?"]
        raise RunFileError(
            f"commit {manifest.commit[:12]} is not in this clone ({reason[0]}); "
            "a shallow clone needs `git fetch --unshallow`"
        )
    return done.stdout


def restore(study: Path, target: Path | None = None) -> int:
    """Write the archived files of ``study`` into ``target`` (default: ``study``) and, when
    ``target`` is another folder, the files the tree kept too, so it is a whole copy.
    Returns the number of files written. Existing files are replaced."""
    study = study.resolve()
    manifest = Manifest.read(study)
    archive = history_tar(repository_root(study), manifest)
    target = (target or study).resolve()
    target.mkdir(parents=True, exist_ok=True)
    wanted = set(manifest.paths)
    written = 0
    with tarfile.open(fileobj=io.BytesIO(archive)) as tar:
        for member in tar.getmembers():
            if not member.isfile():
                continue
            relative = member.name[len(manifest.prefix) + 1 :]
            if relative not in wanted:
                continue
            member.name = relative
            tar.extract(member, target, filter="data")
            written += 1
    if written != len(wanted):
        raise RunFileError(f"{study}: the history holds {written} of {len(wanted)} archived files")
    if target != study:
        for kept in study.rglob("*"):
            if kept.is_file() and kept.name != MANIFEST:
                destination = target / kept.relative_to(study)
                destination.parent.mkdir(parents=True, exist_ok=True)
                destination.write_bytes(kept.read_bytes())
    return written


BULKY_FOLDERS = ("checkpoints", "optimization", "trajectories")
BULKY_SUFFIXES = (".pt", ".npz")


def is_bulky(relative: str) -> bool:
    """Checkpoints, optimisation traces, trajectories and tensors: what resume and the
    model-based analyses read, not what a reader of the study needs."""
    parts = Path(relative).parts
    return any(part in BULKY_FOLDERS for part in parts[:-1]) or relative.endswith(BULKY_SUFFIXES)


def archive(study: Path) -> int:
    """Delete ``study``'s bulky files from the work tree, recording in ``archived.json``
    the commit (HEAD) that holds them. Every such file must be committed and unchanged
    (RunFileError otherwise), so the history holds exactly what is deleted. Returns the
    number of files archived; commit the deletion afterwards."""
    study = study.resolve()
    root = repository_root(study)
    prefix = study.relative_to(root).as_posix()
    head = subprocess.run(
        ["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True, text=True
    )
    tracked = subprocess.run(
        ["git", "-C", str(root), "ls-files", "-z", "--", prefix], capture_output=True, text=True
    )
    changed = subprocess.run(
        ["git", "-C", str(root), "status", "--porcelain", "-z", "--", prefix],
        capture_output=True,
        text=True,
    )
    if head.returncode or tracked.returncode or changed.returncode:
        raise RunFileError(f"{study}: git could not list the folder")
    if changed.stdout.strip("\0"):
        raise RunFileError(f"{study}: has uncommitted changes; commit them before archiving")
    names = [n[len(prefix) + 1 :] for n in tracked.stdout.split("\0") if n]
    bulky = [n for n in names if is_bulky(n)]
    previous: list[str] = []
    if (study / MANIFEST).is_file():
        old = Manifest.read(study)
        if old.commit != head.stdout.strip() and bulky:
            raise RunFileError(f"{study}: already archived at {old.commit[:12]}; restore it first")
        previous = list(old.paths)
    if not bulky:
        return 0
    total = sum((study / n).stat().st_size for n in bulky)
    for name in bulky:
        (study / name).unlink()
    for folder in sorted({(study / n).parent for n in bulky}, key=lambda p: -len(p.parts)):
        while folder != study and folder.is_dir() and not any(folder.iterdir()):
            folder.rmdir()
            folder = folder.parent
    write_manifest(study, head.stdout.strip(), prefix, sorted(set(previous) | set(bulky)), total)
    return len(bulky)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    commands = parser.add_subparsers(dest="command", required=True)
    restoring = commands.add_parser(
        "restore", help="write the archived files back from the history"
    )
    restoring.add_argument("study", type=Path, help="a study folder holding archived.json")
    restoring.add_argument("--to", type=Path, default=None, help="write a whole copy here instead")
    archiving = commands.add_parser(
        "archive", help="delete the committed bulky files, keep a manifest"
    )
    archiving.add_argument("study", type=Path, nargs="+", help="study folders, committed")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    try:
        if args.command == "restore":
            count = restore(args.study, args.to)
            log.info("restored %d files into %s", count, (args.to or args.study).resolve())
        else:
            for study in args.study:
                log.info("%s: %d files archived", study, archive(study))
    except RunFileError as error:
        log.error("%s", error)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
