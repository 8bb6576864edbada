#!/usr/bin/env bash
# moonbot's one set-up path. Every command first makes sure the machine is ready — Debian packages
# (apt-get, with sudo when not root), a .venv with the package and its test extras — and skips
# whatever is already done, so a second run costs a second or two.
#
#   ./dev.sh setup     install what is missing, build the core into .venv
#   ./dev.sh demo      setup, then `moonbot render-one` on the embedded default config
#   ./dev.sh test      setup, then lint, C++ tests (ctest: release, then ASan+UBSan), pytest,
#                      `moonbot generate configs/smoke.yaml` into build/smoke, and validate,
#                      baseline and eval on that dataset; every stage time-bounded (below)
#                      (options go to pytest: ./dev.sh test -m unit). Every test is marked
#                      (pyproject.toml; `.venv/bin/python -m pytest -m unit` runs one kind alone):
#                        unit         in-process and quick: a function, a render, a command
#                        integration  generate or merge over real workers (a Dask cluster), SLURM
#                        slow         besides: the minutes-long sweeps on a real cluster
#   ./dev.sh lint      setup, then ruff's lint, and the format checks: import order, `ruff format`,
#                      clang-format over cpp/ (pyproject.toml and .clang-format configure them)
#   ./dev.sh format    setup, then sort imports and format the Python and C++ code in place
#   ./dev.sh bench     setup, then the benchmarks in bench/ (results in bench/results/);
#                      ./dev.sh bench terrain runs bench/bench_terrain.py alone
#   ./dev.sh throughput  setup, then `moonbot bench throughput` (options passed on; ~6 min on 2 cores)
set -euo pipefail
cd "$(dirname "$0")"

# pkg-config finds OpenImageIO (cpp/CMakeLists.txt says why not its CMake config). What these bring
# onto a bare Debian 12: bench/results/install-weight-debian12.md.
APT_PACKAGES=(build-essential pkg-config python3 python3-dev python3-venv
              libembree-dev libopenimageio-dev libglm-dev
              libgeographiclib-dev libtbb-dev zlib1g-dev)
VENV=.venv
# What ruff lints and formats: the package, its tests, the benchmarks, the cluster recipes, the docs' script.
PYTHON_SOURCES=(moonbot tests bench cluster docs)
# The tests that trace rays, re-run under every Embree ISA the CPU offers (`./dev.sh test`).
ISA_TESTS=(tests/test_render_geometry.py tests/test_lighting.py tests/test_watertight.py tests/test_amodal.py
           tests/test_embree_isa.py)
PY="$VENV/bin/python"
# What the first compile of the core (./dev.sh setup) and of each C++ test build (./dev.sh test) takes
# on a 2-core machine, minutes, said before they start (bench/results/README.md "Set-up time" has the timings).
FIRST_BUILD_MIN=4
FIRST_TEST_BUILD_MIN=2
# Bounds on `./dev.sh test`, so that a hang fails CI with a stack instead of eating its 90 minutes:
# ctest's limit for each test; the whole pytest run (each test has its own 300 s limit, set in
# pyproject.toml); each re-run of the ray-tracing tests under another Embree ISA; each moonbot
# command on the smoke sweep. At a bound `timeout` sends SIGABRT,
# on which Python's faulthandler prints every thread's stack, and SIGKILL 30 s later.
CTEST_TEST_LIMIT_S=300
PYTEST_LIMIT_S=3600
ISA_TESTS_LIMIT_S=900
SMOKE_STEP_LIMIT_S=600

# Every line says how long dev.sh has been running (m:ss), so no stage is a silent stretch.
log() { printf '\033[1m[dev %d:%02d]\033[0m %s\n' $((SECONDS / 60)) $((SECONDS % 60)) "$*"; }
# took START: "m:ss" since START (a value of $SECONDS).
took() { local s=$((SECONDS - $1)); printf '%d:%02d' $((s / 60)) $((s % 60)); }

# bounded SECONDS COMMAND...: runs COMMAND (and its children: timeout signals its process group),
# ending it with every Python thread's stack after SECONDS.
bounded() {
    local limit=$1 status=0
    shift
    PYTHONFAULTHANDLER=1 timeout --signal=ABRT --kill-after=30 "$limit" "$@" || status=$?
    if [ "$status" -eq 124 ]; then log "timed out after $limit s: $*"; fi
    return "$status"
}

