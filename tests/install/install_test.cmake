# Installs the build tree into a scratch prefix, then configures, builds and
# runs examples/c_driver against it with find_package(hapticlab): what a
# driver author outside this repository does. Then the same for
# examples/device_plugin, checked with the installed `hapticlab device check`.
file(REMOVE_RECURSE ${WORK_DIR})
execute_process(COMMAND ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${WORK_DIR}/prefix
                RESULT_VARIABLE rc)
if(rc)
  message(FATAL_ERROR "cmake --install failed")
endif()
foreach(f include/hapticlab/hapticlab.h include/hapticlab/study.h include/hapticlab/device_plugin.h
          lib/cmake/hapticlab/hapticlabConfig.cmake lib/hapticlab/plugins/hapticlab_sim_device.so)
  if(NOT EXISTS ${WORK_DIR}/prefix/${f})
    message(FATAL_ERROR "not installed: ${f}")
  endif()
endforeach()
execute_process(COMMAND ${CMAKE_COMMAND} -S ${SOURCE_DIR}/examples/c_driver -B ${WORK_DIR}/build
                        -DCMAKE_PREFIX_PATH=${WORK_DIR}/prefix RESULT_VARIABLE rc)
if(rc)
  message(FATAL_ERROR "configuring the consumer project failed")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} --build ${WORK_DIR}/build RESULT_VARIABLE rc)
if(rc)
  message(FATAL_ERROR "building the consumer project failed")
endif()
execute_process(COMMAND ${WORK_DIR}/build/hapticlab_c_driver
                        ${WORK_DIR}/prefix/share/hapticlab/settings/all_degradations.json 1.0
                RESULT_VARIABLE rc OUTPUT_VARIABLE out)
message(STATUS "${out}")
if(rc)
  message(FATAL_ERROR "the example driver failed")
endif()

# The study API's example application, built the same way, runs a whole
# session of a study the installed CLI created (issue 15 section 3).
execute_process(COMMAND ${CMAKE_COMMAND} -S ${SOURCE_DIR}/examples/external_app -B ${WORK_DIR}/build-app
                        -DCMAKE_PREFIX_PATH=${WORK_DIR}/prefix RESULT_VARIABLE rc)
if(rc)
  message(FATAL_ERROR "configuring examples/external_app against the installed package failed")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} --build ${WORK_DIR}/build-app RESULT_VARIABLE rc)
if(rc)
  message(FATAL_ERROR "building examples/external_app against the installed package failed")
endif()
execute_process(COMMAND ${WORK_DIR}/prefix/bin/hapticlab study create
                        --protocol ${WORK_DIR}/prefix/share/hapticlab/protocols/external_peg_touch.json
                        --db ${WORK_DIR}/peg.db
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE out)
if(rc)
  message(FATAL_ERROR "hapticlab study create failed: ${out}")
endif()
execute_process(COMMAND ${WORK_DIR}/build-app/hapticlab_external_app ${WORK_DIR}/peg.db P01
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE out)
message(STATUS "${out}")
if(rc OR NOT out MATCHES "schedule complete")
  message(FATAL_ERROR "the example application did not complete its session")
endif()
# --- examples/device_plugin: built against the package, loaded by the installed CLI
execute_process(COMMAND ${CMAKE_COMMAND} -S ${SOURCE_DIR}/examples/device_plugin -B ${WORK_DIR}/build-plugin
                        -DCMAKE_PREFIX_PATH=${WORK_DIR}/prefix RESULT_VARIABLE rc)
if(rc)
  message(FATAL_ERROR "configuring examples/device_plugin failed")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} --build ${WORK_DIR}/build-plugin RESULT_VARIABLE rc)
if(rc)
  message(FATAL_ERROR "building examples/device_plugin failed")
endif()
foreach(plugin ${WORK_DIR}/build-plugin/acme_device.so ${WORK_DIR}/prefix/lib/hapticlab/plugins/hapticlab_sim_device.so)
  execute_process(COMMAND ${WORK_DIR}/prefix/bin/hapticlab device check --device plugin:${plugin} --seconds 0.2
                          --rate-tolerance 0.5  # a loaded CI machine; the rate has its own tests
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  message(STATUS "${out}${err}")
  if(rc)
    message(FATAL_ERROR "hapticlab device check failed on ${plugin}")
  endif()
endforeach()
