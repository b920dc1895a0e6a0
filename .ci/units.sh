#!/usr/bin/env bash
# Runs README's GNU parallel lines (glossy-room as work units, at draft, merged) and checks that
# the result holds the same assets, byte for byte, and the same settings as a whole bake; the
# same lines must stand in docs/work-units.md.
# usage: .ci/units.sh BIN_DIR
set -euo pipefail
bin=$(cd "$1" && pwd)
cd "$(dirname "$0")/.."
repo=$PWD

as_root() { if [ "$(id -u)" = 0 ]; then "$@"; else sudo "$@"; fi; }
if ! command -v parallel >/dev/null; then
  export DEBIAN_FRONTEND=noninteractive
  as_root apt-get update -q
  as_root apt-get install -y -q parallel
fi

# The ```sh block that runs `parallel`, from a Markdown file.
recipe() { awk '/^```sh$/ { b = ""; on = 1; next } /^```$/ { if (on && b ~ /\| parallel /) printf "%s", b; on = 0; next } on { b = b $0 "\n" }' "$1"; }
lines=$(recipe README.md)
[ -n "$lines" ] || { echo "units: README.md has no GNU parallel block" >&2; exit 1; }
[ "$lines" = "$(recipe docs/work-units.md)" ] \
  || { echo "units: docs/work-units.md's GNU parallel block differs from README.md's" >&2; exit 1; }

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
ln -s "$repo/scenes" "$tmp/scenes"
cd "$tmp"
export PATH="$bin:$PATH"
glint-bake scenes/glossy-room/scene.json --quality draft --bundle whole.glint >/dev/null 2>whole.log
bash -euo pipefail -c "$lines" >units.log 2>&1 || { cat units.log >&2; exit 1; }
glint-bundle verify out/glossy-room.glint >/dev/null
python3 "$repo/.ci/same-assets.py" whole.glint/manifest.json out/glossy-room.glint/manifest.json \
  "units: glossy-room baked as units with GNU parallel and merged"
