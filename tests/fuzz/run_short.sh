#!/usr/bin/env bash
# SPDX-License-Identifier: GPL-3.0-or-later
# Runs each fuzz target of a METRON_FUZZ build for a few seconds on its seed corpus (docs/fuzzing.md).
# Exits non-zero when a target finds a crash, a leak, a sanitizer report or a timeout; the
# reproducer is left in BUILD_DIR/fuzz/artifacts/<target>/.
# Usage: tests/fuzz/run_short.sh BUILD_DIR [seconds per target, default 10] [targets...]
set -uo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
build="$(cd "${1:?usage: run_short.sh BUILD_DIR [seconds] [targets...]}" && pwd)"
seconds="${2:-10}"
shift; [ $# -gt 0 ] && shift
targets=("$@")
[ ${#targets[@]} -eq 0 ] && targets=(dmis world characterisation expected points)

[ -d "$build/fuzz/seeds" ] || bash "$here/make_corpus.sh" "$build"
failed=()
for t in "${targets[@]}"; do
  exe="$build/tests/fuzz/fuzz_$t"
  if [ ! -x "$exe" ]; then echo "run_short: $exe not built" >&2; failed+=("$t"); continue; fi
  # New inputs go to a working corpus beside the seeds, so that the seeds stay as collected.
  corpus="$build/fuzz/corpus/$t"; artifacts="$build/fuzz/artifacts/$t"
  mkdir -p "$corpus" "$artifacts"
  dict=(); [ -f "$build/fuzz/$t.dict" ] && dict=(-dict="$build/fuzz/$t.dict")
  log="$build/fuzz/$t.log"
  # -timeout: one input taking over 10 s is a hang; -rss_limit_mb: the sanitizers' own overhead
  # fits well inside 2 GB, more is unbounded growth.
  "$exe" "$corpus" "$build/fuzz/seeds/$t" "${dict[@]}" -max_total_time="$seconds" -timeout=10 \
    -rss_limit_mb=2048 -max_len=65536 -print_final_stats=1 -artifact_prefix="$artifacts/" >"$log" 2>&1
  rc=$?
  stats=$(grep -E '^stat::number_of_executed_units|^stat::average_exec_per_sec' "$log" | awk '{print $2}' | paste -sd' ')
  cov=$(grep -E '#[0-9]+.*(cov|DONE)' "$log" | tail -1 | grep -oE 'cov: [0-9]+ ft: [0-9]+')
  echo "fuzz_$t: exit $rc, ${seconds}s, executions/exec-per-s: ${stats:-?}, ${cov:-no coverage line} (log $log)"
  [ $rc -ne 0 ] && failed+=("$t")
done
if [ ${#failed[@]} -gt 0 ]; then
  echo "run_short: findings or errors in: ${failed[*]} (reproducers in $build/fuzz/artifacts/)" >&2
  exit 1
fi
