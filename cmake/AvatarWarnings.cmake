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
  if(ARG_INSTALL)
    install(TARGETS ${name} RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
  endif()
endfunction()
