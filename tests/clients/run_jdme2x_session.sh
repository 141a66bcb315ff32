#!/usr/bin/env bash
# Drive `metron serve` with libjdme2x (github.com/aschet/libjdme2x, BSL-1.0), an I++ DME 2.5
# client library in C++ that metron's authors did not write: builds the library's sources (Boost
# headers and Asio from Debian's libboost-dev) with tests/clients/jdme2x_session.cpp, starts a
# server on a free port and runs the session. Not part of ctest: the library is not vendored.
# Usage: bash tests/clients/run_jdme2x_session.sh <libjdme2x source dir> [metron binary] [world]
# Exit status: the number of steps that did not answer as expected (docs/ipp-dme.md).
set -euo pipefail
src=${1:?give the libjdme2x source directory}
here=$(cd "$(dirname "$0")" && pwd)
metron=${2:-$here/../../build/cli/metron}
world=${3:-}
work=$(mktemp -d)
trap 'kill "${server:-}" 2>/dev/null || true; rm -rf "$work"' EXIT
objects=()
for f in $(find "$src/src" -name '*.cpp' ! -path '*/Server/*'); do
  o="$work/$(echo "${f#$src/}" | tr '/' '_').o"
  g++ -std=c++17 -O1 -I"$src/include" -I"$src/src" -c "$f" -o "$o"
  objects+=("$o")
done
g++ -std=c++17 -O1 -I"$src/include" "$here/jdme2x_session.cpp" "${objects[@]}" -o "$work/jdme2x_session" -lpthread
"$metron" serve --port 0 --once ${world:+--world "$world"} > "$work/serve.out" 2>&1 &
server=$!
for _ in $(seq 50); do grep -q "I++ DME on" "$work/serve.out" && break; sleep 0.1; done
port=$(sed -n 's/.*I++ DME on [^:]*:\([0-9]*\).*/\1/p' "$work/serve.out" | head -1)
"$work/jdme2x_session" 127.0.0.1 "$port"
