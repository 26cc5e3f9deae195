"""The configuration reference, generated from ``conf/`` so it cannot drift.

``python -m analysis.config_reference [--check]`` writes ``docs/reference/configuration.md``
(every runner's groups, every option of each group with every key and its default, the
top-level keys with their comments, the presets) and each runner's ``--help`` text
(``conf/hydra/help/<runner>.yaml``). ``--check`` writes nothing and exits 1 naming the
files that differ from what ``conf/`` gives (the test suite runs it).

The YAML files are read as data (OmegaConf, nothing resolved or instantiated).
"""

from __future__ import annotations

import argparse
import re
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml
from omegaconf import OmegaConf

ROOT = Path(__file__).resolve().parent.parent
CONF = ROOT / "conf"
PAGE = ROOT / "docs" / "reference" / "configuration.md"
RUNNERS = {
    "train": "MC-PILCO and its variants (thesis chapters 2-4)",
    "control": "GP feedback-linearisation torque control (thesis chapter 5)",
    "cgpdm": "the cloth's controlled GP dynamical model (thesis chapter 6)",
}
MOST_USED = {
    "train": "seed num_trials threads device dtype compile resume overwrite".split(),
    "control": "seed threads model_dir fit_model resume overwrite".split(),
    "cgpdm": "mode seed threads device resume overwrite".split(),
}
HIDDEN_GROUPS = ("hydra",)
COMMENT = re.compile(r"^(?P<key>[A-Za-z_][\w]*):\s*(?P<value>[^#]*?)\s*(?:#\s?(?P<comment>.*))?$")


@dataclass(frozen=True)
class TopKey:
    """A top-level key of a runner's config: its default (as written) and its comment."""

    name: str
    default: str
    comment: str


def top_level_keys(config_file: Path) -> list[TopKey]:
    """The scalar top-level keys of ``config_file`` with the comment on their line (and the
    comment lines right under it that continue it, aligned past the key)."""
    keys: list[TopKey] = []
    lines = config_file.read_text().splitlines()
    for index, line in enumerate(lines):
        match = COMMENT.match(line)
        if not match or match["key"] == "defaults" or not match["value"]:
            continue
        comment = [match["comment"] or ""]
        for follow in lines[index + 1 :]:
            stripped = follow.strip()
            if follow.startswith(" ") and stripped.startswith("#"):
                comment.append(stripped.lstrip("#").strip())
            else:
                break
        keys.append(TopKey(match["key"], match["value"], " ".join(c for c in comment if c)))
    return keys


def defaults_of(config_file: Path) -> list[tuple[str, str]]:
    """``(group, option)`` of a config's defaults list (``_self_`` and derived entries left out)."""
    data = yaml.safe_load(config_file.read_text()) or {}
    pairs = []
    for entry in data.get("defaults", []):
        if isinstance(entry, dict):
            for group, option in entry.items():
                if "$" not in str(option) and not str(group).startswith("override "):
                    pairs.append((str(group), str(option)))
    return pairs


def flatten(node: Any, prefix: str = "") -> Iterator[tuple[str, Any]]:
    if isinstance(node, dict):
        for key, value in node.items():
            if key == "defaults" and not prefix:
                continue
            yield from flatten(value, f"{prefix}{key}.")
    else:
        yield prefix[:-1], node


def header_comment(option_file: Path) -> str:
    """The first comment line(s) of an option file, up to the first blank or key line."""
    text = []
    for line in option_file.read_text().splitlines():
        if line.startswith("# @package"):
            continue
        if not line.startswith("#"):
            break
        text.append(line.lstrip("#").strip())
    return " ".join(
        t for t in text if not t.startswith("python -m") and not t.startswith("(")
    ).strip()


def option_keys(option_file: Path) -> tuple[list[str], list[tuple[str, Any]]]:
    """What choosing an option sets: the groups its defaults list overrides, and every key."""
    raw = yaml.safe_load(option_file.read_text()) or {}
    sets = []
    for entry in raw.get("defaults", []) if isinstance(raw, dict) else []:
        if isinstance(entry, dict):
            for group, option in entry.items():
                sets.append(f"{str(group).removeprefix('override ').lstrip('/')}={option}")
        elif entry != "_self_":
            sets.append(str(entry))
    loaded = OmegaConf.to_container(OmegaConf.load(option_file), resolve=False)
    return sets, list(flatten(loaded if isinstance(loaded, dict) else {}))


def value_text(value: Any) -> str:
    text = (
        "null"
        if value is None
        else yaml.safe_dump(value, default_flow_style=True, width=10**6).strip()
    )
    text = text.removesuffix("...").strip()
    return text.replace("|", "\\|")


def options_of(group: str) -> list[Path]:
    return sorted((CONF / group).glob("*.yaml"))


def experiment_runner(option_file: Path) -> str:
    text = option_file.read_text()
    for runner in ("control", "cgpdm"):
        if f"runners.{runner}" in text:
            return runner
    return "train"


