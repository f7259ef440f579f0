# Script mode (cmake -P): stages the extension and zips it.
#   ADDON_DIR  addon/sweep_deform       LIBRARY  the built libsweepdeform.so.<version>
#   STAGE      scratch directory        ZIP      the zip to write
#   EXTRA_LIBRARIES  optional: more libraries of ours for lib/ (libsweepdeform_dmap.so.<version>)
# Libraries of the base system (glibc, the C++ runtime, the dynamic loader) are not bundled:
# Blender itself needs them and every Linux that runs Blender has them (Blender's own builds
# assume the same). Everything else the library needs is copied into lib/ under its SONAME,
# the name the dynamic loader looks for, as a regular file (no symlinks in the zip).
cmake_minimum_required(VERSION 3.21)

foreach(v ADDON_DIR LIBRARY STAGE ZIP)
  if(NOT DEFINED ${v})
    message(FATAL_ERROR "package_addon.cmake: -D${v}=... is required")
  endif()
endforeach()

file(REMOVE_RECURSE ${STAGE})
file(MAKE_DIRECTORY ${STAGE}/lib)
# The add-on's files with their folders (core/, blender/, ui/).
file(GLOB_RECURSE sources RELATIVE ${ADDON_DIR} ${ADDON_DIR}/*.py ${ADDON_DIR}/*.toml ${ADDON_DIR}/*.md)
foreach(source ${sources})
  configure_file(${ADDON_DIR}/${source} ${STAGE}/${source} COPYONLY)
endforeach()
set(ours ${LIBRARY} ${EXTRA_LIBRARIES})
foreach(lib ${ours})
  get_filename_component(name ${lib} NAME)
  configure_file(${lib} ${STAGE}/lib/${name} COPYONLY)
endforeach()
get_filename_component(library_name ${LIBRARY} NAME)

set(system_libraries
  "^ld-linux" "^libc\\.so" "^libm\\.so" "^libdl\\.so" "^libpthread\\.so" "^librt\\.so"
  "^libstdc\\+\\+\\.so" "^libgcc_s\\.so" "^linux-vdso")
file(GET_RUNTIME_DEPENDENCIES
  LIBRARIES ${ours}
  RESOLVED_DEPENDENCIES_VAR resolved
  UNRESOLVED_DEPENDENCIES_VAR unresolved
  PRE_EXCLUDE_REGEXES ${system_libraries}
  POST_EXCLUDE_REGEXES ".*/ld-linux[^/]*$" ".*/libc\\.so[^/]*$")
if(unresolved)
  message(FATAL_ERROR "package_addon.cmake: unresolved dependencies of ${library_name}: ${unresolved}")
endif()
set(bundled "")
foreach(dep ${resolved})
  # The file name the loader asks for is the dependency's SONAME; ldd/cmake resolve that name
  # to a path whose last component is it (a symlink to the versioned file).
  get_filename_component(soname ${dep} NAME)
  configure_file(${dep} ${STAGE}/lib/${soname} COPYONLY)
  list(APPEND bundled ${soname})
endforeach()
message(STATUS "Bundled beside ${library_name}: ${bundled}")

get_filename_component(zip_dir ${ZIP} DIRECTORY)
file(MAKE_DIRECTORY ${zip_dir})
file(REMOVE ${ZIP})
file(GLOB_RECURSE staged RELATIVE ${STAGE} ${STAGE}/*)
list(SORT staged)
execute_process(
  COMMAND ${CMAKE_COMMAND} -E tar cf ${ZIP} --format=zip -- ${staged}
  WORKING_DIRECTORY ${STAGE}
  RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "package_addon.cmake: zipping failed (${rc})")
endif()
message(STATUS "Wrote ${ZIP}: ${staged}")
