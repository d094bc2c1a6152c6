#!/usr/bin/env bash
# Builds the servicesim_competition interface package with ament_cmake + rosidl from the ROS 2
# PyPI wheels, and installs it into the virtual environment's prefix.
#
#   interfaces/build.sh VENV_DIR
#
# Idempotent: it does nothing when the installed package is newer than every interface file.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
venv=$(cd "${1:?usage: interfaces/build.sh VENV_DIR}" && pwd)
py="$venv/bin/python"
stamp="$venv/share/servicesim_competition/.bt_servicesim_build_stamp"
sources=$(cd "$here" && cat CMakeLists.txt package.xml msg/*.msg srv/*.srv action/*.action | sha256sum | cut -d' ' -f1)

if [ -f "$stamp" ] && [ "$(cat "$stamp")" = "$sources" ] \
   && "$py" -c "import servicesim_competition.action" 2>/dev/null; then
  echo "interfaces: servicesim_competition is up to date"
  exit 0
fi
command -v cmake >/dev/null || { echo "interfaces: cmake is missing (apt-get install cmake)" >&2; exit 1; }
command -v c++ >/dev/null || { echo "interfaces: a C++ compiler is missing (apt-get install g++)" >&2; exit 1; }

# The wheels' exported CMake files name the include dirs of the interpreter they were built with
# (/opt/python/cp311-cp311/...); point them at this interpreter and this venv's numpy.
py_include=$("$py" -c "import sysconfig; print(sysconfig.get_paths()['include'])")
np_include=$("$py" -c "import numpy; print(numpy.get_include())")
{ grep -l "/opt/python/cp311-cp311" "$venv"/share/*/cmake/*.cmake 2>/dev/null || true; } | while read -r f; do
  sed -i -e "s#/opt/python/cp311-cp311/include/python3.11#$py_include#g" \
         -e "s#/opt/python/cp311-cp311/lib/python3.11/site-packages/numpy/_core/include#$np_include#g" "$f"
done

build="$venv/build/servicesim_competition"
mkdir -p "$build"
started=$(date +%s)
export PATH="$venv/bin:$PATH" AMENT_PREFIX_PATH="$venv" CMAKE_PREFIX_PATH="$venv"
cmake -S "$here" -B "$build" -G "Unix Makefiles" -Wno-dev \
  -DCMAKE_BUILD_TYPE=Release -DCMAKE_INSTALL_PREFIX="$venv" -DCMAKE_PREFIX_PATH="$venv" \
  -DPython3_EXECUTABLE="$py" -DPYTHON_EXECUTABLE="$py" -DBUILD_TESTING=OFF >"$build.log" 2>&1 \
  || { tail -30 "$build.log" >&2; echo "interfaces: cmake configure failed (log: $build.log)" >&2; exit 1; }
cmake --build "$build" -j "$(nproc)" >>"$build.log" 2>&1 \
  || { tail -30 "$build.log" >&2; echo "interfaces: build failed (log: $build.log)" >&2; exit 1; }
cmake --install "$build" >>"$build.log" 2>&1 \
  || { tail -30 "$build.log" >&2; echo "interfaces: install failed (log: $build.log)" >&2; exit 1; }
"$py" -c "import servicesim_competition.msg, servicesim_competition.srv, servicesim_competition.action" \
  || { echo "interfaces: built, but servicesim_competition does not import" >&2; exit 1; }
echo "$sources" >"$stamp"
echo "interfaces: built servicesim_competition in $(( $(date +%s) - started )) s"
