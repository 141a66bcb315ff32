#!/usr/bin/env bash
# SPDX-License-Identifier: GPL-3.0-or-later
# Collects the seed corpora and dictionaries of the fuzz targets (docs/fuzzing.md) into
# BUILD_DIR/fuzz/seeds/<target>/ and BUILD_DIR/fuzz/<target>.dict, from programs/, tests/ and the
# shared data (METRON_SHARED_DATA, default /work/shared/data). Nothing generated is committed.
# Characterisation seeds are produced by `metron characterise` on a few worlds: set METRON to a
# metron executable (default: build/cli/metron of this tree, when built); without one the
# characterisation corpus holds only the hand-written seed below.
# Usage: tests/fuzz/make_corpus.sh BUILD_DIR
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../.." && pwd)"
build="$(cd "${1:?usage: make_corpus.sh BUILD_DIR}" && pwd)"
data="${METRON_SHARED_DATA:-/work/shared/data}"
metron="${METRON:-$root/build/cli/metron}"
out="$build/fuzz/seeds"
rm -rf "$out"
mkdir -p "$out"/{dmis,world,characterisation,expected,points}

# Copies each file under the given roots matching the find expression, named by a hash of its
# path so that equal base names in different folders do not collide.
collect() {  # collect TARGET MAX_BYTES ROOTS... -- FIND-EXPRESSION...
  local target=$1 max=$2; shift 2
  local roots=()
  while [ "$1" != "--" ]; do [ -e "$1" ] && roots+=("$1"); shift; done; shift
  [ ${#roots[@]} -eq 0 ] && return 0
  find "${roots[@]}" -type f -size -"$max"c \( "$@" \) -not -path '*/build*/*' -print0 |
    while IFS= read -r -d '' f; do
      cp "$f" "$out/$target/$(printf '%s' "$f" | sha1sum | cut -c1-12)-$(basename "$f")"
    done
}

collect dmis 65536 "$root/programs" "$root/tests" "$data" -- -iname '*.dmi' -o -iname '*.dms'
collect world 65536 "$root/programs/worlds" "$root/tests" -- -name '*.json'
collect expected 65536 "$root/programs" "$root/tests" -- -name '*.expected'
collect points 65536 "$data" "$root/tests" -- -name '*.ds' -o -name '*.csv'

# Characterisation files as `metron characterise --out` writes them.
if [ -x "$metron" ]; then
  for w in default touch_latched touch_const_time touch_mixed scanned_skip; do
    world=()
    [ "$w" != default ] && world=(--world "$root/programs/worlds/$w.json")
    (cd "$build" && "$metron" characterise "${world[@]}" --out "$out/characterisation/$w.json" >/dev/null 2>&1) || true
  done
  (cd "$build" && "$metron" characterise --fastest --out "$out/characterisation/default_fastest.json" >/dev/null 2>&1) || true
fi
# A minimal seed whatever the binary: the smallest shapes the loader meets.
printf '{}\n' > "$out/characterisation/empty_object.json"

# Dictionaries: DMIS major and minor words found in the seed programs, and the JSON keys of the
# worlds and characterisations, plus JSON punctuation.
{
  cat "$out"/dmis/* | grep -aoE '[A-Z][A-Z0-9_]{1,15}' | sort -u | sed 's/.*/"&"/'
  printf '"/"\n","\n"="\n"\\x0A"\n"$"\n"("\n")"\n"["\n"]"\n".AND."\n".OR."\n".NOT."\n".EQ."\n".LT."\n"\x27"\n"1e400"\n'
} > "$build/fuzz/dmis.dict"
json_dict() {
  cat "$@" 2>/dev/null | grep -aoE '"[A-Za-z_][A-Za-z0-9_]*"' | sort -u | sed 's/"/\\"/g; s/.*/"&"/'
  printf '"{"\n"}"\n"["\n"]"\n":"\n","\n"true"\n"false"\n"null"\n"1e400"\n"-0"\n"/*"\n"*/"\n"//"\n'
}
json_dict "$out"/world/* > "$build/fuzz/world.dict"
json_dict "$out"/characterisation/* > "$build/fuzz/characterisation.dict"

for t in dmis world characterisation expected points; do
  echo "fuzz seeds: $t $(find "$out/$t" -type f | wc -l) files"
done
