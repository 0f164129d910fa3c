# An installed copy works wherever its prefix ends up: installs into a
# scratch prefix, moves the whole prefix elsewhere, then from an empty
# folder runs `demo --quick` and `engine demo` (which must find the shipped
# protocols and settings under <prefix>/share/hapticlab, not in this source
# tree), and builds and runs the example C driver and the study API's
# example application with pkg-config.
#   -DBUILD_DIR=... -DWORK_DIR=... -DSOURCE_DIR=...
file(REMOVE_RECURSE ${WORK_DIR})
execute_process(COMMAND ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${WORK_DIR}/first
                RESULT_VARIABLE rc OUTPUT_QUIET)
if(rc)
  message(FATAL_ERROR "cmake --install failed")
endif()
file(RENAME ${WORK_DIR}/first ${WORK_DIR}/moved)
set(prefix ${WORK_DIR}/moved)
file(MAKE_DIRECTORY ${WORK_DIR}/empty)

function(run_in_empty_folder what)
  execute_process(COMMAND ${ARGN} WORKING_DIRECTORY ${WORK_DIR}/empty
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(rc)
    message(FATAL_ERROR "${what} failed (${rc}) from the moved prefix:\n${out}\n${err}")
  endif()
  set(last_output "${out}" PARENT_SCOPE)
endfunction()

# The source tree must not be what makes it work: hide it from the binary
# by pointing nothing at it (HAPTICLAB_DATA_DIR unset) and checking which
# protocol the demo says it used.
run_in_empty_folder("demo --quick"
  ${CMAKE_COMMAND} -E env --unset=HAPTICLAB_DATA_DIR
  ${prefix}/bin/hapticlab demo --quick --no-plots --out demo)
if(NOT last_output MATCHES "${WORK_DIR}/moved/share/hapticlab/protocols")
  message(FATAL_ERROR "demo did not use the moved prefix's protocols:\n${last_output}")
endif()
foreach(f demo/study.db demo/metrics.csv demo/report.html)
  if(NOT EXISTS ${WORK_DIR}/empty/${f})
    message(FATAL_ERROR "demo --quick wrote no ${f}")
  endif()
endforeach()
run_in_empty_folder("engine demo"
  ${CMAKE_COMMAND} -E env --unset=HAPTICLAB_DATA_DIR
  ${prefix}/bin/hapticlab engine demo --out engine_demo)
file(GLOB csvs ${WORK_DIR}/empty/engine_demo/*.csv)
list(LENGTH csvs n)
if(n LESS 8)
  message(FATAL_ERROR "engine demo wrote ${n} CSV files, expected one per shipped setting (8)")
endif()

# pkg-config from the moved prefix: the .pc file's paths are relative to itself.
find_program(PKG_CONFIG pkg-config REQUIRED)
execute_process(COMMAND ${CMAKE_COMMAND} -E env PKG_CONFIG_PATH=${prefix}/lib/pkgconfig
                        ${PKG_CONFIG} --cflags --libs hapticlab
                OUTPUT_VARIABLE flags OUTPUT_STRIP_TRAILING_WHITESPACE RESULT_VARIABLE rc)
if(rc OR NOT flags MATCHES "-I${prefix}/")
  message(FATAL_ERROR "pkg-config --cflags --libs hapticlab gave '${flags}'")
endif()
separate_arguments(flags UNIX_COMMAND "${flags}")
execute_process(COMMAND cc -std=c99 -o ${WORK_DIR}/driver ${SOURCE_DIR}/examples/c_driver/driver.c ${flags} -lm
                RESULT_VARIABLE rc ERROR_VARIABLE err)
if(rc)
  message(FATAL_ERROR "building the example driver with pkg-config failed:\n${err}")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} -E env LD_LIBRARY_PATH=${prefix}/lib
                        ${WORK_DIR}/driver ${prefix}/share/hapticlab/settings/all_degradations.json 0.2
                RESULT_VARIABLE rc OUTPUT_QUIET)
if(rc)
  message(FATAL_ERROR "the example driver built with pkg-config failed (${rc})")
endif()

# The study API's example application, built with pkg-config alone (as a lab
# with make or meson would), runs a session of a study the moved CLI made.
execute_process(COMMAND ${CMAKE_COMMAND} -E env PKG_CONFIG_PATH=${prefix}/lib/pkgconfig
                        ${PKG_CONFIG} --cflags --libs hapticlab-study
                OUTPUT_VARIABLE flags OUTPUT_STRIP_TRAILING_WHITESPACE RESULT_VARIABLE rc)
if(rc OR NOT flags MATCHES "-lhapticlab_study" OR NOT flags MATCHES "-lhapticlab( |$)")
  message(FATAL_ERROR "pkg-config --cflags --libs hapticlab-study gave '${flags}'")
endif()
separate_arguments(flags UNIX_COMMAND "${flags}")
execute_process(COMMAND cc -std=c99 -o ${WORK_DIR}/external_app ${SOURCE_DIR}/examples/external_app/external_app.c
                        ${flags} -lm
                RESULT_VARIABLE rc ERROR_VARIABLE err)
if(rc)
  message(FATAL_ERROR "building examples/external_app with pkg-config failed:\n${err}")
endif()
run_in_empty_folder("study create"
  ${prefix}/bin/hapticlab study create --protocol ${prefix}/share/hapticlab/protocols/external_peg_touch.json
  --db peg.db)
run_in_empty_folder("the study API's example application"
  ${CMAKE_COMMAND} -E env LD_LIBRARY_PATH=${prefix}/lib ${WORK_DIR}/external_app peg.db P01)
if(NOT last_output MATCHES "schedule complete")
  message(FATAL_ERROR "the example application built with pkg-config did not complete its session:\n${last_output}")
endif()
