# Helpers that give every GLAM target the same include root, warnings and sanitizers.
include(GoogleTest)

# Include paths are rooted at the project: #include "engine/core/sim3.h".

set(GLAM_WARNINGS -Wall -Wextra -Wpedantic -Wshadow=local -Wnon-virtual-dtor)
if(GLAM_WERROR)
  list(APPEND GLAM_WARNINGS -Werror)
endif()

if(GLAM_SANITIZE)
  add_compile_options(-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined)
  add_link_options(-fsanitize=address,undefined)
  # GCC 12 with the sanitizers reports maybe-uninitialized inside libstdc++'s std::function
  # (std::regex's compiler): a false positive that -Werror would turn into a failed build.
  list(APPEND GLAM_WARNINGS -Wno-maybe-uninitialized)
endif()

function(glam_target_defaults target)
  target_compile_options(${target} PRIVATE ${GLAM_WARNINGS})
  target_include_directories(${target} PUBLIC "${PROJECT_SOURCE_DIR}")
endfunction()

# glam_add_library(name SOURCES a.cc b.cc DEPS dep1 dep2)
function(glam_add_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  add_library(${name} STATIC ${ARG_SOURCES})
  glam_target_defaults(${name})
  target_link_libraries(${name} PUBLIC ${ARG_DEPS})
endfunction()

# glam_add_test(name SOURCES a_test.cc DEPS lib [NEEDS_CLI] [LABELS l] [FIXTURES f] [TIMEOUT s])
# One gtest executable; each TEST becomes its own CTest entry (discovered before test run,
# so a build never executes test binaries).
function(glam_add_test name)
  cmake_parse_arguments(ARG "NEEDS_CLI" "TIMEOUT" "SOURCES;DEPS;LABELS;FIXTURES" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  glam_target_defaults(${name})
  target_link_libraries(${name} PRIVATE ${ARG_DEPS} glam_test_main GTest::gtest GTest::gmock)
  # Tests find the CLI and the shared synthetic clips (CTest fixtures) through these.
  target_compile_definitions(${name} PRIVATE
    GLAM_TEST_FIXTURES_DIR="${CMAKE_BINARY_DIR}/fixtures"
    GLAM_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
  if(ARG_NEEDS_CLI)
    # Tests that drive the `glam` executable (end-to-end, CLI error handling).
    target_compile_definitions(${name} PRIVATE GLAM_BIN="$<TARGET_FILE:glam>")
    add_dependencies(${name} glam)
  endif()
  if(NOT ARG_TIMEOUT)
    set(ARG_TIMEOUT 300)
  endif()
  set(props TIMEOUT ${ARG_TIMEOUT})
  if(ARG_LABELS)
    list(APPEND props LABELS "${ARG_LABELS}")
  endif()
  # gtest_discover_tests passes PROPERTIES through cmake_parse_arguments, which flattens a
  # list value: FIXTURES_REQUIRED "a;b" would require a and read b as a property name (b then
  # silently not required). So a test needing several fixtures requires one group fixture, set
  # up by a no-op test that requires them all (CTest follows fixtures of setup tests).
  if(ARG_FIXTURES)
    list(LENGTH ARG_FIXTURES fixture_count)
    if(fixture_count GREATER 1)
      list(JOIN ARG_FIXTURES "+" fixture)
      add_test(NAME fixture_group.${name} COMMAND ${CMAKE_COMMAND} -E true)
      set_tests_properties(fixture_group.${name} PROPERTIES
        FIXTURES_SETUP ${fixture} FIXTURES_REQUIRED "${ARG_FIXTURES}")
    else()
      set(fixture ${ARG_FIXTURES})
    endif()
    list(APPEND props FIXTURES_REQUIRED ${fixture})
  endif()
  gtest_discover_tests(${name}
    DISCOVERY_MODE PRE_TEST
    WORKING_DIRECTORY "${CMAKE_BINARY_DIR}"
    PROPERTIES ${props})
endfunction()

# glam_add_synth_fixture(name DIR dir [TIMEOUT s] ARGS synth args...)
# A CTest fixture `synth_<name>` that renders a clip with `glam synth ARGS --out
# <build>/fixtures/<dir>`; tests list it in glam_add_test(... FIXTURES synth_<name>). `glam synth`
# skips re-rendering when the directory already holds the same clip (synth.json matches).
function(glam_add_synth_fixture name)
  cmake_parse_arguments(ARG "" "DIR;TIMEOUT" "ARGS" ${ARGN})
  if(NOT ARG_TIMEOUT)
    set(ARG_TIMEOUT 300)
  endif()
  add_test(NAME fixture.synth_${name}
    COMMAND glam synth ${ARG_ARGS} --out ${CMAKE_BINARY_DIR}/fixtures/${ARG_DIR})
  set_tests_properties(fixture.synth_${name} PROPERTIES
    FIXTURES_SETUP synth_${name}
    TIMEOUT ${ARG_TIMEOUT})
endfunction()
