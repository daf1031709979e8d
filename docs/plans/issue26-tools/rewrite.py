# ruff: noqa  (a one-off tool of the issue-26 plan, deleted once the restructuring is done)
"""Rewrite every import of a moved module (absolute, relative, `from pkg import module`, dotted strings).

usage: python rewrite.py ROOT   (after the git mv; ROOT = repository root)
Python files under alpaca_zwo/ tests/ benchmarks/ scripts/ tools/: ast-located ImportFrom/Import
nodes are rewritten in place (relative imports stay relative, recomputed from the file's NEW
package); string literals naming an old dotted module (mock targets, logger names, -m args) are
rewritten too. Other text files (docs, README, Dockerfile, pyproject, deploy) get path and dotted-name
replacements on word boundaries. Prints every change; idempotent.
"""
from __future__ import annotations
import ast, re, sys
from pathlib import Path
sys.path.insert(0, str(Path(__file__).parent))
from moves import MOVES

ROOT = Path(sys.argv[1])
OLD_TO_NEW = dict(MOVES)
# `from alpaca_zwo import wire_values` style: names that are modules
MODULE_NAMES = {old.rsplit(".", 1)[1]: new for old, new in MOVES.items()}

def module_of(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)

def package_of(path: Path) -> str:
    mod = module_of(path)
    return mod if path.name == "__init__.py" else mod.rpartition(".")[0]

def absolute(pkg: str, level: int, module: str | None) -> str:
    base = pkg.split(".")
    base = base[: len(base) - (level - 1)] if level > 1 else base
    return ".".join(base + ([module] if module else []))

def relative(pkg: str, target: str) -> tuple[int, str]:
    """Shortest relative form of `target` seen from package `pkg`."""
    p, t = pkg.split("."), target.split(".")
    common = 0
    while common < min(len(p), len(t)) and p[common] == t[common]:
        common += 1
    level = len(p) - common + 1
    return level, ".".join(t[common:])

def new_name(mod: str) -> str:
    if mod in OLD_TO_NEW:
        return OLD_TO_NEW[mod]
    return mod  # exact names only: a prefix rule would rewrite alpaca_zwo.mount.operations again

def rewrite_py(path: Path) -> list[str]:
    text = path.read_text()
    tree = ast.parse(text)
    lines = text.splitlines(keepends=True)
    pkg = package_of(path) if path.is_relative_to(ROOT / "alpaca_zwo") else None
    edits: list[tuple[int, int, int, int, str]] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                if pkg is None:
                    continue
                # pkg is the NEW package; resolve against the OLD package of this file
                target = absolute(OLD_PKG.get(path, pkg), node.level, node.module)
            else:
                target = node.module or ""
            if not target.startswith("alpaca_zwo"):
                continue
            names = [a.name for a in node.names]
            moved_names = [n for n in names if target == "alpaca_zwo" and n in MODULE_NAMES]
            new_target = new_name(target)
            if moved_names:
                # `from alpaca_zwo import sky, wire_values` -> split: one import per new parent package
                groups: dict[str, list[str]] = {}
                for a in node.names:
                    dest = MODULE_NAMES.get(a.name) if a.name in moved_names else None
                    parent, _, leaf = (dest.rpartition(".") if dest else ("alpaca_zwo", "", a.name))
                    groups.setdefault(parent, []).append(leaf + (f" as {a.asname}" if a.asname else (f" as {a.name}" if dest and leaf != a.name else "")))
                stmts = []
                for parent, items in groups.items():
                    mod = parent
                    if node.level and pkg is not None:
                        lvl, rest = relative(pkg, parent)
                        mod = "." * lvl + rest
                    stmts.append(f"from {mod} import {', '.join(items)}")
                replacement = ("\n" + " " * node.col_offset).join(stmts)
            elif new_target != target or (node.level and pkg is not None and OLD_PKG.get(path, pkg) != pkg):
                if node.level and pkg is not None:
                    lvl, rest = relative(pkg, new_target)
                    mod = "." * lvl + rest
                else:
                    mod = new_target
                src = ast.get_source_segment(text, node)
                replacement = re.sub(r"^from\s+\S+\s+import", f"from {mod} import", src, count=1)
                if replacement == src:
                    continue
            else:
                continue
            edits.append((node.lineno, node.col_offset, node.end_lineno, node.end_col_offset, replacement))
        elif isinstance(node, ast.Import):
            for a in node.names:
                if a.name in OLD_TO_NEW:
                    src = ast.get_source_segment(text, node)
                    edits.append((node.lineno, node.col_offset, node.end_lineno, node.end_col_offset,
                                  src.replace(a.name, OLD_TO_NEW[a.name])))
        elif isinstance(node, ast.Constant) and isinstance(node.value, str):
            v = node.value
            for old, new in OLD_TO_NEW.items():
                if re.search(rf"(?<![\w.]){re.escape(old)}(?![\w])", v):
                    src = ast.get_source_segment(text, node)
                    nsrc = re.sub(rf"(?<![\w.]){re.escape(old)}(?![\w])", new, src)
                    if nsrc != src:
                        edits.append((node.lineno, node.col_offset, node.end_lineno, node.end_col_offset, nsrc))
                    break
    if not edits:
        return []
    # apply from the end
    offsets = [0]
    for line in lines:
        offsets.append(offsets[-1] + len(line))
    out = text
    for l1, c1, l2, c2, rep in sorted(edits, key=lambda e: (e[0], e[1]), reverse=True):
        a = offsets[l1 - 1] + len(lines[l1 - 1].encode()[:c1].decode())
        b = offsets[l2 - 1] + len(lines[l2 - 1].encode()[:c2].decode())
        out = out[:a] + rep + out[b:]
    path.write_text(out)
    return [f"{path.relative_to(ROOT)}: {len(edits)} edit(s)"]

def rewrite_text(path: Path) -> list[str]:
    text = path.read_text()
    new = text
    for old, new_mod in OLD_TO_NEW.items():
        old_path, new_path = old.replace(".", "/") + ".py", new_mod.replace(".", "/") + ".py"
        new = re.sub(rf"(?<![\w/.]){re.escape(old_path)}", new_path, new)
        new = re.sub(rf"(?<![\w.]){re.escape(old)}(?![\w])", new_mod, new)
    if new != text:
        path.write_text(new)
        return [f"{path.relative_to(ROOT)}: text"]
    return []

# OLD_PKG: a moved file's package BEFORE the move (relative imports in it were written against it)
NEW_TO_OLD_FILE = {}
for old, new in MOVES.items():
    NEW_TO_OLD_FILE[ROOT / (new.replace(".", "/") + ".py")] = old
OLD_PKG = {f: old.rpartition(".")[0] for f, old in NEW_TO_OLD_FILE.items()}

changes = []
for top in ("alpaca_zwo", "tests", "benchmarks", "scripts", "tools"):
    for path in sorted((ROOT / top).rglob("*.py")) if (ROOT / top).exists() else []:
        changes += rewrite_py(path)
for pattern in ("*.md", "docs/**/*", "Dockerfile", "pyproject.toml", "deploy/**/*", "alpaca_zwo/**/*.md", ".ci/*", "scripts/*"):
    for path in ROOT.glob(pattern):
        if path.is_file() and path.suffix not in (".py", ".png", ".jpg", ".svg", ".ico"):
            try:
                changes += rewrite_text(path)
            except UnicodeDecodeError:
                pass
print("\n".join(changes))
print(f"{len(changes)} files changed")
