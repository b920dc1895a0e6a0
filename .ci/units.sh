#!/usr/bin/env bash
# Bakes glossy-room (draft) as work units with `xargs -P 2`, merges the shards and checks that
# the result holds the same assets, byte for byte, and the same settings as a whole bake.
# usage: .ci/units.sh BIN_DIR
set -euo pipefail
bin=$(cd "$1" && pwd)
cd "$(dirname "$0")/.."
scene=scenes/glossy-room/scene.json
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
"$bin/glint-bake" "$scene" --quality draft --bundle "$tmp/whole.glint" >/dev/null 2>"$tmp/whole.log"
for wave in 0 1 2; do
  "$bin/glint-bake" "$scene" --quality draft --plan --wave "$wave" \
    | xargs -P 2 -I{} "$bin/glint-bake" "$scene" --quality draft --unit {} --bundle "$tmp/shards/{}.glint" >/dev/null 2>>"$tmp/units.log"
done
"$bin/glint-bundle" merge "$tmp/merged.glint" "$tmp"/shards/*.glint
"$bin/glint-bundle" verify "$tmp/merged.glint" >/dev/null
python3 - "$tmp/whole.glint/manifest.json" "$tmp/merged.glint/manifest.json" <<'PY'
import json, sys
def stages(p):
    m = json.load(open(p))
    return {s: (r["settings"], [(a["path"], a["kind"], a["bytes"], a["blake3"]) for a in r["assets"]])
            for s, r in m["stages"].items()}
whole, merged = stages(sys.argv[1]), stages(sys.argv[2])
bad = [s for s in sorted(set(whole) | set(merged)) if whole.get(s) != merged.get(s)]
n = sum(len(a) for _, a in whole.values())
if bad:
    sys.exit(f"units: the merged bundle differs from the whole bake in stage(s) {', '.join(bad)}")
print(f"units: glossy-room baked as units and merged: {n} assets byte-identical to a whole bake")
PY
