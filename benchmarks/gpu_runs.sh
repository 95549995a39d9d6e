#!/usr/bin/env bash
# pcgeom on a CUDA machine, as a user runs it: the CUDA tests, then `pcgeom param --device cuda`
# on the built-in example (3 seeds) and the shared real surfaces, each CLI run timed from the
# outside (start-up, reading, training, evaluation and writing included).
#
# Usage: bash benchmarks/gpu_runs.sh DATA_DIR OUT_DIR
#   DATA_DIR holds face_3holes_small_choi.ply and face_human_choi.ply (../shared/data here).
# Writes OUT_DIR/gpu_runs.jsonl (one `--json` summary per run, plus "wall_s" and "label") and
# OUT_DIR/env.txt. Python packages the machine lacks (libigl, trimesh) must be importable.
set -uo pipefail
data=$1
out=$2
mkdir -p "$out"
{
    nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader
    python3 -c "import torch, igl, trimesh, pcgeom; print('python', __import__('sys').version.split()[0], 'torch', torch.__version__, 'cuda', torch.cuda.is_available(), 'pcgeom', pcgeom.__version__)"
} > "$out/env.txt" 2>&1
cat "$out/env.txt"

python3 -m pytest -q -p no:cacheprovider tests -k cuda 2>&1 | tail -5

run() {  # label, then pcgeom param arguments
    local label=$1
    shift
    local t0 t1 line
    t0=$(date +%s.%N)
    line=$(python3 -m pcgeom param "$@" --device cuda --quiet --json --out "$out/$label.npz")
    local rc=$?
    t1=$(date +%s.%N)
    if [ $rc -ne 0 ]; then
        echo "{\"label\": \"$label\", \"rc\": $rc}" >> "$out/gpu_runs.jsonl"
        echo "$label: failed ($rc)"
        return
    fi
    python3 - "$label" "$t0" "$t1" "$line" >> "$out/gpu_runs.jsonl" <<'PY'
import json, sys
label, t0, t1, line = sys.argv[1:]
record = json.loads(line)
record.update(label=label, wall_s=float(t1) - float(t0))
print(json.dumps(record))
PY
    tail -n 1 "$out/gpu_runs.jsonl" | python3 -c "import json,sys; r=json.load(sys.stdin); e=r['evaluation'] or {}; print(r['label'], f\"{r['wall_s']:.1f} s wall, {r['seconds']:.1f} s training\", e.get('mean_abs_angle_rad'), e.get('flipped'), r['domain_hausdorff'])"
}

for seed in 0 1 2; do
    run "peaks3_fast_s$seed" --example peaks3 --seed "$seed"
done
run face3holes_fast_s0 "$data/face_3holes_small_choi.ply"
run facehuman_fast_s0 "$data/face_human_choi.ply"
for seed in 0 1 2; do
    run "peaks3_disk_s$seed" --example peaks3 --domain disk --seed "$seed"
    run "facehuman_disk_s$seed" "$data/face_human_choi.ply" --domain disk --seed "$seed"
done
rm -f "$out"/*.npz
