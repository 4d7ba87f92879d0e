#!/usr/bin/env bash
# Issue 30 on a lent GPU machine: the rig and gradient tests on cuda, then the 64³ reconstruction
# sweep (12 views of 128², and 4 views, and 1 % noise) side by side, each case stopped after
# BUDGET_S and measured at its last finished round. Results in $OUT (default /tmp/gpu-recon).
#
#   BUDGET_S=270 bash benchmarks/gpu_reconstruction.sh
set -u
out=${OUT:-/tmp/gpu-recon}
mkdir -p "$out"
if [ -d .whl ] && [ "${NO_WHL:-0}" != 1 ]; then
    python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade \
        --target /tmp/site .whl/*.whl || exit 1
    export PYTHONPATH=$PWD/src:$PWD/tests:$PWD/benchmarks:/tmp/site
fi
export PYTHONUNBUFFERED=1 PYTHONDONTWRITEBYTECODE=1
py=${PYTHON:-python3}
timeout 120 $py -m pytest -q -p no:cacheprovider -o addopts="-ra" -m cuda \
    tests/camera/test_camera_rig.py tests/inverse ${EXTRA_TESTS:-} > "$out/pytest-cuda.log" 2>&1
echo "pytest rc=$?"; tail -n 8 "$out/pytest-cuda.log"
long='"round": 100, "memory": 50, "tv_eps_K": 100.0, "tv_weight": 0.003'
settings="[{$long, \"iterations\": 300},
 {$long, \"iterations\": 1000, \"levels\": 2},
 {\"round\": 100, \"memory\": 50, \"dark_fraction\": 0.05, \"iterations\": 1000, \"levels\": 2},
 {$long, \"iterations\": 300, \"views\": 4},
 {$long, \"iterations\": 300, \"noise\": 0.01},
 {$long, \"iterations\": 1000, \"levels\": 2, \"tv_eps_K\": 30.0}]"
timeout $(( ${BUDGET_S:-270} + 150 )) $py benchmarks/reconstruction_sweep.py --backend "${BACKEND:-cuda}" \
    --jobs 6 --budget-s "${BUDGET_S:-270}" --settings "$settings" --size "${SIZE:-64}" \
    --pixels "${PIXELS:-128}" \
    --out "$out/reconstruction-sweep-cuda.json" > "$out/sweep.log" 2>&1
echo "sweep rc=$?"; cat "$out/sweep.log"
