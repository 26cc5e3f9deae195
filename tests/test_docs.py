"""The documentation cannot drift: every command block runs as written, the configuration
reference and each runner's --help match conf/, the results tables match the committed run
summaries, and the README stays a short landing page."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from analysis import config_reference, results_tables

sys.path.insert(0, str(Path(__file__).resolve().parent))
from docs_commands import PLACEHOLDER, ROOT, commands, pages, script  # noqa: E402

ORDER = ["README.md", "getting_started.md"]
"""Pages run first (a reader starts there; later pages use the smoke run they make)."""


def test_no_command_block_holds_a_placeholder() -> None:
    found = [
        f"{c.page.name}:{c.line}: {c.text}"
        for p in pages()
        for c in commands(p)
        if PLACEHOLDER.search(c.text)
    ]
    assert not found, "commands a reader cannot type as written:\n" + "\n".join(found)
    assert sum(len(commands(p)) for p in pages()) > 40  # the parser finds the blocks


def _scratch(tmp_path: Path) -> Path:
    """A reader's clone without the package sources: the docs, README, Makefile and examples
    copied (commands may write under docs/ here, never into the checkout), the installed
    .venv linked, and a git repository that borrows the checkout's objects so that
    ``analysis.study_archive restore`` finds the history."""
    scratch = tmp_path / "clone"
    scratch.mkdir()
    for name in ("docs", "examples"):
        shutil.copytree(ROOT / name, scratch / name)
    for name in ("README.md", "Makefile", "pyproject.toml", "mkdocs.yml"):
        shutil.copy2(ROOT / name, scratch / name)
    (scratch / ".venv").symlink_to(ROOT / ".venv")
    stamp = ROOT / ".venv" / ".installed"
    if stamp.exists():  # make must see the installation as up to date
        old = stamp.stat().st_mtime - 10
        os.utime(scratch / "pyproject.toml", (old, old))
    subprocess.run(["git", "init", "-q", str(scratch)], check=True)
    (scratch / ".git" / "objects" / "info" / "alternates").write_text(
        str(ROOT / ".git" / "objects") + "\n"
    )
    return scratch


def _history_available() -> bool:
    shallow = subprocess.run(
        ["git", "-C", str(ROOT), "rev-parse", "--is-shallow-repository"],
        capture_output=True,
        text=True,
    )
    return shallow.returncode == 0 and shallow.stdout.strip() == "false"


@pytest.mark.skipif(
    not (ROOT / ".venv" / "bin" / "activate").exists(), reason="needs make install's .venv"
)
@pytest.mark.skipif(
    shutil.which("git") is None or not _history_available(), reason="needs the clone's history"
)
def test_every_command_of_the_readme_and_the_docs_runs_as_written(tmp_path: Path) -> None:
    scratch = _scratch(tmp_path)

    def rank(page: Path) -> tuple[int, str]:
        first = page.name in ORDER and page.parent in (ROOT, ROOT / "docs")
        return (ORDER.index(page.name) if first else len(ORDER), str(page))

    text, count = script(sorted(pages(), key=rank))
    (scratch / "commands.sh").write_text(text)
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    done = subprocess.run(
        ["bash", "commands.sh"], cwd=scratch, capture_output=True, text=True, env=env, timeout=1500
    )
    tried = [line for line in done.stderr.splitlines() if line.startswith(">>> ")]
    assert done.returncode == 0, f"failed at {tried[-1] if tried else '?'}:\n{done.stderr[-3000:]}"
    assert len(tried) == count
    assert (scratch / "runs" / "smoke" / "replay.rrd").is_file()  # make smoke ran for real
    assert (scratch / "runs" / "pendulum" / "summary.csv").is_file()  # so did the plug-in


def test_the_configuration_reference_and_each_help_match_conf() -> None:
    assert config_reference.main(["--check"]) == 0
    page = (ROOT / "docs" / "reference" / "configuration.md").read_text()
    for group in sorted(
        p.name for p in (ROOT / "conf").iterdir() if p.is_dir() and p.name != "hydra"
    ):
        for option in (ROOT / "conf" / group).glob("*.yaml"):
            assert f"`{group}={option.stem}`" in page or f"`{option.stem}`" in page, (
                group,
                option.stem,
            )


@pytest.mark.parametrize("runner", ["train", "control", "cgpdm"])
def test_help_lists_the_runners_groups_and_main_keys(runner: str) -> None:
    done = subprocess.run(
        [sys.executable, "-m", f"runners.{runner}", "--help"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    for group, default in config_reference.defaults_of(ROOT / "conf" / f"{runner}.yaml"):
        assert f"  {group}: {default}" in done.stdout
    for key in config_reference.MOST_USED[runner]:
        assert f"  {key}=" in done.stdout
    assert "torch" not in done.stderr


def test_results_tables_are_those_of_the_committed_summaries() -> None:
    assert results_tables.main(["--check"]) == 0
    text = "".join(page.read_text() for page in (ROOT / "docs" / "results").glob("*.md"))
    assert all(f"<!-- table: {name} -->" in text for name in results_tables.TABLES)


def test_results_pages_type_no_table() -> None:
    for page in (ROOT / "docs" / "results").glob("chapter*.md"):
        inside = False
        for number, line in enumerate(page.read_text().splitlines(), 1):
            if line.startswith("<!-- table: "):
                inside = True
            elif line.startswith("<!-- /table -->"):
                inside = False
            elif line.startswith("|") and not inside:
                pytest.fail(f"{page.name}:{number}: a table row typed outside a generated block")


def test_the_readme_is_a_short_landing_page() -> None:
    lines = (ROOT / "README.md").read_text().splitlines()
    assert len(lines) <= 200
