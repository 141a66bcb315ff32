// SPDX-License-Identifier: GPL-3.0-or-later
// The fuzz targets in every test run (docs/fuzzing.md, "In the test suite"). The libFuzzer build
// needs clang and instruments every library, which takes longer than CI allows; this driver links
// the same LLVMFuzzerTestOneInput into the normal build (and the ASan/UBSan build) instead. It
// replays the seed corpus, then a fixed number of mutations of it drawn from a fixed seed, so that
// a run is the same on every machine. A crash, an abort or a sanitizer report fails the test. It
// is a smoke run, not coverage-guided: the libFuzzer campaigns stay the way to search.
//
// Usage: fuzz_replay_TARGET [--mutations N] [--seed S] [--max-bytes B] [--ext .EXT]... [--keep FILE] PATH...
//   PATH: files, or folders searched recursively (files ending in one of the --ext, all without).
//   --keep FILE: each input is written to FILE before it runs, so that the one that crashed is there.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);

namespace {

namespace fs = std::filesystem;
using Bytes = std::vector<std::uint8_t>;

struct Options {
  long mutations = 2000;
  std::uint64_t seed = 1;
  std::size_t max_bytes = 65536;
  std::vector<std::string> extensions;
  std::vector<std::string> paths;
  std::string keep;
};

bool wanted(const fs::path& p, const Options& o) {
  if (o.extensions.empty()) return true;
  return std::any_of(o.extensions.begin(), o.extensions.end(),
                     [&](const std::string& e) { return p.extension() == e; });
}

Bytes slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return Bytes(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// Values that break parsers more often than random bytes do (from libFuzzer's own mutators:
// separators, brackets, signs, and numbers at the edges of the types).
const char* const interesting_tokens[] = {
    "0",      "-1",   "1e400", "-1e308", "nan",      "inf", "2147483648", "99999999999999999999",
    "1e-320", ",",    "/",     "(",      ")",        "[",   "]",          "{",
    "}",      "\"",   "'",     "$",      "\n",       "\r",  "\\",         "=",
    ":",      "null", "true",  "ENDFIL", "\xc3\xa9", "\xff"};

// One to four stacked edits of `input`, or a splice with `other`.
Bytes mutate(Bytes input, const Bytes& other, std::mt19937_64& random, std::size_t max_bytes) {
  const auto pick = [&](std::size_t n) { return n == 0 ? std::size_t{0} : static_cast<std::size_t>(random() % n); };
  const int edits = 1 + static_cast<int>(random() % 4);
  for (int k = 0; k < edits; ++k) {
    switch (random() % 7) {
      case 0:  // flip a bit
        if (!input.empty()) input[pick(input.size())] ^= static_cast<std::uint8_t>(1u << (random() % 8));
        break;
      case 1:  // a random byte
        if (!input.empty()) input[pick(input.size())] = static_cast<std::uint8_t>(random());
        break;
      case 2: {  // delete a run
        if (input.empty()) break;
        const std::size_t at = pick(input.size()), n = std::min(input.size() - at, 1 + pick(32));
        input.erase(input.begin() + static_cast<long>(at), input.begin() + static_cast<long>(at + n));
        break;
      }
      case 3: {  // duplicate a run (repetition: deep nesting, long chains)
        if (input.empty()) break;
        const std::size_t at = pick(input.size()), n = std::min(input.size() - at, 1 + pick(64));
        const Bytes run(input.begin() + static_cast<long>(at), input.begin() + static_cast<long>(at + n));
        const int times = 1 + static_cast<int>(random() % 8);
        for (int t = 0; t < times; ++t) input.insert(input.begin() + static_cast<long>(at), run.begin(), run.end());
        break;
      }
      case 4: {  // insert an interesting token
        const std::string token = interesting_tokens[pick(std::size(interesting_tokens))];
        input.insert(input.begin() + static_cast<long>(pick(input.size() + 1)), token.begin(), token.end());
        break;
      }
      case 5: {  // replace a number by an interesting token
        std::vector<std::size_t> digits;
        for (std::size_t i = 0; i < input.size(); ++i)
          if (input[i] >= '0' && input[i] <= '9' && (i == 0 || input[i - 1] < '0' || input[i - 1] > '9'))
            digits.push_back(i);
        if (digits.empty()) break;
        const std::size_t at = digits[pick(digits.size())];
        std::size_t end = at;
        while (end < input.size() && ((input[end] >= '0' && input[end] <= '9') || input[end] == '.')) ++end;
        const std::string token = interesting_tokens[pick(9)];
        input.erase(input.begin() + static_cast<long>(at), input.begin() + static_cast<long>(end));
        input.insert(input.begin() + static_cast<long>(at), token.begin(), token.end());
        break;
      }
      default: {  // splice: this input's head, the other's tail
        const std::size_t head = pick(input.size() + 1), tail = pick(other.size() + 1);
        input.resize(head);
        input.insert(input.end(), other.begin() + static_cast<long>(tail), other.end());
        break;
      }
    }
  }
  if (input.size() > max_bytes) input.resize(max_bytes);
  return input;
}

void run_one(const Bytes& input, const Options& o) {
  if (!o.keep.empty())
    std::ofstream(o.keep, std::ios::binary)
        .write(reinterpret_cast<const char*>(input.data()), static_cast<std::streamsize>(input.size()));
  LLVMFuzzerTestOneInput(input.data(), input.size());
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool has_value = i + 1 < argc;
    if (a == "--mutations" && has_value)
      o.mutations = std::atol(argv[++i]);
    else if (a == "--seed" && has_value)
      o.seed = std::strtoull(argv[++i], nullptr, 10);
    else if (a == "--max-bytes" && has_value)
      o.max_bytes = std::strtoull(argv[++i], nullptr, 10);
    else if (a == "--ext" && has_value)
      o.extensions.emplace_back(argv[++i]);
    else if (a == "--keep" && has_value)
      o.keep = argv[++i];
    else if (a.rfind("--", 0) == 0) {
      std::fprintf(stderr, "unknown option %s\n", a.c_str());
      return 2;
    } else {
      o.paths.push_back(a);
    }
  }
  std::vector<fs::path> files;
  for (const auto& p : o.paths) {
    std::error_code ec;
    if (fs::is_directory(p, ec)) {
      for (const auto& e : fs::recursive_directory_iterator(p, ec))
        if (e.is_regular_file() && wanted(e.path(), o) && e.file_size() <= o.max_bytes) files.push_back(e.path());
    } else if (fs::is_regular_file(p, ec)) {
      files.emplace_back(p);
    }
  }
  std::sort(files.begin(), files.end());  // directory order differs between machines
  if (files.empty()) {
    // A checkout without the shared data (../shared/data) has no seeds for some targets: skipped.
    std::fprintf(stderr, "no seed files under the given paths: skipped\n");
    return 77;
  }
  std::vector<Bytes> seeds;
  for (const auto& f : files) {
    seeds.push_back(slurp(f));
    run_one(seeds.back(), o);
  }
  std::mt19937_64 random(o.seed);
  for (long m = 0; m < o.mutations; ++m) {
    const std::size_t a = static_cast<std::size_t>(random() % seeds.size()),
                      b = static_cast<std::size_t>(random() % seeds.size());
    run_one(mutate(seeds[a], seeds[b], random, o.max_bytes), o);
  }
  std::printf("%zu seeds and %ld mutations (seed %llu) ran without a crash\n", seeds.size(), o.mutations,
              static_cast<unsigned long long>(o.seed));
  return 0;
}
