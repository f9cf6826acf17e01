#!/usr/bin/env bash
# Our solver library against the C++ reference, WireLib, on IPAnema 1, in
# one interleaved run (see README.md in this directory).
#
#   benches/cpp_reference/compare.sh [WIREX_DIR]
#
# WIREX_DIR (argument or environment variable): the WireX source root (with
# WireLib/, Eigen/, tinyXML/, motionPlanning/), outside this repository.
# ALTERNATIONS (default 3): how many times our bench and WireLib's harness
# run, alternately (ours, WireLib, ours, WireLib, ...). WIRELIB_BENCH_DIR
# (default /tmp/wirelib-bench): WireLib's build and this run's files.
# CARGO_BUILD_JOBS defaults to 2, WIRELIB_JOBS (build.sh) to 2.
#
# Steps: build WireLib's harness (build.sh) and our bench (cargo, bench
# profile); write the poses file (our bench with CDPR_CPP_REFERENCE_POSES);
# print WireLib's results beside ours (the correctness check) and WireLib's
# heap allocations per call; then the alternations, and one table: per
# alternation our median ns, WireLib's and the ratio WireLib / ours, and the
# median of the alternations' ratios.
set -euo pipefail

here=$(cd "$(dirname "$0")" && pwd)
repo=$(cd "$here/../.." && pwd)
wirex=${1:-${WIREX_DIR:-}}
[[ -n "$wirex" ]] || { echo "usage: $0 WIREX_DIR (or set WIREX_DIR)" >&2; exit 2; }
alternations=${ALTERNATIONS:-3}
out=${WIRELIB_BENCH_DIR:-/tmp/wirelib-bench}
export WIRELIB_BENCH_DIR=$out

echo "== building WireLib's harness" >&2
cpp=$("$here/build.sh" "$wirex")
echo "== building our bench" >&2
ours=$(cd "$repo" && CARGO_BUILD_JOBS=${CARGO_BUILD_JOBS:-2} cargo bench --bench cpp_reference --no-run 2>&1 |
    tee /dev/stderr | sed -n 's/.*Executable .*(\(.*\)).*/\1/p' | tail -1)
[[ -n "$ours" ]] || { echo "cannot find our bench's executable" >&2; exit 1; }
[[ "$ours" = /* ]] || ours="$repo/$ours"

poses="$out/poses.txt"
CDPR_CPP_REFERENCE_POSES="$poses" CDPR_CPP_REFERENCE_DUMP_ONLY=1 "$ours"

echo
echo "== correctness: WireLib's results beside ours ($poses)"
"$cpp" "$poses" check
echo
echo "== WireLib's heap allocations per call (mean over the poses)"
"${cpp}_allocations" "$poses" allocations

for a in $(seq 1 "$alternations"); do
    echo "== alternation $a of $alternations: ours" >&2
    "$ours" >"$out/ours-$a.tsv"
    echo "== alternation $a of $alternations: WireLib" >&2
    "$cpp" "$poses" >"$out/wirelib-$a.tsv"
done

echo
echo "== median ns per call over 1000 poses x 20 rounds; WireLib built with: $(cat "$out/flags")"
python3 - "$out" "$alternations" <<'PY'
import statistics, sys

out, n = sys.argv[1], int(sys.argv[2])

def rows(path):
    with open(path) as f:
        return {name: float(ns) for name, ns in (l.rstrip("\n").split("\t") for l in f if "\t" in l)}

ours = [rows(f"{out}/ours-{a}.tsv") for a in range(1, n + 1)]
theirs = [rows(f"{out}/wirelib-{a}.tsv") for a in range(1, n + 1)]
# (row, our call, WireLib's call)
pairs = [
    ("timer (empty call: two clock reads, in every row)", "timer (empty call)", "timer (empty call)"),
    ("kinematics (W and f / A^T incl. R)", "kinematics", "kinematics"),
    ("kinematics (WireLib: A^T, R given)", "kinematics", "kinematics (given R)"),
    ("closed-form (WireLib: llt, its default)", "closed-form", "closed-form (llt, default)"),
    ("closed-form (WireLib: lu)", "closed-form", "closed-form (lu)"),
    ("closed-form (WireLib: householderQr, another answer)", "closed-form", "closed-form (householderQr)"),
    ("improved-closed-form", "improved-closed-form", "improved-closed-form"),
    ("puncture (WireLib's puncture)", "puncture", "puncture"),
    ("improved-puncture (WireLib's puncture)", "improved-puncture", "puncture"),
    ("barycenter (ours warm)", "barycenter (warm)", "barycenter"),
    ("barycenter (ours cold)", "barycenter (cold)", "barycenter"),
]
head = "| call |" + "".join(f" ours {a} | WireLib {a} | ratio {a} |" for a in range(1, n + 1))
print(head + " median ratio |")
print("| --- |" + " ---: |" * (3 * n + 1))
for label, o, t in pairs:
    cells, ratios = [], []
    for a in range(n):
        x, y = ours[a].get(o), theirs[a].get(t)
        r = y / x if x and y else None
        if r is not None:
            ratios.append(r)
        cells += [f"{x:.0f}" if x else "-", f"{y:.0f}" if y else "-", f"{r:.2f}" if r else "-"]
    med = f"{statistics.median(ratios):.2f}" if ratios else "-"
    print(f"| {label} | " + " | ".join(cells) + f" | {med} |")
PY
