"""analysis.study_archive: bulky run files leave the work tree and come back byte for byte
from the git history (checked against the files as first written, not against the code)."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import pytest

from analysis.study_archive import main

pytestmark = pytest.mark.skipif(shutil.which("git") is None, reason="needs git")


def git(repo: Path, *args: str) -> str:
    done = subprocess.run(
        ["git", "-C", str(repo), "-c", "user.name=t", "-c", "user.email=t@t", *args],
        capture_output=True,
        text=True,
        check=True,
    )
    return done.stdout


@pytest.fixture
def study(tmp_path: Path) -> tuple[Path, dict[str, bytes]]:
    repo = tmp_path / "repo"
    folder = repo / "docs" / "results" / "s"
    files = {
        "README.md": b"# a study\n",
        "run/config.yaml": b"seed: 0\n",
        "run/summary.csv": b"trial,cost\n0,1.0\n",
        "run/train.log": b"trial 0\n",
        "run/checkpoints/trial_00/policy.pt": bytes(range(256)) * 7,
        "run/optimization/trial_01.csv": b"step,J\n0,3.5\n",
        "run/trajectories/trial_00.npz": b"\x00npz\xff" * 40,
        "probe/tensor.pt": b"\x01" * 99,
    }
    for name, content in files.items():
        (folder / name).parent.mkdir(parents=True, exist_ok=True)
        (folder / name).write_bytes(content)
    git(repo, "init", "-q")
    git(repo, "add", ".")
    git(repo, "commit", "-q", "-m", "study")
    return folder, files


def test_archive_keeps_what_a_reader_needs_and_restore_brings_back_the_rest(study, tmp_path):
    folder, files = study
    assert main(["archive", str(folder)]) == 0
    kept = {p.relative_to(folder).as_posix() for p in folder.rglob("*") if p.is_file()}
    assert kept == {
        "README.md",
        "run/config.yaml",
        "run/summary.csv",
        "run/train.log",
        "archived.json",
    }
    manifest = json.loads((folder / "archived.json").read_text())
    assert manifest["files"] == 4 and manifest["prefix"] == "docs/results/s"
    assert manifest["total_bytes"] == sum(len(files[p]) for p in manifest["paths"])

    copy = tmp_path / "copy"
    assert main(["restore", str(folder), "--to", str(copy)]) == 0
    restored = {
        p.relative_to(copy).as_posix(): p.read_bytes() for p in copy.rglob("*") if p.is_file()
    }
    assert restored == files

    assert main(["restore", str(folder)]) == 0
    for name, content in files.items():
        assert (folder / name).read_bytes() == content


def test_archive_refuses_uncommitted_changes(study):
    folder, _ = study
    (folder / "run" / "summary.csv").write_text("changed\n")
    assert main(["archive", str(folder)]) == 2
    assert (folder / "run" / "checkpoints" / "trial_00" / "policy.pt").is_file()


def test_restore_names_a_commit_the_clone_lacks(study, caplog):
    folder, _ = study
    assert main(["archive", str(folder)]) == 0
    manifest = json.loads((folder / "archived.json").read_text())
    manifest["commit"] = "0" * 40
    (folder / "archived.json").write_text(json.dumps(manifest))
    assert main(["restore", str(folder)]) == 2
    assert "not in this clone" in caplog.text


def test_a_manifest_pointing_outside_the_folder_is_refused(study, caplog):
    folder, _ = study
    assert main(["archive", str(folder)]) == 0
    manifest = json.loads((folder / "archived.json").read_text())
    manifest["paths"].append("../../../etc/passwd")
    (folder / "archived.json").write_text(json.dumps(manifest))
    assert main(["restore", str(folder)]) == 2
    assert "leaves the study folder" in caplog.text