def group_section(group: str, default: str) -> list[str]:
    lines = [f"#### `{group}` (default `{default}`)", ""]
    for option_file in options_of(group):
        sets, keys = option_keys(option_file)
        description = header_comment(option_file)
        lines.append(
            f"- **`{group}={option_file.stem}`**" + (f": {description}" if description else "")
        )
        if sets:
            lines.append(f"  sets {', '.join(f'`{s}`' for s in sets)}")
        if keys:
            lines += ["", "  | key | default |", "  |---|---|"]
            lines += [f"  | `{k}` | `{value_text(v)}` |" for k, v in keys]
        lines.append("")
    nested = sorted(p for p in (CONF / group).iterdir() if p.is_dir())
    for folder in nested:
        names = ", ".join(f.stem for f in options_of(f"{group}/{folder.name}"))
        lines.append(f"- `{group}/{folder.name}/`: {names} (chosen by the config itself)")
    if nested:
        lines.append("")
    return lines


def reference_page() -> str:
    lines = [
        "# Configuration reference",
        "",
        "Generated by `python -m analysis.config_reference` from `conf/` (a test fails when this",
        "page and `conf/` disagree). Pick an option with `group=option`, set a key with",
        "`key=value`, add a preset with `+experiment=name`; `--cfg job` prints the composed",
        "configuration without running anything.",
        "",
    ]
    for runner, what in RUNNERS.items():
        config_file = CONF / f"{runner}.yaml"
        lines += [
            f"## `runners.{runner}`: {what}",
            "",
            f"Config `conf/{runner}.yaml`.",
            "",
            "### Top-level keys",
            "",
        ]
        lines += ["| key | default | meaning |", "|---|---|---|"]
        for key in top_level_keys(config_file):
            default, meaning = (text.replace("|", "\\|") for text in (key.default, key.comment))
            lines.append(f"| `{key.name}` | `{default}` | {meaning} |")
        lines.append("")
        nested = {
            k: v for k, v in (OmegaConf.to_container(OmegaConf.load(config_file)) or {}).items()
        }
        blocks = [k for k, v in nested.items() if isinstance(v, dict) and k not in HIDDEN_GROUPS]
        if blocks:
            lines += ["### Nested keys", "", "| key | default |", "|---|---|"]
            for block in blocks:
                lines += [
                    f"| `{k}` | `{value_text(v)}` |" for k, v in flatten({block: nested[block]})
                ]
            lines.append("")
        lines += ["### Groups", ""]
        for group, default in defaults_of(config_file):
            lines += group_section(group, default)
        presets = [p for p in options_of("experiment") if experiment_runner(p) == runner]
        if presets:
            lines += ["### Presets (`+experiment=name`)", ""]
            for preset in presets:
                sets, keys = option_keys(preset)
                changed = ", ".join(f"`{s}`" for s in sets) + (", " if sets and keys else "")
                changed += ", ".join(f"`{k}`" for k, _ in keys if not k.startswith("hydra."))
                lines.append(
                    f"- **`{preset.stem}`**: {header_comment(preset)} Sets {changed or 'nothing'}."
                )
            lines.append("")
    launchers = options_of("hydra/launcher")
    lines += ["## Launchers (`hydra/launcher=name`, with `--multirun`)", ""]
    lines += [f"- **`{p.stem}`**: {header_comment(p)}" for p in launchers]
    return "\n".join(lines).rstrip() + "\n"


def help_template(runner: str) -> str:
    """The ``--help`` text of ``runners.<runner>``: its groups with their options, the most
    used keys with their defaults and where the full reference is."""
    config_file = CONF / f"{runner}.yaml"
    keys = {k.name: k for k in top_level_keys(config_file)}
    lines = [
        f"python -m runners.{runner} [group=option ...] [key=value ...] [--multirun] [--cfg job]",
        "",
        f"runners.{runner}: {RUNNERS[runner]}.",
        "",
        "Groups (group=option; the default first):",
    ]
    for group, default in defaults_of(config_file):
        others = [p.stem for p in options_of(group) if p.stem != default]
        lines.append(f"  {group}: {', '.join([default, *others])}")
    presets = [p.stem for p in options_of("experiment") if experiment_runner(p) == runner]
    if presets:
        lines.append(f"  +experiment: {', '.join(presets)}")
    lines += ["", "Most used keys (default):"]
    for name in MOST_USED[runner]:
        key = keys[name]
        lines.append(f"  {name}={key.default}  {key.comment.split(';')[0].split('. ')[0][:90]}")
    lines += [
        "",
        "Every group, option and key: docs/reference/configuration.md; the composed config of",
        "a command: add --cfg job. Hydra's own flags: --hydra-help.",
    ]
    body = re.sub(r"\$\{hydra:runtime\.choices\.(\w+)\}", r"(the \1 option)", "\n".join(lines))
    body = re.sub(r"\$\{[^}]*\}", "(derived)", body).replace("$", "$$")  # no interpolation
    return (
        "# Generated by python -m analysis.config_reference from conf/: do not edit.\n"
        "template: |-\n" + "".join(f"  {line}\n" if line else "\n" for line in body.splitlines())
    )


def outputs() -> dict[Path, str]:
    files = {PAGE: reference_page()}
    for runner in RUNNERS:
        files[CONF / "hydra" / "help" / f"{runner}.yaml"] = help_template(runner)
    return files


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument(
        "--check", action="store_true", help="write nothing; exit 1 on a difference"
    )
    args = parser.parse_args(argv)
    stale = []
    for path, text in outputs().items():
        if path.is_file() and path.read_text() == text:
            continue
        stale.append(path)
        if not args.check:
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(text)
    if args.check and stale:
        names = ", ".join(str(p.relative_to(ROOT)) for p in stale)
        sys.stderr.write(
            f"out of date with conf/: {names} (run python -m analysis.config_reference)\n"
        )
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
