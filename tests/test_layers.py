"""The house's shape (issue 26), read from the imports: layers as packages, each importing only layers below.

Every import counts, including those under ``TYPE_CHECKING`` and inside functions: a lazy import is still a
dependency a newcomer must know about. The rules are docs/ARCHITECTURE.md's; each package's docstring
says the same in words.
"""

from __future__ import annotations

import ast
from collections.abc import Iterator
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "alpaca_zwo"

#: room -> the rooms it may import (besides itself, ``_exceptions`` and the package's ``__init__``).
ALLOWED: dict[str, set[str]] = {
    "_exceptions": set(),
    "sky": set(),
    "clients": set(),
    "service": set(),
    "healthcheck": set(),
    "zwo": set(),
    "alpaca": {"clients"},
    "mount": {"zwo", "sky"},
    "config": {"zwo"},
    "emulator": {"zwo", "sky"},
    "catalogue": {"sky"},
    "motion": {"mount", "config", "zwo", "clients", "sky"},
    "telescope": {"motion", "mount", "config", "zwo", "clients", "sky"},
    "bridges": {"telescope", "mount", "config", "zwo", "clients", "sky"},
    "observatory": {"telescope", "motion", "config", "alpaca", "clients"},
    "facade": {"telescope", "motion", "mount", "config", "zwo", "alpaca", "clients", "sky"},
    "web": {"facade", "catalogue", "sky"},
    "server": {"facade", "web", "bridges", "observatory", "telescope", "motion", "mount", "config", "zwo", "alpaca",
               "emulator", "clients", "sky", "service"},
    "cli": {"server", "web", "config", "zwo", "alpaca", "emulator", "service", "clients", "sky"},
    "__main__": {"cli"},
}
FREE = {"_exceptions", "__init__"}  # anyone may import these
MAX_TOP_MODULES = 8  # besides __init__ and __main__
MAX_FLOORS = 10  # the longest chain of imports between rooms, counted in rooms


def _module_name(path: Path) -> str:
    parts = ["alpaca_zwo", *path.relative_to(PACKAGE).with_suffix("").parts]
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imports(path: Path, known: set[str]) -> Iterator[str]:
    """The dotted alpaca_zwo modules (or packages) ``path`` imports, relative imports resolved."""
    package = _module_name(path).split(".")
    if path.name != "__init__.py":
        package = package[:-1]
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            yield from (a.name for a in node.names if a.name.startswith("alpaca_zwo"))
        elif isinstance(node, ast.ImportFrom):
            base = package[: len(package) - node.level + 1] if node.level else []
            module = ".".join(base + ([node.module] if node.module else []))
            if module.startswith("alpaca_zwo"):  # `from pkg import module` names the module, not pkg
                yield from (f"{module}.{a.name}" if f"{module}.{a.name}" in known else module for a in node.names)


def _modules() -> dict[str, set[str]]:
    files = {_module_name(p): p for p in PACKAGE.rglob("*.py")}
    return {name: {m for m in _imports(path, set(files)) if m in files and m != name} for name, path in files.items()}


def _room(module: str) -> str:
    parts = module.split(".")
    return "__init__" if len(parts) == 1 else parts[1]


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one node (Tarjan), i.e. the import circles."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    found: list[list[str]] = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        for nxt in graph.get(node, ()):
            if nxt not in index:
                visit(nxt)
                low[node] = min(low[node], low[nxt])
            elif nxt in stack:
                low[node] = min(low[node], index[nxt])
        if low[node] == index[node]:
            component = []
            while True:
                top = stack.pop()
                component.append(top)
                if top == node:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return found


def _rooms() -> dict[str, set[str]]:
    rooms: dict[str, set[str]] = {}
    for module, targets in _modules().items():
        here = _room(module)
        rooms.setdefault(here, set()).update(_room(t) for t in targets if _room(t) != here)
    return rooms


def test_no_module_imports_a_module_that_imports_it_back() -> None:
    assert _cycles(_modules()) == []


def _against_rules(rooms: dict[str, set[str]]) -> dict[str, list[str]]:
    """room -> the rooms it imports that its row of ALLOWED does not list."""
    return {room: sorted(targets - ALLOWED.get(room, set()) - FREE) for room, targets in rooms.items()
            if room not in FREE and targets - ALLOWED.get(room, set()) - FREE}


def test_each_layer_imports_only_the_layers_below_it() -> None:
    assert _against_rules(_rooms()) == {}, "imports against docs/ARCHITECTURE.md's layer rule"


def test_every_room_has_a_rule() -> None:
    assert set(_rooms()) - FREE <= set(ALLOWED), "a new top-level module or package needs its row in ALLOWED"


def test_the_emulator_never_imports_the_link() -> None:
    uses = {m: sorted(t for t in targets if t.startswith("alpaca_zwo.zwo.link"))
            for m, targets in _modules().items() if m.startswith("alpaca_zwo.emulator")}
    assert {m: t for m, t in uses.items() if t} == {}


def test_few_modules_at_the_top_and_few_floors() -> None:
    top = sorted(p.stem for p in PACKAGE.glob("*.py") if p.stem not in ("__init__", "__main__"))
    assert len(top) <= MAX_TOP_MODULES, top
    rooms = _rooms()
    floors: dict[str, int] = {}

    def floor(room: str) -> int:
        if room not in floors:
            floors[room] = 1 + max((floor(r) for r in rooms.get(room, ())), default=0)
        return floors[room]

    assert max(floor(r) for r in rooms) <= MAX_FLOORS


def test_the_rules_can_see_a_circle_and_a_wrong_way_import() -> None:
    """The checks themselves, on a made-up graph: a circle is found, and so is an import upwards."""
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert _against_rules({"motion": {"mount", "telescope"}, "web": {"facade", "_exceptions"}}) == {
        "motion": ["telescope"]}


#: Files the ZWO command table's merge (issue 34 part A) removes; a class there may still repeat a name
#: until then. Empty this once they are gone.
_LEAVING = {"bridges/zwo_clock_site.py"}


def test_no_class_name_is_defined_twice() -> None:
    """One name, one class: a reader who meets ``Pulse`` or ``Reading`` knows which one it is."""
    where: dict[str, list[str]] = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        name = path.relative_to(PACKAGE).as_posix()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ClassDef) and name not in _LEAVING:
                where.setdefault(node.name, []).append(name)
    assert {cls: files for cls, files in where.items() if len(files) > 1} == {}


def test_no_stale_module_names() -> None:
    """Modules that moved (``alpaca_zwo.firmware`` is ``zwo/firmware.py``, ``alpaca_zwo/actions.py`` is
    ``telescope/actions.py``, the catalogue left ``web/``) are not named by their old paths anywhere."""
    stale = ("alpaca_zwo.firmware", "alpaca_zwo/firmware.py", "alpaca_zwo/actions.py", "alpaca_zwo.actions",
             "alpaca_zwo/web/objects.py", "alpaca_zwo.web.objects", "web/sky_data.json", "web/star_names.csv")
    roots = [PACKAGE, PACKAGE.parent / "tests", PACKAGE.parent / "docs", PACKAGE.parent / "tools"]
    found = [f"{path.relative_to(PACKAGE.parent)}: {old}" for root in roots for path in sorted(root.rglob("*"))
             if path.suffix in (".py", ".md", ".toml") and path != Path(__file__)
             for old in stale if old in path.read_text(encoding="utf-8")]
    assert found == []
