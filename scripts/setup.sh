#!/usr/bin/env bash
# Installs what the project needs on a fresh machine of this kind (Debian + CPython 3.11).
#   bash scripts/setup.sh        everything: the main job, the test suite, building LIGGGHTS from source
#   bash scripts/setup.sh main   only what the main job (scripts/main.sh) runs: the codes it drives, without
#                                their recommended packages, and the Python packages without the test extras
# Idempotent: once everything is there it only checks (dpkg, and Python modules found without importing them).
# Set HARNESS_SKIP_APT=1 to skip the Debian packages.
set -euo pipefail
cd "$(dirname "$0")/.."
mode="${1:-all}"
case "$mode" in all|main) ;; *) echo "setup.sh: unknown mode '$mode' (all or main)" >&2; exit 2 ;; esac

# the main job: the codes of the system targets (targets/*.json; liggghts-doc holds the LIGGGHTS tutorials
# the target liggghts runs) and mpirun for the LIGGGHTS run on two ranks (testcases/liggghts/settling)
apt_packages=(liggghts liggghts-doc lammps yade openmpi-bin)
if [ "$mode" = all ]; then
    # lammps-examples and the rest of the suite's needs; cmake, g++, ccache, libopenmpi-dev and libvtk9-dev
    # (with the Qt5 development files its CMake package needs) build LIGGGHTS-PUBLIC with VTK from source
    # (targets/liggghts-src.json); linux-perf: harness run --profile (perf record -g); g++ also builds the
    # small C++ code of tests/efficiency; chromium: the dashboard's browser tests; postgresql: the store's tests
    apt_packages+=(lammps-examples chromium make gcc postgresql cmake g++ ccache libopenmpi-dev libvtk9-dev
                   qtbase5-dev libqt5opengl5-dev linux-perf)
fi
if [ "${HARNESS_SKIP_APT:-0}" != 1 ] && command -v apt-get >/dev/null 2>&1; then
    missing=()
    for p in "${apt_packages[@]}"; do
        dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p")
    done
    if [ ${#missing[@]} -gt 0 ]; then
        echo "setup: installing Debian packages: ${missing[*]}"
        SUDO=""; [ "$(id -u)" = 0 ] || SUDO="sudo"
        $SUDO apt-get update -qq
        if [ "$mode" = main ]; then
            # recommended packages (paraview for liggghts, a desktop for yade ...) are not run by the main job:
            # without them the download is 445 MB instead of 655 MB (benchmarks/main_job.py --install)
            DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
        else
            # python3-paraview (recommended through liggghts -> paraview) conflicts with python3-vtk9, which
            # libvtk9-dev depends on: drop it (the project reads VTK with pip's vtk, not ParaView's Python)
            DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${missing[@]}" python3-paraview- >/dev/null
        fi
    fi
fi

# the Python modules each mode needs, looked up without importing them (importing numba, vtk and playwright
# takes seconds)
modules="numba vtk django git junit_xml distributed filelock dj_database_url simpleeval scipy pydantic"
extras=""; marker=.harness/.installed
if [ "$mode" = all ]; then
    modules="$modules pytest playwright xmlschema jsonschema psycopg"; extras="[test]"
else
    marker=.harness/.installed-main
fi
found() {
    python3 -c 'import importlib.util, sys; sys.exit(any(importlib.util.find_spec(m) is None for m in sys.argv[1:]))' $modules 2>/dev/null
}
newest_marker=$marker
# the installed `harness` must be this checkout's: an editable install made in another folder (a checkout since
# moved or removed) leaves a command whose import fails outside this folder; looked up from / so that the current
# folder is not on the path (PYTHONPATH, as benchmarks/main_job.py sets it for a clone, still counts)
here=$(pwd -P)
this_checkout() {
    (cd / && python3 -c 'import importlib.util, os, sys
spec = importlib.util.find_spec("harness")
sys.exit(spec is None or not os.path.realpath(spec.origin).startswith(sys.argv[1] + os.sep))' "$here") 2>/dev/null
}
# everything installed counts for the main job too
[ "$mode" = main ] && [ .harness/.installed -nt "$marker" ] && newest_marker=.harness/.installed
if ! command -v harness >/dev/null 2>&1 || ! command -v dem >/dev/null 2>&1 || ! found || ! this_checkout \
   || [ pyproject.toml -nt "$newest_marker" ]; then
    echo "setup: installing Python packages (pip install -e .$extras)"
    python3 -m pip install -q --disable-pip-version-check -e ".$extras"
    mkdir -p .harness && touch "$marker"
fi
