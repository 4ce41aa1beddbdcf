# avatar_library(<name> SOURCES ... [PUBLIC_DEPS ...] [PRIVATE_DEPS ...])
# Declares one of the product's static libraries with its avatar:: alias,
# its public include directory, strict warnings and the install rules.
function(avatar_set_warnings target)
  target_compile_options(${target} PRIVATE
    -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor -Woverloaded-virtual
    -Wcast-qual -Wformat=2 -Wimplicit-fallthrough -Wmissing-declarations)
  if(AVATAR_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()

# Remembers a library or program and its layer (the top folder it lives in:
# common, config, acquire, analyze, tau, tools) for the layering check, which
# reads the link graph avatar_write_link_graph() writes (tests/layering).
function(avatar_record_layer target)
  file(RELATIVE_PATH rel ${PROJECT_SOURCE_DIR} ${CMAKE_CURRENT_SOURCE_DIR})
  string(REGEX REPLACE "/.*" "" layer "${rel}")
  set_property(GLOBAL APPEND PROPERTY AVATAR_LAYERED_TARGETS "${layer}|${target}")
endfunction()

# Writes "<layer> <target>: <linked libraries>" for every recorded target.
function(avatar_write_link_graph file)
  get_property(entries GLOBAL PROPERTY AVATAR_LAYERED_TARGETS)
  set(text "")
  foreach(entry IN LISTS entries)
    string(REPLACE "|" ";" parts "${entry}")
    list(GET parts 0 layer)
    list(GET parts 1 target)
    get_target_property(links ${target} LINK_LIBRARIES)
    if(NOT links)
      set(links "")
    endif()
    string(REPLACE ";" " " links "${links}")
    string(APPEND text "${layer} ${target}: ${links}\n")
  endforeach()
  file(WRITE ${file} "${text}")
endfunction()

function(avatar_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;PUBLIC_DEPS;PRIVATE_DEPS" ${ARGN})
  add_library(avatar_${name} STATIC ${ARG_SOURCES})
  add_library(avatar::${name} ALIAS avatar_${name})
  set_target_properties(avatar_${name} PROPERTIES
    OUTPUT_NAME avatar_${name}
    EXPORT_NAME ${name}
    POSITION_INDEPENDENT_CODE ON)
  target_include_directories(avatar_${name} PUBLIC
    $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>
    $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>
    PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/src)
  target_link_libraries(avatar_${name} PUBLIC ${ARG_PUBLIC_DEPS} PRIVATE ${ARG_PRIVATE_DEPS})
  target_compile_features(avatar_${name} PUBLIC cxx_std_17)
  avatar_set_warnings(avatar_${name})
  avatar_record_layer(avatar_${name})
  install(TARGETS avatar_${name} EXPORT AvatarTargets
          ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR})
  # Headers under an internal/ folder are shared between the AVATAR libraries
  # only; tests/install checks that none is installed.
  install(DIRECTORY include/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR} PATTERN internal EXCLUDE)
endfunction()

# avatar_executable(<name> SOURCES ... DEPS ...)
function(avatar_executable name)
  cmake_parse_arguments(ARG "INSTALL" "" "SOURCES;DEPS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_DEPS})
  avatar_set_warnings(${name})
  avatar_record_layer(${name})
  if(ARG_INSTALL)
    install(TARGETS ${name} RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
  endif()
endfunction()
