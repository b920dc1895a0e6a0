#!/usr/bin/env bash
# Shows that two builds of glint behave the same: bakes shipped scenes with each and compares the
# bundles' stages (settings and every asset's bytes), then replays each bundle headless in several
# reflection modes with each viewer and compares every frame byte for byte.
# usage: .ci/compare.sh BEFORE_BIN_DIR AFTER_BIN_DIR [WORK_DIR]
#   env: SCENES (default: every folder of scenes/ with a scene.json), QUALITIES (default: draft),
#        VIEW=0 to skip the replays.
set -euo pipefail
before=$(cd "$1" && pwd); after=$(cd "$2" && pwd)
cd "$(dirname "$0")/.."
work=${3:-$(mktemp -d)}
mkdir -p "$work/before" "$work/after"
scenes=${SCENES:-$(for s in scenes/*/scene.json; do basename "$(dirname "$s")"; done)}
qualities=${QUALITIES:-draft}
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
fail=0
for scene in $scenes; do
  for q in $qualities; do
    for side in before after; do
      bin=$([ $side = before ] && echo "$before" || echo "$after")
      rm -rf "$work/$side/$scene-$q.glint"
      "$bin/glint-bake" "scenes/$scene/scene.json" --quality "$q" --bundle "$work/$side/$scene-$q.glint" \
        >/dev/null 2>"$work/$side/$scene-$q.log"
    done
    if python3 - "$work/before/$scene-$q.glint/manifest.json" "$work/after/$scene-$q.glint/manifest.json" <<'PY'
import json, sys
def stages(p):
    m = json.load(open(p))
    return (m["scene_name"], m["scene_hash"]), {s: (r["settings"], [(a["path"], a["kind"], a["bytes"], a["blake3"]) for a in r["assets"]])
                        for s, r in m["stages"].items()}
(sa, a), (sb, b) = stages(sys.argv[1]), stages(sys.argv[2])
bad = [s for s in sorted(set(a) | set(b)) if a.get(s) != b.get(s)]
if sa != sb: bad.append("scene")
n = sum(len(x) for _, x in a.values())
print(("DIFFERENT: " + ", ".join(bad)) if bad else f"same ({len(a)} stages, {n} assets)")
sys.exit(1 if bad else 0)
PY
    then r=ok; else r=DIFF; fail=1; fi
    echo "bake   $scene $q: $r"
  done
done
if [ "${VIEW:-1}" != 0 ] && [ -x "$before/glint-view" ] && [ -x "$after/glint-view" ]; then
  q=$(echo "$qualities" | awk '{print $1}')
  for scene in $scenes; do
    for mode in "off --curved off --impostors off" "geometry --recursion-depth 2 --curved cubemap --impostors off" "image --curved cubemap --impostors off"; do
      tag=$(echo "$mode" | tr ' ' '_' | tr -d '-')
      for side in before after; do
        bin=$([ $side = before ] && echo "$before" || echo "$after")
        rm -rf "$work/$side/frames/$scene/$tag"; mkdir -p "$work/$side/frames/$scene"
        "$bin/glint-view" "$work/before/$scene-$q.glint" --replay --headless --size 360x243 --every 40 \
          --reflections $mode --out "$work/$side/frames/$scene/$tag" >/dev/null 2>"$work/$side/view-$scene-$tag.log" \
          || echo "view   $scene $tag: $side exited non-zero (see $work/$side/view-$scene-$tag.log)"
      done
      n=0; d=0
      for f in "$work/before/frames/$scene/$tag"/*.png; do
        [ -e "$f" ] || continue
        n=$((n + 1)); cmp -s "$f" "$work/after/frames/$scene/$tag/$(basename "$f")" || d=$((d + 1))
      done
      nb=$(ls "$work/after/frames/$scene/$tag"/*.png 2>/dev/null | wc -l)
      if [ "$n" -gt 0 ] && [ "$d" = 0 ] && [ "$nb" = "$n" ]; then r="ok ($n frames identical)"; else r="DIFF ($d of $n frames differ, after has $nb)"; fail=1; fi
      echo "replay $scene $tag: $r"
    done
  done
fi
exit $fail
