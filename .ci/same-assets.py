#!/usr/bin/env python3
"""Fails unless a merged bundle holds the same stages as a whole bake: the same settings and
every asset's path, kind, size and BLAKE3 hash.
usage: same-assets.py WHOLE/manifest.json MERGED/manifest.json LABEL"""
import json
import sys


def stages(path):
    m = json.load(open(path))
    return {s: (r["settings"], [(a["path"], a["kind"], a["bytes"], a["blake3"]) for a in r["assets"]])
            for s, r in m["stages"].items()}


whole, merged = stages(sys.argv[1]), stages(sys.argv[2])
label = sys.argv[3]
bad = [s for s in sorted(set(whole) | set(merged)) if whole.get(s) != merged.get(s)]
n = sum(len(a) for _, a in whole.values())
if bad:
    sys.exit(f"{label}: the merged bundle differs from the whole bake in stage(s) {', '.join(bad)}")
print(f"{label}: {n} assets byte-identical to a whole bake")
