# The one-way dependency rule of docs/architecture.md, checked on the sources
# and on the CMake link graph. Run by ctest (tests/layering/CMakeLists.txt):
#   cmake -DSOURCE_DIR=<tree> -DLINKS_FILE=<file> -P CheckLayering.cmake
#
# Layers, bottom up, and what each may use:
#   common  -> (nothing)
#   config  -> common
#   acquire -> config, common       (avatar/acquire/ and avatar/render/ headers)
#   analyze -> config, common
#   tau     -> acquire, analyze, config, common
#   tools   -> anything (tools/ is not checked; nothing may include from it)
# An #include <avatar/X/...> and a link to avatar::X both count as a use of X's
# layer. A quoted include may not reach outside its own layer's folder.
# LINKS_FILE has one line per library: "<layer> <library>: <linked avatar libraries>".

cmake_minimum_required(VERSION 3.22)

set(allowed_common "common")
set(allowed_config "common;config")
set(allowed_acquire "common;config;acquire")
set(allowed_analyze "common;config;analyze")
set(allowed_tau "common;config;acquire;analyze;tau")

# The layer an include path belongs to ("" when it is no AVATAR header).
function(layer_of_include path out)
  set(layer "")
  if(path MATCHES "^avatar/(common|config|acquire|analyze|tau)/")
    set(layer "${CMAKE_MATCH_1}")
  elseif(path MATCHES "^avatar/render/")
    set(layer "acquire")  # the renderer is part of the acquisition layer
  endif()
  set(${out} "${layer}" PARENT_SCOPE)
endfunction()

# The layer of a library target name (avatar::vision -> tau).
function(layer_of_library library out)
  string(REGEX REPLACE "^avatar(::|_)" "" name "${library}")
  if(name MATCHES "^(common|config|acquire|analyze)$")
    set(${out} "${name}" PARENT_SCOPE)
  elseif(name MATCHES "^(protocol|vision|taunet|tauunit|servo)$")
    set(${out} "tau" PARENT_SCOPE)
  else()
    set(${out} "" PARENT_SCOPE)
  endif()
endfunction()

set(violations "")
set(files_checked 0)

foreach(layer common config acquire analyze tau)
  set(root "${SOURCE_DIR}/${layer}")
  if(NOT IS_DIRECTORY "${root}")
    continue()
  endif()
  file(GLOB_RECURSE sources "${root}/*.h" "${root}/*.hpp" "${root}/*.cpp")
  foreach(source IN LISTS sources)
    math(EXPR files_checked "${files_checked} + 1")
    file(RELATIVE_PATH shown "${SOURCE_DIR}" "${source}")
    file(STRINGS "${source}" lines REGEX "^[ \t]*#[ \t]*include[ \t]*[<\"]")
    foreach(line IN LISTS lines)
      if(line MATCHES "#[ \t]*include[ \t]*<([^>]+)>")
        layer_of_include("${CMAKE_MATCH_1}" used)
        if(used AND NOT used IN_LIST allowed_${layer})
          list(APPEND violations "${shown}: the ${layer} layer includes <${CMAKE_MATCH_1}> of the ${used} layer")
        endif()
      elseif(line MATCHES "#[ \t]*include[ \t]*\"([^\"]+)\"")
        set(included "${CMAKE_MATCH_1}")
        get_filename_component(dir "${source}" DIRECTORY)
        get_filename_component(target "${dir}/${included}" ABSOLUTE)
        file(RELATIVE_PATH inside "${root}" "${target}")
        if(inside MATCHES "^\\.\\./")
          file(RELATIVE_PATH reached "${SOURCE_DIR}" "${target}")
          list(APPEND violations "${shown}: the ${layer} layer includes \"${included}\" (${reached}) from outside its folder")
        endif()
      endif()
    endforeach()
  endforeach()
endforeach()

if(NOT EXISTS "${LINKS_FILE}")
  message(FATAL_ERROR "layering: no link graph ${LINKS_FILE} (written when CMake configures the build)")
endif()
file(STRINGS "${LINKS_FILE}" link_lines)
set(libraries_checked 0)
foreach(line IN LISTS link_lines)
  if(NOT line MATCHES "^([a-z]+) ([A-Za-z0-9_:.-]+):(.*)$")
    message(FATAL_ERROR "layering: ${LINKS_FILE}: cannot read the line '${line}'")
  endif()
  set(layer "${CMAKE_MATCH_1}")
  if(layer STREQUAL "tools")
    continue()  # tools may use anything
  endif()
  if(NOT DEFINED allowed_${layer})
    message(FATAL_ERROR "layering: ${LINKS_FILE}: '${CMAKE_MATCH_2}' is in no known layer ('${layer}')")
  endif()
  set(library "${CMAKE_MATCH_2}")
  string(STRIP "${CMAKE_MATCH_3}" deps)
  separate_arguments(deps)
  math(EXPR libraries_checked "${libraries_checked} + 1")
  foreach(dep IN LISTS deps)
    layer_of_library("${dep}" used)
    if(used AND NOT used IN_LIST allowed_${layer})
      list(APPEND violations "${library} (${layer} layer) links ${dep} of the ${used} layer")
    endif()
  endforeach()
endforeach()

list(SORT violations)
list(LENGTH violations count)
if(count GREATER 0)
  list(JOIN violations "\n  " text)
  message(FATAL_ERROR "layering: ${count} use(s) of a layer above (docs/architecture.md, \"Layers\"):\n  ${text}")
endif()
message(STATUS "layering: ${files_checked} files and ${libraries_checked} libraries and programs use only their own layer and those below it")
