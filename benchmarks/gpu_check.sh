#!/usr/bin/env bash
# One run on a lent GPU machine (no network there): install the wheels carried in .whl/ (Dr.Jit
# and the few pure-Python needs its image lacks), run every `cuda`-marked test, then the GPU
# benchmarks, writing logs and JSON to $OUT (default /tmp/gpu-check). Each step has its own
# timeout so one slow step cannot eat the others' time.
#
#   bash benchmarks/gpu_check.sh [TEST_TIMEOUT_S] [PYTEST ARGS...]
set -u
out=${OUT:-/tmp/gpu-check}
mkdir -p "$out"
test_timeout=${1:-180}
shift || true
if [ -d .whl ]; then
    python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade \
        --target /tmp/site .whl/*.whl || exit 1
    export PYTHONPATH=$PWD/src:$PWD/tests:/tmp/site
fi
export PYTHONUNBUFFERED=1 PYTHONDONTWRITEBYTECODE=1
py=${PYTHON:-python3}
{
    nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv
    nproc
    $py -c "import drjit as dr, incandescent._jit as j; print('drjit', dr.__version__, 'cuda:', j.cuda_problem(), 'llvm:', j.llvm_problem())"
} > "$out/env.txt" 2>&1
cat "$out/env.txt"

tests=("$@")
[ ${#tests[@]} -eq 0 ] && tests=(-m cuda tests)
timeout "$test_timeout" $py -m pytest -q -p no:cacheprovider -o addopts="-ra" \
    --continue-on-collection-errors "${tests[@]}" > "$out/pytest-cuda.log" 2>&1
echo "pytest rc=$?"; tail -n 25 "$out/pytest-cuda.log"
[ "${GPU_CHECK_TESTS_ONLY:-0}" = 1 ] && exit 0

timeout 60 $py benchmarks/scattering_cost.py "$out/scattering-cost-cuda.json" --backend cuda \
    --resolution 512 --rounds 5 > "$out/scattering.log" 2>&1; echo "scattering rc=$?"
timeout 75 $py benchmarks/fire_cost.py "$out/fire-cost-cuda.json" --backend cuda \
    --sizes 128,256 --steps 5 --frames 2 > "$out/fire.log" 2>&1; echo "fire rc=$?"
timeout 75 $py -c "from incandescent.cli import app; app()" bench --json --size 256 --pixels 512 \
    --repeat 5 --no-reference > "$out/bench-cuda.json" 2> "$out/bench.err"; echo "bench rc=$?"
tail -n 3 "$out"/*.log "$out/bench.err"
