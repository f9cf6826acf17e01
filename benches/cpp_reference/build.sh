#!/usr/bin/env bash
# Builds the WireLib reference bench (wirelib_bench.cpp) against a WireLib
# source tree kept outside this repository, with WireLib's own compiler flags.
#
#   benches/cpp_reference/build.sh [WIREX_DIR]
#
# WIREX_DIR (argument or environment variable) is the WireX source root, the
# directory holding WireLib/, Eigen/, tinyXML/ and motionPlanning/ (its WireLib/
# subdirectory is accepted too). The objects and the binary go to
# WIRELIB_BENCH_DIR (default /tmp/wirelib-bench); nothing is written into the
# repository. The binaries: $WIRELIB_BENCH_DIR/wirelib_bench (timing, check)
# and $WIRELIB_BENCH_DIR/wirelib_bench_allocations (allocation counts).
#
# Flags: WireLib's CMakeLists.txt sets "-fpermissive -w -std=c++0x -fPIC" and no
# optimisation level (its CMake build has no CMAKE_BUILD_TYPE, that is -O0);
# its release build (Visual Studio) compiles with /O2 (MaxSpeed) and NDEBUG.
# The default optimisation here is the GCC equivalent of that release build,
# WIRELIB_OPT="-O2 -DNDEBUG"; set WIRELIB_OPT to compare others (for example
# "-O3 -DNDEBUG", or add -march=native). A change of WIRELIB_OPT rebuilds all.
set -euo pipefail

root=${1:-${WIREX_DIR:-}}
if [[ -z "$root" ]]; then
    echo "usage: $0 WIREX_DIR (or set WIREX_DIR): the WireX source root" >&2
    exit 2
fi
root=$(cd "$root" && pwd)
[[ $(basename "$root") == WireLib ]] && root=$(dirname "$root")
for d in WireLib Eigen tinyXML motionPlanning; do
    [[ -d "$root/$d" ]] || { echo "$root/$d: not found (need the WireX source root)" >&2; exit 2; }
done

out=${WIRELIB_BENCH_DIR:-/tmp/wirelib-bench}
opt=${WIRELIB_OPT:--O2 -DNDEBUG}
jobs=${WIRELIB_JOBS:-2}
here=$(cd "$(dirname "$0")" && pwd)
cxx=${CXX:-g++}
# WireLib's CMakeLists.txt flags, then the optimisation level.
flags="-fpermissive -w -std=c++0x -fPIC $opt -I$root"
mkdir -p "$out/obj"

# A change of flags or compiler rebuilds everything.
stamp="$cxx $flags"
if [[ ! -f "$out/flags" || "$(cat "$out/flags")" != "$stamp" ]]; then
    rm -f "$out"/obj/*.o
    echo "$stamp" >"$out/flags"
fi

# WireLib's sources the timed calls need (the structure matrix and the force
# distributions, and what they link against), compiled unmodified. levmar.cpp
# is WireLib's own wrapper, which returns -1 without the levmar library: the
# timed calls never reach it.
sources=(
    WireLib/RobotData.cpp WireLib/Algorithm.cpp WireLib/StructureMatrix.cpp
    WireLib/Kinematics.cpp WireLib/Reflection.cpp WireLib/levmar.cpp
    motionPlanning/Utilities.cpp
    tinyXML/tinyxml.cpp tinyXML/tinystr.cpp tinyXML/tinyxmlerror.cpp tinyXML/tinyxmlparser.cpp
)
stale=()
objects=()
for s in "${sources[@]}"; do
    o="$out/obj/$(echo "$s" | tr / _).o"
    objects+=("$o")
    [[ -f "$o" && "$o" -nt "$root/$s" ]] || stale+=("$s")
done
compile() { $cxx $flags -c "$1" -o "$2"; }
export -f compile
export cxx flags
if ((${#stale[@]})); then
    echo "compiling ${#stale[@]} WireLib sources with: $cxx $flags (-j$jobs)" >&2
    for s in "${stale[@]}"; do
        printf '%s\n%s\n' "$root/$s" "$out/obj/$(echo "$s" | tr / _).o"
    done | xargs -d '\n' -n 2 -P "$jobs" bash -c 'compile "$0" "$1"'
fi
echo "compiling wirelib_bench.cpp and linking $out/wirelib_bench{,_allocations}" >&2
$cxx $flags -c "$here/wirelib_bench.cpp" -o "$out/obj/wirelib_bench.o"
$cxx $opt -o "$out/wirelib_bench" "$out/obj/wirelib_bench.o" "${objects[@]}"
# The same harness counting every heap allocation (its timings are not used).
$cxx $flags -DWIRELIB_BENCH_COUNT_ALLOCATIONS -c "$here/wirelib_bench.cpp" -o "$out/obj/wirelib_bench_allocations.o"
$cxx $opt -o "$out/wirelib_bench_allocations" "$out/obj/wirelib_bench_allocations.o" "${objects[@]}"
echo "$out/wirelib_bench"
