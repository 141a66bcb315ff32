# SPDX-License-Identifier: GPL-3.0-or-later
# METRON_FUZZ (docs/fuzzing.md): libFuzzer targets under tests/fuzz. Needs clang
# (CC=clang-14 CXX=clang++-14); every project library is then compiled with coverage
# instrumentation and ASan/UBSan, and only the fuzz targets link the libFuzzer driver.
if(METRON_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    message(FATAL_ERROR "METRON_FUZZ needs clang (libFuzzer): configure with CC=clang-14 CXX=clang++-14")
  endif()
  if(METRON_SANITIZE)
    message(FATAL_ERROR "METRON_FUZZ already builds with ASan and UBSan: leave METRON_SANITIZE off")
  endif()
  # -fno-sanitize-recover: a UBSan finding stops the run like a crash, so libFuzzer keeps the input.
  add_compile_options(-fsanitize=fuzzer-no-link,address,undefined -fno-sanitize-recover=undefined
                      -fno-omit-frame-pointer -g)
  add_link_options(-fsanitize=address,undefined)
endif()
