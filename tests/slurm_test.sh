#!/usr/bin/env bash
# The community mapper's stages on a real Slurm: a one-node cluster
# (slurmctld, slurmd, munge from Debian) is started in a temporary folder,
# scripts/slurm_community_mapper.sh submits the partition, the community
# array and the merge on a generated scene, and the merged model must be the
# one-process run's. Then a community is lost (its record and model
# deleted, as when its node died): the merge refuses and names it, and
# rerunning the script redoes that community only. The daemons are stopped
# by their PIDs. Exits 77 (skipped) where Slurm cannot start.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
BUILD_DIR=${BUILD_DIR:-$here/../build}
BUILD_DIR=$(cd "$BUILD_DIR" && pwd)
skip() { echo "SKIPPED: $*"; exit 77; }

for tool in slurmctld slurmd sbatch sinfo munged mungekey; do
  command -v "$tool" > /dev/null ||
    skip "$tool is not installed (scripts/install_deps.sh installs Slurm)"
done
[ "$(id -u)" -eq 0 ] || skip "the one-node cluster runs its daemons as root"

D=$(mktemp -d /tmp/colmap_slurm_test.XXXXXX)
W="$D/work"
mkdir -p "$D/state" "$D/spool" "$D/key" "$D/sock" "$W"
chmod 700 "$D/key"
chmod 755 "$D/sock" "$D"
stop_daemons() {
  for name in slurmd slurmctld munged; do
    if [ -f "$D/$name.pid" ]; then
      pid=$(cat "$D/$name.pid")
      kill "$pid" 2>/dev/null || true
      for _ in $(seq 50); do
        kill -0 "$pid" 2>/dev/null || break
        sleep 0.1
      done
    fi
  done
}
cleanup() {
  status=$?
  stop_daemons
  if [ "$status" -ne 0 ] && [ "$status" -ne 77 ]; then
    for log in "$D"/*.log "$W"/sparse-slurm/slurm/*.log; do
      [ -f "$log" ] && { echo "== $log"; tail -n 30 "$log"; }
    done
  fi
  rm -rf "$D"
}
trap cleanup EXIT

mungekey -c -k "$D/key/munge.key" > /dev/null 2>&1 ||
  skip "mungekey could not create a key"
munged -f --key-file="$D/key/munge.key" --socket="$D/sock/munge.sock" \
  --pid-file="$D/munged.pid" --log-file="$D/munged.log" \
  --seed-file="$D/key/munged.seed" || skip "munged did not start"
cat > "$D/slurm.conf" <<CONF
ClusterName=ci
SlurmctldHost=localhost
SlurmctldPort=16817
SlurmdPort=16818
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$D/sock/munge.sock
CredType=cred/munge
StateSaveLocation=$D/state
SlurmdSpoolDir=$D/spool
SlurmctldPidFile=$D/slurmctld.pid
SlurmdPidFile=$D/slurmd.pid
SlurmctldLogFile=$D/slurmctld.log
SlurmdLogFile=$D/slurmd.log
MailProg=/bin/true
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ReturnToService=2
MpiDefault=none
NodeName=localhost CPUs=$(nproc) State=UNKNOWN
PartitionName=debug Nodes=localhost Default=YES MaxTime=INFINITE State=UP
CONF
if ! ip -o addr 2>/dev/null | grep -v " lo " | grep -q inet; then
  echo "CommunicationParameters=EnableIPv6" >> "$D/slurm.conf"
fi
export SLURM_CONF="$D/slurm.conf"
slurmctld -c -f "$SLURM_CONF" || skip "slurmctld did not start"
slurmd -N localhost -f "$SLURM_CONF" || skip "slurmd did not start"
idle=0
for _ in $(seq 30); do
  if [ "$(timeout 2 sinfo -h -o %t 2>/dev/null)" = "idle" ]; then
    idle=1
    break
  fi
  sleep 0.5
done
[ "$idle" -eq 1 ] || skip "the one-node cluster did not become idle"
echo "Slurm is up: $(sinfo -h -o '%P %D %t')"

# A small scene; one thread per community, so that a community's model is
# the same in any process.
"$BUILD_DIR/scene_generator" --output_path "$W/scene" --num_clusters 3 \
  --num_images_per_cluster 24 --num_images_per_link 20 --seed 17 \
  > "$W/generate.log" 2>&1
options=(--database_path "$W/scene/database.db"
         --image_path "$W/scene/images" --Mapper.num_threads 1)

"$BUILD_DIR/colmap" community_mapper "${options[@]}" \
  --output_path "$W/sparse-one-go" > "$W/one-go.log" 2>&1

COLMAP="$BUILD_DIR/colmap" "$here/../scripts/slurm_community_mapper.sh" \
  "${options[@]}" --output_path "$W/sparse-slurm"

out="$W/sparse-slurm"
num_communities=$(awk '$1 == "num_communities" { print $2 }' "$out/plan.txt")
[ "$num_communities" -ge 2 ] || { echo "FAIL: $num_communities communities"; exit 1; }
for ((c = 0; c < num_communities; ++c)); do
  [ -f "$out/communities/$c.done" ] || { echo "FAIL: no record of $c"; exit 1; }
  grep -q "SLURM\|community $c" "$out/slurm/community_$c.log" || {
    echo "FAIL: community $c was not run by its array task"; exit 1; }
done

# The merged model against the one-process run's.
compare() {
  "$BUILD_DIR/model_evaluator" --model_path "$1/0" \
    --ground_truth_path "$W/sparse-one-go/0" 2> /dev/null
}
check_same() {
  local evaluation registered expected median extent
  evaluation=$(compare "$1")
  registered=$(awk '$1 == "registered_images" { print $2 }' <<< "$evaluation")
  expected=$(awk '$1 == "ground_truth_images" { print $2 }' <<< "$evaluation")
  median=$(awk '$1 == "max_position_error" { print $2 }' <<< "$evaluation")
  extent=$(awk '$1 == "extent" { print $2 }' <<< "$evaluation")
  echo "$2: $registered of $expected images, max camera distance $median" \
       "(extent $extent)"
  [ "$registered" = "$expected" ] || { echo "FAIL: registered images differ"; exit 1; }
  awk -v e="$median" -v x="$extent" 'BEGIN { exit !(e <= 1e-6 * x) }' || {
    echo "FAIL: the $2 model differs from the one-process model"; exit 1; }
}
check_same "$out" "Slurm"

# A community lost (its node died): the merge refuses and names it; the
# script run again redoes that community only.
lost=$((num_communities - 1))
rm -rf "$out/communities/$lost.done" "$out/communities/$lost" "$out/0"
if sbatch --parsable --wait --output="$W/merge-incomplete.log" \
     --wrap "$BUILD_DIR/colmap community_merger --project_path $out/project.ini" \
     > /dev/null 2>&1; then
  echo "FAIL: the merge ran on an incomplete set of communities"; exit 1
fi
grep -q "have not been reconstructed.*: $lost\. " "$W/merge-incomplete.log" || {
  echo "FAIL: the merge did not name community $lost"
  cat "$W/merge-incomplete.log"; exit 1; }
[ ! -d "$out/0" ] || { echo "FAIL: a model was written"; exit 1; }

COLMAP="$BUILD_DIR/colmap" "$here/../scripts/slurm_community_mapper.sh" \
  "${options[@]}" --output_path "$out"
grep -q "exists and fits" "$out/slurm/partition.log" || {
  echo "FAIL: the partition was not reused"; exit 1; }
for ((c = 0; c < lost; ++c)); do
  grep -q "it is reused" "$out/slurm/community_$c.log" || {
    echo "FAIL: community $c was reconstructed again"; exit 1; }
done
grep -q "Community $lost done" "$out/slurm/community_$lost.log" || {
  echo "FAIL: community $lost was not reconstructed again"; exit 1; }
check_same "$out" "resumed Slurm"
echo "PASSED"
