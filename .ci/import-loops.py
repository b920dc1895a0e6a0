#!/usr/bin/env python3
"""Reports import loops between glint's top-level modules; exits 1 if there is one.

Every `use crate::X...`, `crate::X::...` (and `use super::...` that climbs out of a top-level
module) in src/**.rs is an edge from the file's top-level module (src/scene/*.rs -> scene,
src/camera.rs -> camera) to X. A loop is a cycle in that graph: each is printed with, per
edge, one file and line that makes it.

    .ci/import-loops.py [SRC_DIR]          (default: src beside .ci/)
    .ci/import-loops.py --within scene     (loops between the files of src/scene/ instead)
    .ci/import-loops.py --with-tests       (count `#[cfg(test)] mod` blocks too; by default
                                            a unit test may use any layer)
"""

import re
import sys
from pathlib import Path

COMMENT = re.compile(r"//[^\n]*")


def module_path(src: Path, file: Path) -> list[str]:
    """`src/scene/desc.rs` -> ['scene', 'desc']; `src/scene/mod.rs` -> ['scene']."""
    parts = list(file.relative_to(src).with_suffix("").parts)
    if parts[-1] in ("mod", "lib", "main"):
        parts = parts[:-1]
    return parts


def strip_comments(text: str) -> str:
    """Drops line comments (doc comments name modules in links without importing them)."""
    return COMMENT.sub("", text)


TEST_MOD = re.compile(r"#\[cfg\(test\)\]\s*(?:pub(?:\([a-z]+\))?\s+)?mod\s+\w+\s*\{")


def strip_tests(text: str) -> str:
    """Blanks `#[cfg(test)] mod x { ... }` (lines kept): a unit test may use any layer, as an
    integration test would."""
    out, at = [], 0
    for m in TEST_MOD.finditer(text):
        if m.start() < at:
            continue
        depth, i = 1, m.end()
        while i < len(text) and depth:
            depth += {"{": 1, "}": -1}.get(text[i], 0)
            i += 1
        out.append(text[at : m.start()])
        out.append(re.sub(r"[^\n]", "", text[m.start() : i]))
        at = i
    out.append(text[at:])
    return "".join(out)


USE = re.compile(r"\buse\s+([^;]+);", re.S)
INLINE = re.compile(r"\b((?:crate|super)(?:::[A-Za-z_][A-Za-z0-9_]*)+)")


def expand(tree: str) -> list[list[str]]:
    """`a::{b, c::{d, e}}` -> [[a, b], [a, c, d], [a, c, e]] (`as` renames dropped)."""
    tree = re.sub(r"\s+as\s+[A-Za-z_][A-Za-z0-9_]*", "", tree)
    tree = re.sub(r"\s+", "", tree)

    def parse(t: str) -> list[list[str]]:
        if "{" not in t:
            return [[p for p in t.split("::") if p]]
        head, body = t.split("{", 1)
        body = body[: body.rfind("}")]
        items, depth, cur = [], 0, ""
        for ch in body:
            if ch == "," and depth == 0:
                items.append(cur)
                cur = ""
                continue
            depth += ch == "{"
            depth -= ch == "}"
            cur += ch
        items.append(cur)
        prefix = [p for p in head.split("::") if p]
        return [prefix + rest for item in items if item for rest in parse(item)]

    return parse(tree)


def resolve(here: list[str], path: list[str]) -> list[str] | None:
    """A path as written in module `here` -> the path from the crate root (None: another
    crate, or one this script does not follow)."""
    if not path:
        return None
    if path[0] == "crate":
        return path[1:]
    if path[0] in ("super", "self"):
        base = list(here)
        while path and path[0] in ("super", "self"):
            if path[0] == "super":
                if not base:
                    return None
                base.pop()
            path = path[1:]
        return base + path
    return None


