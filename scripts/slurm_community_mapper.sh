#!/usr/bin/env bash
# `colmap community_mapper` on a Slurm cluster: the partition as one job, the
# communities as a job array (one task per community, SLURM_ARRAY_TASK_ID is
# the community id), the merge as a job that depends on the array. All three
# read and write OUT, which must be on storage every node sees, as must the
# database and the images.
#
#   scripts/slurm_community_mapper.sh --database_path DB --image_path IMAGES \
#       --output_path OUT [--CommunityMapper.* ...] [--Mapper.* ...]
#
# The options go to `colmap community_partitioner`, which records them in
# OUT/project.ini and OUT/plan.txt; the community and merge jobs read them
# from there. The script waits for the merge and returns its exit status.
#
# Environment:
#   COLMAP        the colmap binary (default: colmap on PATH)
#   SBATCH_ARGS   extra sbatch arguments of every job, e.g.
#                 "--partition=cpu --time=04:00:00"
#   COMMUNITY_ARGS extra sbatch arguments of the community jobs only, e.g.
#                 "--cpus-per-task=8 --mem=16G"
#   MAX_PARALLEL  at most this many communities at once (array throttle)
#
# Faults: a community job that fails (or a node that dies) leaves no record;
# the merge then refuses, naming the missing communities. Run this script
# again with the same arguments: the partition and every community with a
# record are reused, only the missing ones run again. A single community can
# also be rerun by hand:
#   sbatch --wrap "colmap community_reconstructor \
#       --project_path OUT/project.ini --community_id K"
set -euo pipefail

COLMAP=${COLMAP:-colmap}
read -r -a sbatch_args <<< "${SBATCH_ARGS:-}"
read -r -a community_args <<< "${COMMUNITY_ARGS:-}"

output_path=""
arguments=("$@")
for ((i = 0; i < ${#arguments[@]}; ++i)); do
  case "${arguments[$i]}" in
    --output_path) output_path="${arguments[$((i + 1))]:-}" ;;
    --output_path=*) output_path="${arguments[$i]#--output_path=}" ;;
  esac
done
if [ -z "$output_path" ]; then
  echo "usage: $0 --database_path DB --image_path IMAGES --output_path OUT" \
       "[colmap community_mapper options]" >&2
  exit 2
fi
for tool in sbatch "$COLMAP"; do
  if ! command -v "$tool" > /dev/null; then
    echo "$0: $tool not found (set COLMAP to the colmap binary)" >&2
    exit 2
  fi
done
COLMAP=$(command -v "$COLMAP")
mkdir -p "$output_path/slurm"
output_path=$(cd "$output_path" && pwd)
logs="$output_path/slurm"

quote() { printf '%q ' "$@"; }

echo "Partition ..."
sbatch --parsable --wait "${sbatch_args[@]}" --job-name=community-partition \
  --output="$logs/partition.log" \
  --wrap "$(quote "$COLMAP" community_partitioner "$@")" > /dev/null || {
  echo "$0: the partition failed, see $logs/partition.log" >&2
  exit 1
}

num_communities=$(awk '$1 == "num_communities" { print $2 }' \
                  "$output_path/plan.txt")
if [ -z "$num_communities" ] || [ "$num_communities" -lt 1 ]; then
  echo "$0: $output_path/plan.txt has no communities" >&2
  exit 1
fi
project="$output_path/project.ini"
array="0-$((num_communities - 1))${MAX_PARALLEL:+%$MAX_PARALLEL}"
echo "Communities: $num_communities (array $array) ..."
array_job=$(sbatch --parsable "${sbatch_args[@]}" "${community_args[@]}" \
  --job-name=community --array="$array" \
  --output="$logs/community_%a.log" \
  --wrap "$(quote "$COLMAP" community_reconstructor --project_path "$project") --community_id \$SLURM_ARRAY_TASK_ID")

# afterany: the merge checks that every community has its record itself,
# and names the missing ones.
echo "Merge (after job $array_job) ..."
if sbatch --parsable --wait "${sbatch_args[@]}" --job-name=community-merge \
     --dependency="afterany:$array_job" --output="$logs/merge.log" \
     --wrap "$(quote "$COLMAP" community_merger --project_path "$project")" \
     > /dev/null; then
  echo "Merged models in $output_path (logs in $logs)"
else
  echo "$0: the merge failed, see $logs/merge.log; rerun this script to" \
       "redo only the missing communities" >&2
  exit 1
fi
