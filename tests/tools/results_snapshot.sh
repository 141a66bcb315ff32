#!/usr/bin/env bash
# Runs every regression program and example with the world and seed its .expected file names
# (examples: the default world, seed 1) and copies each run's outputs (results.json, DMIS output
# files, the printed report and the exit status) into DIR. Two snapshots taken before and after
# a change that must not alter behaviour compare with `diff -r` (issue 10: every move keeps the
# results byte-identical; determinism, ARCHITECTURE.md rule 3, makes that checkable).
# Usage: tests/tools/results_snapshot.sh METRON_BINARY DIR
set -uo pipefail
metron=$(realpath "$1"); out=$(realpath -m "$2")
root=$(cd "$(dirname "$0")/../.." && pwd)
rm -rf "$out"; mkdir -p "$out"
run_one() {  # name program world seed
  local name=$1 program=$2 world=$3 seed=$4 dir="$out/$1"
  mkdir -p "$dir/run"
  local args=(run "$program" --seed "$seed" --out "$dir/run")
  [ -n "$world" ] && args+=(--world "$world")
  # the NIST examples call ../../../shared/data/...: a folder a program may read only when given
  # (docs/security.md)
  [ -d "$root/../shared/data" ] && args+=(--include "$(realpath "$root/../shared/data")")
  # example 08 calibrates the wavefront world in programs/worlds (outside programs/examples)
  args+=(--include "$root/programs/worlds")
  (cd "$(dirname "$program")" && "$metron" "${args[@]}" >"$dir/stdout" 2>"$dir/stderr"; echo $? >"$dir/exit")
  # paths differ between checkouts: print them relative to the project
  sed -i "s#$root#<root>#g; s#$dir#<out>#g" "$dir/stdout" "$dir/stderr" "$dir"/run/* 2>/dev/null
}
for expected in "$root"/programs/regression/*.expected; do
  program=${expected%.expected}.dmi
  world=$(awk '$1=="world"{print $2; exit}' "$expected")
  seed=$(awk '$1=="seed"{print $2; exit}' "$expected")
  [ -n "$world" ] && world=$(realpath -m "$(dirname "$expected")/$world")
  run_one "regression_$(basename "${expected%.expected}")" "$program" "$world" "${seed:-1}"
done
for program in "$root"/programs/examples/*.dmi; do
  run_one "example_$(basename "${program%.dmi}")" "$program" "" 1
done
# the NIST parts' programs on the worlds built from their CAD (README.md)
run_one example_03_on_nist_world "$root/programs/examples/03_nist_simple_part.dmi" \
  "$root/programs/worlds/nist_simple_part.json" 1
run_one example_04_on_nist_world "$root/programs/examples/04_nist_dcx_part.dmi" \
  "$root/programs/worlds/nist_dcx_part.json" 1
echo "snapshot of $(ls "$out" | wc -l) runs in $out"
