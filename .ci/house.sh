#!/usr/bin/env bash
# House rules a newcomer relies on (issue 49), checked in CI before the tests:
#   1. README.md holds at most 250 lines, none over 400 characters: it is for users; the
#      design, formats, measurements and history live in docs/ and CHANGELOG.md.
#   2. No code comment in src/**/*.rs or shaders/*.wgsl holds a measured percentage (a number
#      followed by %): figures live in docs/measurements.md and docs/tuning.md, and a comment
#      links them (docs/tuning.md#anchor). A formula's own percentage (a threshold's
#      definition, a default) may stay: add the phrase that carries it to ALLOWED below, so
#      each exception is written down once and reviewed.
#   3. A file in src/ over 800 lines says why it is one file: a module-comment line starting
#      with "//! Kept in one file".
#   4. .ci/import-loops.py finds no loop between the top-level modules of src/, and
#      .ci/module-loops.py none between its files.
# Needs bash and python3 (standard library only). Exit 1 with one line per fault.
set -euo pipefail
cd "$(dirname "$0")/.."

python3 - <<'PY'
import pathlib, re, sys

MAX_README_LINES = 250
MAX_README_LINE_CHARS = 400
MAX_FILE_LINES = 800
KEPT_PHRASE = "//! Kept in one file"

# Phrases that hold a formula's own percentage, not a measurement. Keep this short.
ALLOWED = [
    "99.9 % of",                    # materials/kernel.rs: the K threshold's mass, by construction
    "96.8 % of",                    # materials/kernel.rs: the same, for an isotropic lobe
    "96 % of the diffuse energy",   # scene/material.rs: glTF Appendix B's split, by its formula
    "within 10%",                   # quadtree limits, the planar face-set tie rule
    "(plus 10%)",                   # radiosity/solve.rs: the refinement batch's margin
    "30% beyond",                   # eval/sweep/report.rs: a plot axis's margin
    "1% of the scene",              # eval probes' default reach
    "5% of the reference's mean",   # eval/probe.rs: the relative error's floor
    "below 1 %",                    # view options: the specular-weight cutoff's default
    "central 99 %",                 # view/reflections/lobe_shape.rs: K's kept mass
    "5% of its distance",           # view/reflections/splats.rs: the patch's push back
    "1% of its depth range",        # srdm/capture.rs: the capture frustum's margin
]

PERCENT = re.compile(r"\d(?:[.,]\d+)?\s?%")
faults = []

readme = pathlib.Path("README.md").read_text(encoding="utf-8").split("\n")
if readme and readme[-1] == "":
    readme.pop()
if len(readme) > MAX_README_LINES:
    faults.append(f"README.md: {len(readme)} lines, at most {MAX_README_LINES} (move detail to docs/)")
for n, line in enumerate(readme, 1):
    if len(line) > MAX_README_LINE_CHARS:
        faults.append(f"README.md:{n}: {len(line)} characters, at most {MAX_README_LINE_CHARS}")

def comment_of(line):
    """The part of a line after `//` outside a string literal (good enough for this code)."""
    in_str = False
    i = 0
    while i < len(line) - 1:
        c = line[i]
        if c == "\\" and in_str:
            i += 2
            continue
        if c == '"':
            in_str = not in_str
        elif not in_str and line.startswith("//", i):
            return line[i:]
        i += 1
    return None

sources = sorted(pathlib.Path("src").rglob("*.rs")) + sorted(pathlib.Path("shaders").glob("*.wgsl"))
for path in sources:
    lines = path.read_text(encoding="utf-8").split("\n")
    for n, line in enumerate(lines, 1):
        comment = comment_of(line)
        if comment is None or not PERCENT.search(comment):
            continue
        if any(phrase in comment for phrase in ALLOWED):
            continue
        faults.append(f"{path}:{n}: a measured percentage in a comment (move it to docs/tuning.md "
                      f"and link the anchor; a formula's own percentage goes in .ci/house.sh's ALLOWED): "
                      f"{comment.strip()[:120]}")
    if path.suffix == ".rs" and len(lines) - (lines[-1] == "") > MAX_FILE_LINES:
        if not any(l.startswith(KEPT_PHRASE) for l in lines):
            faults.append(f"{path}: {len(lines)} lines, over {MAX_FILE_LINES}: split it, or say why in a "
                          f"module-comment line starting with \"{KEPT_PHRASE}\"")

for fault in faults:
    print(f"house: {fault}", file=sys.stderr)
if faults:
    print(f"house: {len(faults)} fault(s); see the rules at the top of .ci/house.sh", file=sys.stderr)
    sys.exit(1)
print("house: README, comments and file sizes follow the house rules")
PY

if [ -f .ci/import-loops.py ]; then
  python3 .ci/import-loops.py
  python3 .ci/module-loops.py src
fi
