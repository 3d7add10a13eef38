#!/usr/bin/env bash
# Checks the deploy/ files: the Slurm scripts parse (bash -n) and their #SBATCH lines are
# options sbatch knows; the Kubernetes manifests validate against the API schemas
# (kubernetes-validate from PyPI, strict: no unknown fields), and each sharded Job's
# (precompute, batch) DERMA_SHARD_COUNT equals its completions. Run by scripts/test.sh.
set -euo pipefail
cd "$(dirname "$0")"
for f in slurm/*.sbatch; do
  bash -n "$f"
  grep '^#SBATCH' "$f" | sed 's/^#SBATCH //' | while read -r opt; do
    case "${opt%%=*}" in
      --job-name|--gres|--cpus-per-task|--mem|--time|--requeue|--open-mode|--output|--array|--partition) ;;
      *) echo "$f: unexpected sbatch option '$opt'" >&2; exit 1 ;;
    esac
  done
done
venv=${DERMA_TOOLS:-../target/peer-deploy}
[ -x "$venv/bin/kubernetes-validate" ] || {
  python3 -m venv "$venv"
  "$venv/bin/pip" install --quiet kubernetes-validate==1.37.0
}
"$venv/bin/kubernetes-validate" --strict -k 1.31.0 kubernetes/*.yaml
for f in kubernetes/precompute-*.yaml kubernetes/batch.yaml; do
  c=$(sed -n 's/^  completions: //p' "$f")
  n=$(grep -A1 'name: DERMA_SHARD_COUNT' "$f" | sed -n 's/.*value: "\(.*\)"/\1/p')
  [ "$c" = "$n" ] || { echo "$f: completions $c but DERMA_SHARD_COUNT $n" >&2; exit 1; }
done
echo "deploy: Slurm scripts parse; Kubernetes manifests valid (1.31, strict); shard counts match"
