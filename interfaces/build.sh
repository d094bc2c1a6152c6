#!/usr/bin/env bash
# Builds the ROS interface packages under interfaces/ with ament_cmake + rosidl from the ROS 2
# PyPI wheels, and installs them into the virtual environment's prefix:
#
#   servicesim_competition  the competition's messages and services
#   tf2_msgs                tf2_msgs/msg/TFMessage, upstream's definition unchanged
#   nav2_msgs               nav2_msgs/action/NavigateToPose and nav2_msgs/srv/ClearEntireCostmap,
#                           upstream's (Kilted) unchanged
#
#   interfaces/build.sh VENV_DIR
#
# Idempotent: a package is rebuilt only when its files changed since it was last installed
# (a stamp per package holds their checksum) or it no longer imports.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
venv=$(cd "${1:?usage: interfaces/build.sh VENV_DIR}" && pwd)
py="$venv/bin/python"
packages="servicesim_competition tf2_msgs nav2_msgs"

checksum() {  # every file of package $1 that goes into the build
  (cd "$here/$1" && find . -type f \( -name CMakeLists.txt -o -name package.xml -o -name '*.msg' \
     -o -name '*.srv' -o -name '*.action' \) | LC_ALL=C sort | xargs cat | sha256sum | cut -d' ' -f1)
}

imports() {  # the Python modules package $1 generates
  local modules=""
  for kind in msg srv action; do
    [ -d "$here/$1/$kind" ] && modules="$modules, $1.$kind"
  done
  echo "${modules#, }"
}

up_to_date() {
  local stamp="$venv/share/$1/.bt_servicesim_build_stamp"
  [ -f "$stamp" ] && [ "$(cat "$stamp")" = "$(checksum "$1")" ] \
    && "$py" -c "import $(imports "$1")" 2>/dev/null
}

stale=""
for package in $packages; do
  if up_to_date "$package"; then echo "interfaces: $package is up to date"; else stale="$stale $package"; fi
done
[ -z "$stale" ] && exit 0
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
export PATH="$venv/bin:$PATH" AMENT_PREFIX_PATH="$venv" CMAKE_PREFIX_PATH="$venv"

build_package() {
  local package=$1 build="$venv/build/$1" started
  started=$(date +%s)
  # a build directory configured from another source (interfaces/ before it held three packages)
  grep -qs "^CMAKE_HOME_DIRECTORY:INTERNAL=$here/$package\$" "$build/CMakeCache.txt" || rm -rf "$build"
  mkdir -p "$build"
  cmake -S "$here/$package" -B "$build" -G "Unix Makefiles" -Wno-dev \
    -DCMAKE_BUILD_TYPE=Release -DCMAKE_INSTALL_PREFIX="$venv" -DCMAKE_PREFIX_PATH="$venv" \
    -DPython3_EXECUTABLE="$py" -DPYTHON_EXECUTABLE="$py" -DBUILD_TESTING=OFF >"$build.log" 2>&1 \
    || { tail -30 "$build.log" >&2; echo "interfaces: $package: cmake configure failed (log: $build.log)" >&2; exit 1; }
  cmake --build "$build" -j "$(nproc)" >>"$build.log" 2>&1 \
    || { tail -30 "$build.log" >&2; echo "interfaces: $package: build failed (log: $build.log)" >&2; exit 1; }
  cmake --install "$build" >>"$build.log" 2>&1 \
    || { tail -30 "$build.log" >&2; echo "interfaces: $package: install failed (log: $build.log)" >&2; exit 1; }
  "$py" -c "import $(imports "$package")" \
    || { echo "interfaces: $package: built, but it does not import" >&2; exit 1; }
  checksum "$package" >"$venv/share/$package/.bt_servicesim_build_stamp"
  echo "interfaces: built $package in $(( $(date +%s) - started )) s"
}

for package in $stale; do
  build_package "$package"
done
