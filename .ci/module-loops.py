#!/usr/bin/env python3
"""Import loops between the files of a Rust source tree: `.ci/module-loops.py [--strict] [DIR]`
(default src/view). Each file is a module; file A depends on file B when A's non-test code names
a path (in a `use` or inline: `crate::…`, `super::…`, `self::…`, a child module) that resolves
into B. A folder's `mod.rs` and the files under it are one unit (a submodule may use what its
parent declares, and the parent re-exports its submodules), so edges between a module and its
own ancestors are left out unless `--strict`. Prints every strongly connected group of files
and exits 1 if there is one."""

import importlib.util
import re
import sys
from pathlib import Path

args = sys.argv[1:]
strict = "--strict" in args
args = [a for a in args if a != "--strict"]
root = Path(args[0] if args else "src/view")
crate_root = Path("src")


def module_of(path: Path) -> tuple:
    parts = list(path.relative_to(crate_root).with_suffix("").parts)
    if parts[-1] in ("mod", "lib", "main"):
        parts.pop()
    return tuple(parts)


files = {module_of(p): p for p in sorted(crate_root.rglob("*.rs"))}
ours = {m for m, p in files.items() if root in p.parents or p == root}


def code_of(text: str) -> str:
    """The file without comments, string literals and its test module."""
    text = re.sub(r"#\[cfg\(test\)\]\s*mod\s+\w+\s*\{.*", "", text, flags=re.S)
    text = re.sub(r'r#*"(?:.|\n)*?"#*|"(?:\\.|[^"\\])*"', '""', text)
    text = re.sub(r"//[^\n]*", "", text)
    return re.sub(r"/\*.*?\*/", "", text, flags=re.S)


def expand(tree: str) -> list:
    """`a::{b, c::{d, e}}` → [a::b, a::c::d, a::c::e]."""
    tree = re.sub(r"\s+", "", tree)
    out = []

    def walk(prefix: str, s: str):
        i = s.find("{")
        if i < 0:
            out.append(prefix + s)
            return
        head, body = s[:i], s[i + 1 : s.rfind("}")]
        depth, start = 0, 0
        for j, ch in enumerate(body + ","):
            if ch == "{":
                depth += 1
            elif ch == "}":
                depth -= 1
            elif ch == "," and depth == 0:
                if body[start:j]:
                    walk(prefix + head, body[start:j])
                start = j + 1

    walk("", tree)
    return out


def resolve(module: tuple, path: str, children: set):
    segs = [s for s in path.split("::") if s]
    if not segs:
        return None
    base = list(module)
    if segs[0] == "crate":
        base, segs = [], segs[1:]
    elif segs[0] == "self":
        segs = segs[1:]
    elif segs[0] == "super":
        while segs and segs[0] == "super":
            base.pop()
            segs = segs[1:]
    elif segs[0] in children:
        pass
    else:
        return None
    full = tuple(base + [s.split(" as ")[0] for s in segs])
    for n in range(len(full), 0, -1):
        if full[:n] in files:
            return full[:n]
    return None


edges = {m: set() for m in ours}
for m in ours:
    code = code_of(files[m].read_text())
    children = set(re.findall(r"\bmod\s+(\w+)\s*;", code))
    paths = [p for u in re.findall(r"\buse\s+([^;]+);", code) for p in expand(u)]
    paths += re.findall(r"\b((?:crate|super|self)(?:::\w+)+)", code)
    for p in paths:
        target = resolve(m, p, children)
        if not target or target == m or target not in ours:
            continue
        related = target == m[: len(target)] or m == target[: len(m)]
        if strict or not related:
            edges[m].add(target)

# The strongly connected components, found by import-loops.py's Tarjan (one copy of it).
_spec = importlib.util.spec_from_file_location("import_loops", Path(__file__).with_name("import-loops.py"))
import_loops = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(import_loops)
groups = [comp for comp, _ in import_loops.cycles(edges)]
for g in groups:
    print("loop:", " ".join(str(files[m]) for m in g))
    for m in g:
        print("  ", files[m], "->", ", ".join(str(files[t]) for t in sorted(edges[m] & set(g))))
print(f"{len(ours)} files under {root}, {sum(map(len, edges.values()))} edges, {len(groups)} loops")
sys.exit(1 if groups else 0)
