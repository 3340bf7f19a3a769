#!/usr/bin/env bash
# Installs everything the project needs on a fresh machine of this kind (Debian + CPython 3.11).
# Idempotent: a second call only checks. Set HARNESS_SKIP_APT=1 to skip the Debian packages.
set -euo pipefail
cd "$(dirname "$0")/.."

# cmake, g++, ccache, libopenmpi-dev and libvtk9-dev (with the Qt5 development files its CMake package
# needs) build LIGGGHTS-PUBLIC with VTK from source (targets/liggghts-src.json);
# linux-perf: harness run --profile (perf record -g); g++ also builds the small C++ code of tests/efficiency
apt_packages=(liggghts liggghts-doc lammps lammps-examples yade openmpi-bin chromium make gcc postgresql
              cmake g++ ccache libopenmpi-dev libvtk9-dev qtbase5-dev libqt5opengl5-dev linux-perf)
if [ "${HARNESS_SKIP_APT:-0}" != 1 ] && command -v apt-get >/dev/null 2>&1; then
    missing=()
    for p in "${apt_packages[@]}"; do
        dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p")
    done
    if [ ${#missing[@]} -gt 0 ]; then
        echo "setup: installing Debian packages: ${missing[*]}"
        SUDO=""; [ "$(id -u)" = 0 ] || SUDO="sudo"
        $SUDO apt-get update -qq
        # python3-paraview (recommended through liggghts -> paraview) conflicts with python3-vtk9, which
        # libvtk9-dev depends on: drop it (the project reads VTK with pip's vtk, not ParaView's Python)
        DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${missing[@]}" python3-paraview- >/dev/null
    fi
fi

if ! command -v harness >/dev/null 2>&1 || ! command -v dem >/dev/null 2>&1 \
   || ! python3 -c "import numba, vtk, django, git, junit_xml, pytest, playwright, distributed, filelock, xmlschema, psycopg, dj_database_url, simpleeval, scipy" 2>/dev/null \
   || [ pyproject.toml -nt .harness/.installed ]; then
    echo "setup: installing Python packages (pip install -e .[test])"
    python3 -m pip install -q --disable-pip-version-check -e ".[test]"
    mkdir -p .harness && touch .harness/.installed
fi
