"""Regenerate the guide's two references from the one place that defines them, so they cannot drift.

- docs/guide/configuration.md: every key of the configuration file, read off the settings schema
  (alpaca_zwo/config/settings.py: the dataclasses' fields, defaults and checks, and the ``#:`` or
  trailing comment that explains each key).
- docs/guide/command-line.md: every option of ``alpaca-zwo`` and ``alpaca-zwo-emulator``, read off
  their argparse parsers (alpaca_zwo/cli.py, alpaca_zwo/emulator/cli.py).

Run (with any Python that has alpaca-zwo installed; scripts/run-tests makes .venv-test/):
    .venv-test/bin/python -m tools.make_reference          writes both files
    .venv-test/bin/python -m tools.make_reference --check  exit 1 if either is out of date (tests/test_docs.py)
"""

from __future__ import annotations

import argparse
import ast
import dataclasses
import inspect
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from alpaca_zwo.cli import build_parser as server_parser
from alpaca_zwo.config import settings as schema
from alpaca_zwo.config.file import default_config_path
from alpaca_zwo.emulator.cli import build_parser as emulator_parser

ROOT = Path(__file__).resolve().parents[1]
GUIDE = ROOT / "docs" / "guide"
COMMAND = ".venv-test/bin/python -m tools.make_reference"

#: The guide page that explains each table's keys in context.
_TASK_PAGES = {
    "server": "[Security on a LAN](security.md) and [the first night](first-night.md#3-open-the-page-on-your-phone)",
    "devices": "[the first night](first-night.md#2-connect-the-mount)",
    "site": "[In the field](field.md)",
    "park": "[the mount's own settings](mount-settings.md#park-position)",
    "limits": "[the mount's own settings](mount-settings.md)",
    "safety": "[the observatory](observatory.md) and [the mount's own settings](mount-settings.md#safety)",
    "logging": "[Troubleshooting](troubleshooting.md)",
    "emulator": "[the emulator](emulator.md)",
    "stellarium": "[Stellarium](sharing.md#stellarium)",
    "zwo_port": "[the ZWO port](sharing.md#the-zwo-port-indi-kstarsekos)",
    "time": "[In the field](field.md#the-clock)",
}

#: What a check that is not a plain range or choice accepts, by the check's name.
_VALUES = {
    "_bool": "`true` or `false`",
    "_horizon": "`[[azimuth, altitude], ...]` in degrees, altitude -10..90",
    "_host_names": "host names, or `[\"*\"]` for any",
    "_networks": "`\"local\"`, addresses and networks (`\"10.8.0.0/24\"`)",
    "_host_port": "`\"host:port\"` or `\"\"`",
    "_dangerous_codes": f"command codes among {', '.join(f'`{c}`' for c in schema.ZWO_PORT_DANGEROUS)}, or `\"all\"`",
}


def _toml(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, (tuple, list)):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    return repr(value)


def _escape(text: str) -> str:
    """A table cell's text: a ``|`` would end the cell."""
    return text.replace("|", "\\|")


def _cells(check: Callable[..., Any]) -> dict[str, Any]:
    names = check.__code__.co_freevars
    return {name: cell.cell_contents for name, cell in zip(names, check.__closure__ or (), strict=True)}


def _values(check: Callable[..., Any]) -> str:
    """The values a key's check accepts, read from the check itself."""
    name = check.__qualname__.split(".")[0]
    if name in _VALUES:
        return _VALUES[name]
    cells = _cells(check)
    if name in ("_int", "_float"):
        also = "".join(f" or {a}" for a in cells.get("also", ()))
        return f"{cells['lo']} .. {cells['hi']}{also}"
    if name == "_choice":
        return ", ".join(f'`"{c}"`' for c in cells["choices"])
    if name == "_str" and cells.get("hint"):
        return str(cells["hint"])
    if name == "_device_url":
        return f"`\"\"` or an Alpaca {cells['device_type']} URL"
    return "a string"


def _comments(cls: type) -> dict[str, str]:
    """Each field's explanation: its ``#:`` comment lines above, else the comment at the end of its line."""
    source = inspect.getsource(cls).splitlines()
    found: dict[str, str] = {}
    for node in ast.parse("\n".join(source)).body[0].body:  # type: ignore[attr-defined]
        if not isinstance(node, ast.AnnAssign) or not isinstance(node.target, ast.Name):
            continue
        line = node.lineno - 1
        above = []
        for previous in reversed(source[:line]):
            stripped = previous.strip()
            if not stripped.startswith("#"):
                break
            above.insert(0, stripped.lstrip("#:").strip())
        _, hash_, trailing = source[line].partition("  # ")
        found[node.target.id] = " ".join(above) or (trailing.strip() if hash_ else "")
    return found


