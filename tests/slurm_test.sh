#!/usr/bin/env bash
# The cluster paths on a real SLURM cluster (slurmctld + two slurmd,
# tests/slurm_cluster.sh): the dataset as a job array of shards and a merge
# that depends on it (scripts/dataset-slurm.sbatch, docs/DATASET.md), and
# data-parallel training as one sbatch job of two nodes whose srun starts a
# rank on each (scripts/train-slurm.sbatch, docs/TRAINING.md). Each must equal
# the same work done on one machine. Skips (77) without slurm-wlm and munge;
# REEFGEN_REQUIRE_SLURM=1 (CI) makes that a failure.
source "$(dirname "$0")/cli_lib.sh"
ROOT=$(cd "$(dirname "$0")/.." && pwd)
source "$ROOT/tests/cli_tiny_args.sh"
# The jobs run from slurmd's spool folder: the binary by its absolute path.
BIN=$(realpath "$BIN")
if ! bash "$ROOT/tests/slurm_cluster.sh" start "$T/cluster"; then
  [ "${REEFGEN_REQUIRE_SLURM:-0}" = 1 ] && { echo "FAIL: no SLURM cluster (REEFGEN_REQUIRE_SLURM=1)"; exit 1; }
  echo "SKIP: no SLURM cluster here"; exit 77
fi
trap 'bash "$ROOT/tests/slurm_cluster.sh" stop "$T/cluster"; rm -rf "$T"' EXIT
source "$T/cluster/env"
export REEFGEN="$BIN"
# A job that does not end in time is cancelled and named, never waited on.
wait_job() {  # wait_job JOBID WHAT
  for _ in $(seq 1200); do
    squeue -h -j "$1" 2>/dev/null | grep -q . || return 0
    sleep 0.2
  done
  scancel "$1"; bad "$2: job $1 still running after 240 s (cancelled)"; return 1
}
# Exit code of a finished job from slurmctld's record ("0:0" when it ran clean).
job_exit() { scontrol show job "$1" 2>/dev/null | sed -n 's/.*ExitCode=\([0-9:]*\).*/\1/p' | head -n1; }

tiny_configs "$T"

# 1. The dataset: three shards as an array, the merge after them.
"$BIN" -q dataset build --config "$T/ds.json" --seed 4 --out "$T/one" --threads 1 >/dev/null || bad "one-machine dataset"
cd "$T"
jid=$(sbatch --parsable --array=0-2 --cpus-per-task=1 -o "$T/shard-%a.log" "$ROOT/scripts/dataset-slurm.sbatch" \
  "$T/ds.json" 4 "$T/slurm")
mid=$(sbatch --parsable --dependency="afterok:$jid" --kill-on-invalid-dep=yes -o "$T/merge.log" --wrap "$BIN -q dataset merge $T/slurm")
wait_job "$mid" "dataset merge" && wait_job "$jid" "dataset shards"
for i in 0 1 2; do
  [ -f "$T/slurm/manifest.shard-$i-of-3.jsonl" ] && ok || bad "shard $i of 3 not written: $(cat "$T/shard-$i.log" 2>/dev/null)"
done
[ "$(job_exit "$mid")" = "0:0" ] && ok || bad "merge job exit $(job_exit "$mid"): $(cat "$T/merge.log")"
# Byte for byte the one-machine build (the shard manifests are the array's own).
if diff -r -x 'manifest.shard-*' "$T/one" "$T/slurm" >"$T/diff" 2>&1; then ok
else bad "the array's dataset differs from the one-machine build: $(head -n 5 "$T/diff")"; fi

# A shard that fails (its config is missing) never lets the merge run:
# slurmctld cancels it (--kill-on-invalid-dep) and nothing is merged.
jid=$(sbatch --parsable --array=0-1 --cpus-per-task=1 -o "$T/bad-%a.log" "$ROOT/scripts/dataset-slurm.sbatch" \
  "$T/missing.json" 4 "$T/bad")
mid=$(sbatch --parsable --dependency="afterok:$jid" --kill-on-invalid-dep=yes -o "$T/bad-merge.log" \
  --wrap "$BIN -q dataset merge $T/bad")
wait_job "$mid" "the merge after a failed shard"
grep -q "missing.json" "$T/bad-0.log" && ok || bad "the failed shard's log does not name its config: $(cat "$T/bad-0.log")"
scontrol show job "$mid" | grep -q "JobState=CANCELLED" && ok || bad "the merge after a failed shard was not cancelled"
[ ! -e "$T/bad/manifest.jsonl" ] && ok || bad "a manifest was merged after a failed shard"

# 2. Training: one job of two nodes, a rank on each, against --nproc 2 here.
port=$("$PY" -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])')
# shellcheck disable=SC2086  # TINY_TRAIN is a list of flags
"$BIN" -q train --config "$T/tr.json" --data "$T/one" $TINY_TRAIN --batch-size 1 --nproc 2 --threads 1 \
  --out "$T/t-local" >/dev/null 2>"$T/err" || bad "train --nproc 2: $(cat "$T/err")"
# shellcheck disable=SC2086
tid=$(CONFIG="$T/tr.json" MASTER_PORT=$port sbatch --parsable --nodes=2 --cpus-per-task=1 -o "$T/train.log" \
  "$ROOT/scripts/train-slurm.sbatch" "$T/slurm" "$T/t-slurm" $TINY_TRAIN --batch-size 1)
wait_job "$tid" "training"
[ "$(job_exit "$tid")" = "0:0" ] && ok || bad "training job exit $(job_exit "$tid"): $(tail -n 5 "$T/train.log")"
# Both ranks joined one job (the run says 2 ranks), and it learned what the
# same two ranks learn on one machine: the same losses at every logged step.
"$PY" - "$T/t-local" "$T/t-slurm" <<'PYEOF' && ok || bad "SLURM training differs from --nproc 2"
import csv, json, sys
a, b = (list(csv.DictReader(open(d + "/log.csv"))) for d in sys.argv[1:])
keys = ["step", "epoch", "G_GAN", "G_L1", "D_real", "D_fake"]
assert len(a) == len(b) > 0, (len(a), len(b))
for ra, rb in zip(a, b):
    for k in keys:
        assert ra[k] == rb[k], (k, ra[k], rb[k])
r = json.load(open(sys.argv[2] + "/run.json"))
assert r["world_size"] == 2 and r["global_batch"] == 2, (r["world_size"], r["global_batch"])
PYEOF
cmp -s "$T/t-local/generator.pt" "$T/t-slurm/generator.pt" && ok || bad "generator.pt of the SLURM job differs from --nproc 2's"
finish
