#!/bin/bash
# Submits a season: one array task per mission, the merge after all of them succeed, then
# (RELABEL=1) every mission labelled again in the merged topics. Run from this directory.
set -euo pipefail
n=$(grep -c -v -e '^#' -e '^[[:space:]]*$' "${MISSIONS:-missions.txt}")
mkdir -p logs
missions=$(sbatch --parsable --array=1-"$n" mission.sbatch)
merge=$(sbatch --parsable --dependency=afterok:"$missions" merge.sbatch)
echo "missions: job $missions (array 1-$n); merge: job $merge"
if [ "${RELABEL:-0}" = 1 ]; then
  fixed=$(sbatch --parsable --dependency=afterok:"$merge" --array=1-"$n" --export=ALL,FIXED=1 mission.sbatch)
  echo "relabel: job $fixed"
fi
