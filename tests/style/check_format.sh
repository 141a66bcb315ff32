#!/usr/bin/env bash
# SPDX-License-Identifier: GPL-3.0-or-later
# Every C++ source of the repository is formatted by its .clang-format (STYLE.md). Prints the
# files that are not, with `clang-format -i FILE` as the fix. Skipped (exit 77) without git or
# without clang-format 14 (Debian 12's, which .ci/build installs): another version formats
# some constructs differently and would fail a formatted tree.
set -uo pipefail
cd "${1:?usage: check_format.sh SOURCE_DIR}" || exit 2
command -v git >/dev/null && command -v clang-format >/dev/null || exit 77
clang-format --version | grep -q ' version 14\.' || exit 77
git rev-parse --is-inside-work-tree >/dev/null 2>&1 || exit 77
# One clang-format process for every file (a process per file took ten times as long); the files it
# finds unformatted are the ones its diagnostics name ("FILE:LINE:COL: error: code should be ...").
mapfile -t sources < <(git ls-files '*.cpp' '*.hpp' '*.h' | while IFS= read -r f; do [ -f "$f" ] && echo "$f"; done)
unformatted=()
if ! diagnostics=$(clang-format --dry-run -Werror "${sources[@]}" 2>&1 >/dev/null); then
  mapfile -t unformatted < <(printf '%s\n' "$diagnostics" | sed -n 's/^\(.*\):[0-9]*:[0-9]*: error: .*/\1/p' | sort -u)
  [ ${#unformatted[@]} -gt 0 ] || { printf '%s\n' "$diagnostics"; exit 1; }
fi
if [ ${#unformatted[@]} -gt 0 ]; then
  echo "${#unformatted[@]} file(s) not formatted by .clang-format (fix: clang-format -i FILE):"
  printf '  %s\n' "${unformatted[@]}"
  exit 1
fi
echo "all C++ sources formatted by .clang-format"
