#!/usr/bin/env bash
# Submits a glint bake as Slurm job arrays: wave 0 (units that read no other unit, radiosity
# gathering among them), wave 1 (the radiosity unit, which reads the gathering shards) after
# it, wave 2 (units that read the radiosity unit's shard) after that, then the merge.
#
# usage: submit.sh SCENE.json SHARDS OUT.glint [QUALITY] [-- SBATCH_OPTION...]
#
# What each job asks for (an array task bakes one unit, with as many threads as CPUs granted):
#   every unit:            GLINT_CPUS CPUs (default 2)
#   waves 0 and 2, merge:  GLINT_MEM memory (default 2G: every stage but radiosity peaked at
#                          1.1 GiB or less on a 2M-triangle building at default quality)
#   wave 1 (radiosity):    GLINT_RADIOSITY_MEM (default 8G: the whole solve, 7.0 GiB on that
#                          building; see docs/measurements.md#scale)
#   the merge:             1 CPU
# A default larger than the largest node `sinfo` lists is lowered to that node's size, so no job
# waits for a node that does not exist. sbatch options after `--` go to every job after these,
# so they win (e.g. `-- --partition=long --mem=16G`); SBATCH_* environment variables work for
# options not set here (SBATCH_PARTITION, SBATCH_ACCOUNT, SBATCH_TIMELIMIT, ...).
#
# Resubmitting with the same arguments resumes: a unit whose shard is complete for the same
# inputs prints "up to date" and bakes nothing, so only cancelled, failed or changed units run.
set -euo pipefail
args=() extra=()
while [ $# -gt 0 ]; do
  if [ "$1" = -- ]; then
    shift
    extra=("$@")
    break
  fi
  args+=("$1")
  shift
done
if [ "${#args[@]}" -lt 3 ] || [ "${#args[@]}" -gt 4 ]; then
  echo "usage: submit.sh SCENE.json SHARDS OUT.glint [QUALITY] [-- SBATCH_OPTION...]" >&2
  exit 2
fi
scene=${args[0]} shards=${args[1]} out=${args[2]} q=${args[3]:-}
here=$(cd "$(dirname "$0")" && pwd)
quality=()
if [ -n "$q" ]; then quality=(--quality "$q"); fi

# The largest node's CPUs and memory (MB); empty where sinfo answers nothing.
largest() { sinfo -h -N -o "$1" 2>/dev/null | tr -dc '0-9\n' | sort -n | tail -n 1 || true; }
max_cpus=$(largest %c) max_mb=$(largest %m)
fit_cpus() { if [ -n "$max_cpus" ] && [ "$max_cpus" -gt 0 ] && [ "$max_cpus" -lt "$1" ]; then echo "$max_cpus"; else echo "$1"; fi; }
fit_mem() { if [ -n "$max_mb" ] && [ "$max_mb" -gt 0 ] && [ "$max_mb" -lt "$1" ]; then echo "${max_mb}M"; else echo "${1}M"; fi; }
cpus=${GLINT_CPUS:-$(fit_cpus 2)}
mem=${GLINT_MEM:-$(fit_mem 2048)}
radiosity_mem=${GLINT_RADIOSITY_MEM:-$(fit_mem 8192)}

export SCENE=$scene SHARDS=$shards QUALITY=$q
after=()
for wave in 0 1 2; do
  n=$(glint-bake "$scene" "${quality[@]}" --plan --wave "$wave" | wc -l)
  [ "$n" -gt 0 ] || continue
  wave_mem=$mem
  if [ "$wave" = 1 ]; then wave_mem=$radiosity_mem; fi
  job=$(sbatch --parsable "${after[@]}" --array="0-$((n - 1))" --export="ALL,WAVE=$wave" \
    --cpus-per-task="$cpus" --mem="$wave_mem" "${extra[@]}" "$here/glint-unit.sbatch")
  echo "wave $wave: $n units, job $job ($cpus CPUs, $wave_mem each${extra[*]:+; then ${extra[*]}})"
  after=(--dependency="afterok:$job")
done
job=$(sbatch --parsable "${after[@]}" --job-name=glint-merge --output=glint-merge-%j.log \
  --cpus-per-task=1 --mem="$mem" "${extra[@]}" --wrap="glint-bundle merge '$out' '$shards'/*.glint")
echo "merge: job $job → $out"