def _doc(cls: type) -> str:
    return " ".join((inspect.getdoc(cls) or "").split("\n\n")[0].split())


def _table(title: str, cls: type, default: Any) -> Iterator[str]:
    yield f"## {title}"
    yield ""
    yield f"{_doc(cls)} In context: {_TASK_PAGES[title.strip('[]')]}."
    yield ""
    yield "| Key | Default | Values | What it does |"
    yield "|---|---|---|---|"
    comments = _comments(cls)
    for item in dataclasses.fields(cls):
        text = comments.get(item.name) or "(not explained yet: add a `#:` comment above it in the schema)"
        value = _escape(_toml(getattr(default, item.name)))
        yield f"| `{item.name}` | `{value}` | {_values(item.metadata['check'])} | {_escape(text)} |"
    yield ""


def configuration_md() -> str:
    """The configuration reference, every table and key in the file's order."""
    lines = [
        "# Configuration: every key",
        "",
        f"Generated from the settings schema (`alpaca_zwo/config/settings.py`) by `{COMMAND}`; do not edit by hand.",
        "",
        "The configuration file is TOML, by default `config.toml` in the platform's configuration folder",
        "(`~/.config/alpaca-zwo/` on Linux; `--config FILE` picks another). The server writes it on first start",
        "(it records each device's permanent UniqueID), and the setup page and some Alpaca calls save into it",
        "(atomically: a temporary file, then a rename). Every key is checked for type and range and an unknown",
        "key is refused: a bad file stops the start with the file, the key and the reason. A `server.host` or",
        "`server.port` the server cannot listen with stops the start with one line saying which and where it",
        "is set (exit status 1); the setup page refuses such values in the first place.",
        "",
    ]
    defaults = schema.Settings()
    for name, cls in schema._SECTIONS.items():  # the file's order
        if name == "site":
            lines += list(_table("[[devices]]", schema.DeviceSettings, defaults.devices[0]))
            lines[-1:-1] = ["One table per mount; the first is Alpaca device 0, the next device 1, and so on."]
        lines += list(_table(f"[{name}]", cls, getattr(defaults, name)))
    return "\n".join(lines).rstrip() + "\n"


def _option(action: argparse.Action) -> str:
    flags = ", ".join(f"`{flag}`" for flag in action.option_strings)
    if action.nargs == 0:
        return flags
    choices = "{" + ",".join(map(str, action.choices)) + "}" if action.choices else ""
    shown = action.metavar or choices or action.dest.upper()
    return f"{flags} `{shown}`"


def _options(parser: argparse.ArgumentParser) -> Iterator[str]:
    local_default = str(default_config_path())
    yield "| Option | What it does |"
    yield "|---|---|"
    for action in parser._actions:
        if not action.option_strings:
            continue
        text = (action.help or "") % {"default": action.default, "prog": parser.prog}
        text = text.replace(local_default, "config.toml in the platform's configuration folder")
        choices = f" Choices: {', '.join(f'`{c}`' for c in action.choices)}." if action.choices and \
            not action.metavar and len(action.choices) > 1 and action.nargs != 0 else ""
        yield f"| {_option(action)} | {_escape(text)}.{choices} |".replace("..", ".")


def command_line_md() -> str:
    """The command-line reference of both programs."""
    lines = [
        "# The command line",
        "",
        f"Generated from the programs' own argument parsers by `{COMMAND}`; do not edit by hand.",
        "Options given on the command line are for that run only; the lasting settings are in",
        "[the configuration file](configuration.md). Ctrl-C or SIGTERM stops any manual motion (and parks",
        "when `safety.on_shutdown = \"park\"`) and exits cleanly.",
        "",
    ]
    for parser, what in ((server_parser(), "the server"), (emulator_parser(), "the mount emulator")):
        usage = " ".join(parser.format_usage().split()).removeprefix("usage: ")
        lines += [f"## `{parser.prog}`: {what}", "", parser.description or "", "", "```text", usage, "```", ""]
        lines += [*_options(parser), ""]
    return "\n".join(lines).rstrip() + "\n"


OUTPUTS: dict[Path, Callable[[], str]] = {
    GUIDE / "configuration.md": configuration_md,
    GUIDE / "command-line.md": command_line_md,
}


def stale() -> list[Path]:
    """The generated files whose text differs from what the code defines now."""
    return [path for path, make in OUTPUTS.items() if not path.is_file() or path.read_text(encoding="utf-8") != make()]


def main(argv: list[str]) -> int:
    if "--check" in argv:
        out_of_date = stale()
        for path in out_of_date:
            print(f"{path.relative_to(ROOT)} is out of date: run {COMMAND}", file=sys.stderr)
        return 1 if out_of_date else 0
    for path, make in OUTPUTS.items():
        path.write_text(make(), encoding="utf-8")
        print(f"wrote {path.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
