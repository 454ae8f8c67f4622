# cmake -P script behind the ctest tests `install_consumer` and `add_subdirectory_consumer`.
#
#   MODE=install  cmake --install FERRULE_BINARY_DIR into WORK_DIR/prefix, then configure the
#                 consumer with CMAKE_PREFIX_PATH=WORK_DIR/prefix (find_package(ferrule CONFIG))
#   MODE=subdir   configure the consumer with FERRULE_SOURCE_DIR (add_subdirectory(ferrule))
# then build the consumer in WORK_DIR/build and run its three programs (ferrule::ferrule,
# ferrule::host, ferrule::sim), each of which must exit with 0.
# The consumer is built with the same compiler, flags, build type and generator as the
# ferrule build that registered the test.
cmake_minimum_required(VERSION 3.25)

foreach(var IN ITEMS MODE FERRULE_SOURCE_DIR FERRULE_BINARY_DIR CONSUMER_SOURCE_DIR WORK_DIR
                     CXX_COMPILER GENERATOR)
    if(NOT DEFINED ${var} OR "${${var}}" STREQUAL "")
        message(FATAL_ERROR "run_consumer.cmake: -D${var}=... is required")
    endif()
endforeach()
if(NOT BUILD_TYPE)
    set(BUILD_TYPE Release)
endif()

function(run what)
    string(REPLACE ";" " " shown "${ARGN}")
    message(STATUS "[${MODE}] ${what}: ${shown}")
    execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc)
    if(NOT rc EQUAL 0)
        message(FATAL_ERROR "[${MODE}] ${what} failed (${rc})")
    endif()
endfunction()

file(REMOVE_RECURSE "${WORK_DIR}")
file(MAKE_DIRECTORY "${WORK_DIR}")

set(configure_args
    -S "${CONSUMER_SOURCE_DIR}" -B "${WORK_DIR}/build"
    -G "${GENERATOR}"
    "-DCMAKE_CXX_COMPILER=${CXX_COMPILER}"
    "-DCMAKE_CXX_FLAGS=${CXX_FLAGS}"
    "-DCMAKE_BUILD_TYPE=${BUILD_TYPE}")
if(MAKE_PROGRAM)
    list(APPEND configure_args "-DCMAKE_MAKE_PROGRAM=${MAKE_PROGRAM}")
endif()

if(MODE STREQUAL "install")
    set(prefix "${WORK_DIR}/prefix")
    run("install" "${CMAKE_COMMAND}" --install "${FERRULE_BINARY_DIR}" --prefix "${prefix}"
        --config "${BUILD_TYPE}")
    file(GLOB_RECURSE installed RELATIVE "${prefix}" "${prefix}/*")
    foreach(f IN ITEMS ferrule/core/checksum.hpp ferrule/host/serial_port.hpp
                       ferrule/sim/mock_serial.hpp ferruleConfig.cmake ferruleConfigVersion.cmake
                       ferruleTargets.cmake)
        string(REPLACE "." "\\." f_regex "${f}")
        set(hits ${installed})
        list(FILTER hits INCLUDE REGEX "(^|/)${f_regex}$")
        if(NOT hits)
            message(FATAL_ERROR "[install] ${f} was not installed under ${prefix}")
        endif()
    endforeach()
    # Only the prefix given here may satisfy find_package(ferrule).
    list(APPEND configure_args "-DCMAKE_PREFIX_PATH=${prefix}"
        -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF -DCMAKE_FIND_USE_SYSTEM_PACKAGE_REGISTRY=OFF)
elseif(MODE STREQUAL "subdir")
    list(APPEND configure_args "-DFERRULE_SOURCE_DIR=${FERRULE_SOURCE_DIR}")
else()
    message(FATAL_ERROR "run_consumer.cmake: unknown MODE '${MODE}'")
endif()

run("configure consumer" "${CMAKE_COMMAND}" ${configure_args})
run("build consumer" "${CMAKE_COMMAND}" --build "${WORK_DIR}/build" --config "${BUILD_TYPE}")

foreach(program IN ITEMS ferrule_consumer ferrule_consumer_host ferrule_consumer_sim)
    find_program(exe NAMES ${program}
        PATHS "${WORK_DIR}/build" "${WORK_DIR}/build/${BUILD_TYPE}" NO_DEFAULT_PATH NO_CACHE)
    if(NOT exe)
        message(FATAL_ERROR "[${MODE}] the consumer ${program} was not built")
    endif()
    run("run ${program}" "${exe}")
    unset(exe)
endforeach()
message(STATUS "[${MODE}] OK: ferrule::ferrule (Modbus CRC check value), ferrule::host (a pty "
               "opened as a serial port), ferrule::sim (a Modbus client starts a simulated VFD)")
