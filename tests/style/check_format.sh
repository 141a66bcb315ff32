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
unformatted=()
while IFS= read -r f; do
  [ -f "$f" ] || continue
  clang-format --dry-run -Werror "$f" >/dev/null 2>&1 || unformatted+=("$f")
done < <(git ls-files '*.cpp' '*.hpp' '*.h')
if [ ${#unformatted[@]} -gt 0 ]; then
  echo "${#unformatted[@]} file(s) not formatted by .clang-format (fix: clang-format -i FILE):"
  printf '  %s\n' "${unformatted[@]}"
  exit 1
fi
echo "all C++ sources formatted by .clang-format"
