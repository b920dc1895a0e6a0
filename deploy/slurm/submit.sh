#!/usr/bin/env bash
# Submits a glint bake as Slurm job arrays: wave 0 (units that read no other unit, radiosity
# gathering among them), wave 1 (the radiosity unit, which reads the gathering shards) after
# it, wave 2 (units that read the radiosity unit's shard) after that, then the merge.
#
# usage: submit.sh SCENE.json SHARDS OUT.glint [QUALITY]
set -euo pipefail
scene=$1 shards=$2 out=$3
here=$(cd "$(dirname "$0")" && pwd)
quality=()
if [ -n "${4:-}" ]; then quality=(--quality "$4"); fi
export SCENE=$scene SHARDS=$shards QUALITY=${4:-}
after=()
for wave in 0 1 2; do
  n=$(glint-bake "$scene" "${quality[@]}" --plan --wave "$wave" | wc -l)
  [ "$n" -gt 0 ] || continue
  job=$(sbatch --parsable "${after[@]}" --array="0-$((n - 1))" --export="ALL,WAVE=$wave" "$here/glint-unit.sbatch")
  echo "wave $wave: $n units, job $job"
  after=(--dependency="afterok:$job")
done
job=$(sbatch --parsable "${after[@]}" --job-name=glint-merge --output=glint-merge-%j.log \
  --wrap="glint-bundle merge '$out' '$shards'/*.glint")
echo "merge: job $job → $out"
