"""The command blocks of the README and the documentation pages, and how the docs test runs
them (tests/test_docs.py).

Every fenced ``bash`` block is a list of commands a reader types, in order, with the
environment active (``source .venv/bin/activate``). The test runs each page's blocks as one
script in a scratch copy of the repository's ``docs/`` (so nothing is written into the
checkout), with two substitutions where a command as written would run for minutes or
hours or need a display:

- ``python -m runners.{train,control,cgpdm} …`` gets ``--cfg job`` (Hydra composes the
  configuration, checking every group, option and key, and prints it) unless it already
  has ``--cfg``/``--help`` or it is the one-minute smoke run (``+experiment=smoke``); a
  sweep (``-m``/``--multirun``) is composed for its first job (each swept key at its first
  value), as Hydra allows ``--cfg`` only outside multirun;
- ``make TARGET`` becomes ``make -n TARGET`` (the target exists and its recipe expands)
  except ``make smoke`` and ``make help``, which run; ``rerun FILE`` becomes
  ``rerun rrd verify FILE`` (the recording opens; no viewer is spawned).

A command run earlier in the same order, word for word, is not run again.
Blocks in other languages (``text`` for output, ``yaml``, ``python``) are not run. A command
with a ``<placeholder>`` is an error: a reader could not type it.
"""

from __future__ import annotations

import re
import shlex
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
FENCE = re.compile(r"^```bash\n(.*?)^```", re.DOTALL | re.MULTILINE)
PLACEHOLDER = re.compile(r"<[A-Za-z][^<>]*>")
RUNNERS = re.compile(r"^(?:python|\.venv/bin/python) -m runners\.(train|control|cgpdm)\b")
MAKE = re.compile(r"^make (\S+)(.*)$")
RUN_AS_WRITTEN_MAKE = {"smoke", "help", "install"}


def pages() -> list[Path]:
    """The README and every documentation page (not the study notebooks under
    ``docs/results/<study>/``, which record what was run, with machine-local paths)."""
    found = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
    found += sorted((ROOT / "docs" / "results").glob("*.md"))
    found += sorted((ROOT / "docs" / "reference").glob("*.md"))
    return found


@dataclass(frozen=True)
class Command:
    page: Path
    line: int
    text: str


def commands(page: Path) -> list[Command]:
    """The commands of the page's bash blocks (continuation lines joined, comments and
    blank lines dropped), with their line numbers."""
    text = page.read_text()
    found = []
    for block in FENCE.finditer(text):
        first_line = text[: block.start(1)].count("\n") + 1
        pending, start = "", 0
        for offset, raw in enumerate(block.group(1).splitlines()):
            line = raw.split("  #")[0].rstrip() if not raw.lstrip().startswith("#") else ""
            if not line and not pending:
                continue
            if not pending:
                start = first_line + offset
            pending += line.rstrip("\\").strip() + " "
            if not line.endswith("\\"):
                found.append(Command(page, start, " ".join(pending.split())))
                pending = ""
    return found


def as_run(command: str) -> str:
    """The command the test runs for ``command`` (see the module docstring)."""
    runner = RUNNERS.match(command)
    if runner:
        if "--cfg" in command or "--help" in command or "+experiment=smoke" in command:
            return command
        return first_job(command) + " --cfg job"
    make = MAKE.match(command)
    if make and make.group(1) not in RUN_AS_WRITTEN_MAKE:
        return f"make -n {make.group(1)}{make.group(2)}"
    if command.startswith("rerun ") and command.split()[1].endswith(".rrd"):
        return "rerun rrd verify " + " ".join(command.split()[1:])
    return command


def first_job(command: str) -> str:
    """A ``--multirun`` command as its first job: the flag dropped, each swept override
    (``a,b``, ``range(…)``, ``choice(…)``) at its first value."""
    head, words = shlex.split(command)[:3], shlex.split(command)[3:]  # python -m runners.X
    if not {"-m", "--multirun"} & set(words):
        return command
    from hydra.core.override_parser.overrides_parser import OverridesParser

    parser = OverridesParser.create()
    kept = []
    for word in words:
        if word in ("-m", "--multirun"):
            continue
        if "=" in word and not word.startswith("-"):
            override = parser.parse_override(word)
            if override.is_sweep_override():
                first = next(iter(override.sweep_string_iterator()))
                word = f"{override.get_key_element()}={first}"
        kept.append(word)
    return shlex.join(head + kept)


def script(ordered: list[Path]) -> tuple[str, int]:
    """The pages' commands, in order, as one bash script that stops at the first failure
    and names it; a command already run earlier in the script, word for word, is named but
    not run again (``make smoke`` on two pages). Returns the script and its command count."""
    lines = ["set -euo pipefail", "source .venv/bin/activate"]
    seen: set[str] = set()
    count = 0
    for page in ordered:
        for command in commands(page):
            count += 1
            where = f"{page.relative_to(ROOT)}:{command.line}"
            text = command.text.replace("'", "")
            lines.append(f"echo '>>> {where}: {text}' >&2")
            if command.text not in seen:
                lines.append(as_run(command.text))
            seen.add(command.text)
    return "\n".join(lines) + "\n", count
