add_library(metron_warnings INTERFACE)
target_compile_options(metron_warnings INTERFACE -Wall -Wextra -Wpedantic -Wshadow)
if(METRON_WERROR)
  target_compile_options(metron_warnings INTERFACE -Werror)
endif()
if(METRON_SANITIZE)
  add_compile_options(-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined)
  add_link_options(-fsanitize=address,undefined)
endif()

# metron_layer(NAME DEPS...) : one library per layer folder, public headers in include/.
function(metron_layer name)
  file(GLOB_RECURSE sources CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/src/*.cpp)
  add_library(metron_${name} STATIC ${sources})
  add_library(metron::${name} ALIAS metron_${name})
  target_include_directories(metron_${name} PUBLIC ${CMAKE_CURRENT_SOURCE_DIR}/include
                                            PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/src)
  target_link_libraries(metron_${name} PRIVATE metron_warnings PUBLIC ${ARGN})
endfunction()