apt_deps() {
    local missing=()
    for p in "${APT_PACKAGES[@]}"; do
        dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "ok installed" || missing+=("$p")
    done
    [ ${#missing[@]} -eq 0 ] && return
    local sudo=""
    [ "$(id -u)" -eq 0 ] || sudo=sudo
    local start=$SECONDS
    log "installing Debian packages (about 270 MB to download on a bare Debian 12): ${missing[*]}"
    $sudo apt-get update -qq
    # `env` after sudo: sudo's env_reset would drop a DEBIAN_FRONTEND set in front of it.
    $sudo env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}"
    log "Debian packages installed in $(took "$start")"
}

# A fingerprint of everything that changes the compiled module, and of the *names* of the Python
# files: their contents are live in the editable install, but scikit-build-core's editable
# finder maps only the modules that existed when it was installed, so a new module re-installs.
build_fingerprint() {
    { cat pyproject.toml CMakeLists.txt; find cpp -type f | LC_ALL=C sort | xargs cat
      find moonbot -name '*.py' | LC_ALL=C sort; } | sha256sum | cut -d' ' -f1
}

python_env() {
    if [ ! -x "$PY" ]; then
        log "creating $VENV"
        python3 -m venv "$VENV"
    fi
    local stamp="$VENV/.moonbot-build" want
    want=$(build_fingerprint)
    if [ "$(cat "$stamp" 2>/dev/null)" != "$want" ]; then
        local start=$SECONDS
        log "installing the build tools into $VENV (pip, scikit-build-core, pybind11, cmake, ninja)"
        "$PY" -m pip install -q --upgrade pip
        "$PY" -m pip install -q "scikit-build-core>=0.10" "pybind11==3.1.0" "cmake>=3.25" ninja  # pinned: the generated _core.pyi (tests/test_core_stub.py) follows its version
        if compgen -G "build/cp*-*" >/dev/null; then  # scikit-build-core's build/{wheel_tag}
            log "building moonbot into $VENV: compiling what changed in cpp/ (incremental in build/)"
        else
            log "building moonbot into $VENV: compiling the C++ core, the first time about $FIRST_BUILD_MIN min" \
                "on 2 cores, then its Python dependencies (about 700 MB in $VENV)"
        fi
        "$PY" -m pip install -q --no-build-isolation -e ".[test]"
        echo "$want" > "$stamp"
        log "moonbot built and installed in $(took "$start")"
    fi
}

setup() { apt_deps; python_env; }

# The README's examples call `moonbot` as a command: say how this shell gets it.
path_hint() {
    log "moonbot is $VENV/bin/moonbot: \`source $VENV/bin/activate\` puts it on this shell's PATH," \
        "as the README's examples assume"
}

cpp_tests() {
    local cmake="$VENV/bin/cmake" ctest="$VENV/bin/ctest"
    # cmake and ninja come from the venv's pip packages; a fresh machine has neither on its PATH.
    local PATH="$PWD/$VENV/bin:$PATH"
    for variant in release asan; do
        local flags=(-DCMAKE_BUILD_TYPE=Release)
        [ "$variant" = asan ] && flags=(-DCMAKE_BUILD_TYPE=Debug -DMOONBOT_SANITIZE=ON)
        local start=$SECONDS
        if [ -f "build/ctest-$variant/build.ninja" ]; then
            log "C++ tests ($variant): compiling what changed (build/ctest-$variant)"
        else
            log "C++ tests ($variant): compiling the core and its tests into build/ctest-$variant," \
                "the first time about $FIRST_TEST_BUILD_MIN min on 2 cores"
        fi
        "$cmake" -S . -B "build/ctest-$variant" -G Ninja -DMOONBOT_BUILD_PYTHON=OFF "${flags[@]}" >/dev/null
        "$cmake" --build "build/ctest-$variant"
        log "C++ tests ($variant): compiled in $(took "$start"); running them"
        "$ctest" --test-dir "build/ctest-$variant" --output-on-failure --timeout "$CTEST_TEST_LIMIT_S"
    done
}

cpp_sources() { find cpp \( -name '*.h' -o -name '*.cpp' \) | LC_ALL=C sort; }

# Lint (it must pass), then the formatting checks (`./dev.sh format` fixes those); all run, any failure fails.
lint() {
    local status=0
    log "ruff check (lint)"
    "$VENV/bin/ruff" check "${PYTHON_SOURCES[@]}" || status=1
    log "formatting: import order, ruff format --check, clang-format --dry-run over cpp/"
    "$VENV/bin/ruff" check --select I --output-format concise "${PYTHON_SOURCES[@]}" || status=1
    "$VENV/bin/ruff" format --check --output-format concise "${PYTHON_SOURCES[@]}" || status=1
    cpp_sources | xargs "$VENV/bin/clang-format" --dry-run --Werror || status=1
    [ "$status" -eq 0 ] && log "lint and formatting clean"
    return "$status"
}

case "${1:-}" in
    setup) setup; path_hint ;;
    demo)
        setup
        log "moonbot render-one (embedded default config)"
        "$VENV/bin/moonbot" render-one --out out/demo "${@:2}"
        log "pictures: out/demo/view_000/rgb.png, depth_preview.png, mask.png"
        path_hint
        ;;
    lint) setup; lint ;;
    format)
        setup
        "$VENV/bin/ruff" check --select I --fix "${PYTHON_SOURCES[@]}"
        "$VENV/bin/ruff" format "${PYTHON_SOURCES[@]}"
        cpp_sources | xargs "$VENV/bin/clang-format" -i
        ;;
    test)
        setup
        lint
        cpp_tests
        log "Python tests"
        bounded "$PYTEST_LIMIT_S" "$PY" -m pytest "${@:2}"
        # The tests above ran the ISA `auto` picks here; the ray-tracing tests again under every
        # other one this CPU offers, so an ISA-specific failure shows on any machine that has it.
        for isa in $("$PY" -c 'from moonbot import _core as c; print(*(i for i in c.embree_isas() if i != c.resolve_embree_isa()))'); do
            log "ray-tracing tests with MOONBOT_EMBREE_ISA=$isa"
            MOONBOT_EMBREE_ISA=$isa bounded "$ISA_TESTS_LIMIT_S" "$PY" -m pytest -q "${ISA_TESTS[@]}"
        done
        log "moonbot generate configs/smoke.yaml (the whole pipeline, on a local Dask cluster)"
        rm -rf build/smoke
        bounded "$SMOKE_STEP_LIMIT_S" "$VENV/bin/moonbot" generate configs/smoke.yaml --out build/smoke
        log "moonbot validate, baseline and eval on the smoke dataset (its test split)"
        bounded "$SMOKE_STEP_LIMIT_S" "$VENV/bin/moonbot" validate build/smoke/dataset
        bounded "$SMOKE_STEP_LIMIT_S" "$VENV/bin/moonbot" baseline build/smoke/dataset
        bounded "$SMOKE_STEP_LIMIT_S" "$VENV/bin/moonbot" eval build/smoke/dataset \
            --results build/smoke/dataset/eval/baseline_test.csv
        log "every test stage passed"
        ;;
    bench)  # ./dev.sh bench [render_one|settle|terrain|tonemap_exr ...]: those benchmarks, or all of them
        setup
        for name in "${@:2}"; do [ -f "bench/bench_$name.py" ] || { log "no bench/bench_$name.py"; exit 2; }; done
        for name in "${@:2}"; do "$PY" "bench/bench_$name.py"; done
        [ $# -gt 1 ] || for name in render_one settle terrain tonemap_exr accuracy dust medium generate render_scenes embree_isa; do "$PY" "bench/bench_$name.py"; done
        ;;
    throughput)  # ./dev.sh throughput [--workers 1,2] [--levels ...]: moonbot bench throughput
        setup
        "$VENV/bin/moonbot" bench throughput "${@:2}"
        ;;
    *)
        sed -n '2,21p' "$0" | sed 's/^# \{0,1\}//'
        exit 2
        ;;
esac
