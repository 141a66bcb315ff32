#!/usr/bin/env bash
# Runs every libFuzzer target for a short time (default 10 s each) on its seed corpus: programs/,
# the worlds, characterisation files, expected files and the shared point files. Exit status 1
# when a target finds a crash (its reproducer is left in DIR/crashes/).
# Usage: tests/fuzz/run_short.sh BUILD_DIR [SECONDS_PER_TARGET] [WORK_DIR]
# BUILD_DIR is a -DMETRON_FUZZ=ON build (tests/fuzz/CMakeLists.txt). Not part of CI: CI builds with
# g++ only; run it by hand or in a nightly job with clang installed.
set -uo pipefail
build=$(realpath "$1"); seconds=${2:-10}; work=$(realpath -m "${3:-$build/fuzz-work}")
root=$(cd "$(dirname "$0")/../.." && pwd)
shared=${METRON_SHARED_DATA:-$root/../shared/data}
mkdir -p "$work/crashes"
seed() {  # target: its seed corpus folder, filled once
  local dir="$work/seeds/$1"
  [ -d "$dir" ] && { echo "$dir"; return; }
  mkdir -p "$dir"
  case $1 in
    fuzz_dmis) find "$root/programs" "$shared" -name '*.dmi' -o -name '*.dms' -o -name '*.DMI' | head -400 | xargs -I{} cp {} "$dir/" 2>/dev/null ;;
    fuzz_world) cp "$root"/programs/worlds/*.json "$dir/" 2>/dev/null ;;
    fuzz_characterisation) find "$root/programs" "$root/tests" -name '*characteris*.json' -o -name 'touch*.json' | xargs -I{} cp {} "$dir/" 2>/dev/null
                           printf '{"version": 1}' >"$dir/minimal.json" ;;
    fuzz_expected) cp "$root"/programs/regression/*.expected "$dir/" 2>/dev/null ;;
    fuzz_point_file) find "$shared" -name '*.ds' -size -200k | head -50 | xargs -I{} cp {} "$dir/" 2>/dev/null
                     printf '1,2,3\n4,5,6\n' >"$dir/csv.txt" ;;
  esac
  echo "$dir"
}
status=0
for t in fuzz_dmis fuzz_world fuzz_characterisation fuzz_expected fuzz_point_file; do
  exe="$build/tests/fuzz/$t"
  [ -x "$exe" ] || { echo "missing $exe (build with -DMETRON_FUZZ=ON)"; status=1; continue; }
  corpus="$work/corpus/$t"; mkdir -p "$corpus"
  log="$work/$t.log"
  "$exe" "$corpus" "$(seed $t)" -max_total_time="$seconds" -max_len=65536 -rss_limit_mb=2048 -timeout=10 \
    -artifact_prefix="$work/crashes/$t-" -print_final_stats=1 >"$log" 2>&1
  rc=$?
  execs=$(awk '/stat::number_of_executed_units/{print $2}' "$log")
  cov=$(grep -o 'cov: [0-9]*' "$log" | tail -1)
  echo "$t: exit $rc, $execs executions, $cov"
  [ $rc -ne 0 ] && { status=1; grep -m3 -E 'ERROR|SUMMARY' "$log"; }
done
exit $status
