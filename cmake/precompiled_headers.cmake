# Precompiled headers: the standard and library headers most of metron's sources include (Eigen,
# fmt, nlohmann-json, the containers) are parsed once per target instead of once per source, which
# a cold build on two cores (.ci/run) feels most. METRON_PCH=OFF builds every source on its own
# includes (what a missing #include would show).
option(METRON_PCH "Precompile the headers most sources include" ON)

# ccache caches compilations that use a precompiled header only with these sloppiness settings
# (ccache manual, "Precompiled headers"); without them it compiles them uncached.
if(METRON_PCH AND CCACHE_PROGRAM)
  set(CMAKE_CXX_COMPILER_LAUNCHER ${CMAKE_COMMAND} -E env
      CCACHE_SLOPPINESS=pch_defines,time_macros,include_file_mtime,include_file_ctime ${CCACHE_PROGRAM})
endif()

set(metron_common_headers
    <algorithm> <array> <cmath> <cstdint> <filesystem> <fstream> <functional> <limits> <map> <memory>
    <numbers> <optional> <set> <sstream> <string> <string_view> <vector>
    <Eigen/Core> <Eigen/Geometry> <fmt/format.h> <nlohmann/json.hpp> <tl/expected.hpp>)

# metron_precompile(TARGET [HEADER...]): the common headers, and HEADER..., precompiled for TARGET.
# The header-only libraries they come from are linked privately: a target that does not use them
# itself (test_regression) still compiles its precompiled header.
function(metron_precompile target)
  if(METRON_PCH)
    target_link_libraries(${target} PRIVATE Eigen3::Eigen nlohmann_json::nlohmann_json tl::expected fmt::fmt)
    target_precompile_headers(${target} PRIVATE ${metron_common_headers} ${ARGN})
  endif()
endfunction()