def targets(src: Path, file: Path, text: str) -> list[tuple[list[str], int]]:
    """Each module path the file refers to (from the crate root), with its line."""
    here = module_path(src, file)
    out = []
    spans = []
    for m in USE.finditer(text):
        n = text.count("\n", 0, m.start()) + 1
        spans.append((m.start(), m.end()))
        for path in expand(m.group(1)):
            full = resolve(here, path)
            if full:
                out.append((full, n))
    for m in INLINE.finditer(text):
        if any(a <= m.start() < b for a, b in spans):
            continue
        n = text.count("\n", 0, m.start()) + 1
        full = resolve(here, m.group(1).split("::"))
        if full:
            out.append((full, n))
    return out


def graph(
    src: Path, within: str | None, with_tests: bool
) -> dict[str, dict[str, tuple[str, int]]]:
    """node -> {node it imports: (file, line)}; nodes are top-level modules, or with
    `within` the files (submodules) of that folder."""
    tops = {p.stem for p in src.glob("*.rs")} | {p.name for p in src.iterdir() if p.is_dir()}
    tops.discard("lib")
    edges: dict[str, dict[str, tuple[str, int]]] = {}
    for file in sorted(src.rglob("*.rs")):
        here = module_path(src, file)
        if not here:
            continue
        if within:
            if here[0] != within or len(here) < 2:
                continue
            node = here[1]
        else:
            node = here[0]
        text = strip_comments(file.read_text(encoding="utf-8"))
        if not with_tests:
            text = strip_tests(text)
        for path, line in targets(src, file, text):
            if within:
                if len(path) < 2 or path[0] != within:
                    continue
                to = path[1]
            else:
                to = path[0]
                if to not in tops:
                    continue
            if to != node:
                edges.setdefault(node, {}).setdefault(to, (str(file), line))
    return edges


def cycles(edges: dict[str, dict[str, tuple[str, int]]]) -> list[list[str]]:
    """The strongly connected components with more than one node (Tarjan), each as one
    cycle through all of it where possible, else the component's nodes."""
    index, low, stack, on, comps = {}, {}, [], set(), []
    counter = [0]

    def visit(v: str) -> None:
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in edges.get(v, {}):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                comps.append(sorted(comp))

    sys.setrecursionlimit(10000)
    for v in sorted(edges):
        if v not in index:
            visit(v)
    return [(c, shortest_loop(edges, c)) for c in comps]


def shortest_loop(edges: dict[str, dict[str, tuple[str, int]]], comp: list[str]) -> list[str]:
    """A shortest cycle through the component's first node, by breadth-first search."""
    start, members = comp[0], set(comp)
    prev: dict[str, str] = {}
    queue = [start]
    while queue:
        v = queue.pop(0)
        for w in sorted(edges.get(v, {})):
            if w not in members:
                continue
            if w == start:
                path = [v]
                while path[-1] != start:
                    path.append(prev[path[-1]])
                return list(reversed(path)) + [start]
            if w not in prev:
                prev[w] = v
                queue.append(w)
    return comp


def main() -> int:
    args = sys.argv[1:]
    within = None
    if "--within" in args:
        i = args.index("--within")
        within = args[i + 1]
        del args[i : i + 2]
    with_tests = "--with-tests" in args
    if with_tests:
        args.remove("--with-tests")
    src = Path(args[0]) if args else Path(__file__).resolve().parent.parent / "src"
    edges = graph(src, within, with_tests)
    loops = cycles(edges)
    what = f"files of {src}/{within}" if within else f"top-level modules of {src}"
    if not loops:
        print(f"no import loop between the {what}")
        return 0
    print(f"{len(loops)} group(s) of modules in import loops between the {what}:")
    for comp, loop in loops:
        print(f"  modules that import each other: {', '.join(comp)}")
        print("  e.g. " + " -> ".join(loop))
        for a, b in zip(loop, loop[1:]):
            file, line = edges[a][b]
            print(f"    {a} -> {b}: {file}:{line}")
    return 1


if __name__ == "__main__":
    sys.exit(main())
