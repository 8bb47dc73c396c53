# prt as an installable, relocatable package: CMake config with one
# component per library, pkg-config files, and a build tree laid out like the
# install tree (prt/paths.h finds the plugin and the data relative to
# libprt_core, so neither holds an absolute path).
#
#   prt_library(<target> <component> HEADERS <name.h>...)
#       in each library's CMakeLists.txt: output directory, soname, RPATH,
#       install rules for the library and its public headers (include/prt/),
#       its export set prt-<component>-targets.
#   prt_bundled_data(<source dir> <file>...)
#       files linked into the build tree's <datadir>/prt (symbolic links to the
#       sources) and installed (copied) into <prefix>/<datadir>/prt.
#   prt_install_package()
#       at the end of the top-level CMakeLists.txt: prtConfig.cmake,
#       prtConfigVersion.cmake and the .pc files, with each component's
#       dependencies read from its targets' link libraries (see the table below).
include(CMakePackageConfigHelpers)

# Relative paths between install directories: all that prt compiles in
# (core/paths.cpp) or writes into RPATHs and .pc files.
function(_prt_relative out from to)
  file(RELATIVE_PATH rel "${from}" "${to}")
  string(REGEX REPLACE "/$" "" rel "${rel}")
  if(rel STREQUAL "")
    set(rel ".")
  endif()
  set(${out} "${rel}" PARENT_SCOPE)
endfunction()
_prt_relative(PRT_LIB_FROM_BINDIR "${CMAKE_INSTALL_FULL_BINDIR}" "${CMAKE_INSTALL_FULL_LIBDIR}")
_prt_relative(PRT_DATA_FROM_LIBDIR "${CMAKE_INSTALL_FULL_LIBDIR}" "${CMAKE_INSTALL_FULL_DATADIR}/prt")
_prt_relative(PRT_PREFIX_FROM_PCDIR "${CMAKE_INSTALL_FULL_LIBDIR}/pkgconfig" "${CMAKE_INSTALL_PREFIX}")
if(IS_ABSOLUTE "${CMAKE_INSTALL_LIBDIR}" OR IS_ABSOLUTE "${CMAKE_INSTALL_BINDIR}" OR IS_ABSOLUTE "${CMAKE_INSTALL_DATADIR}")
  message(WARNING "prt: an absolute CMAKE_INSTALL_LIBDIR, BINDIR or DATADIR makes the installed tree non-relocatable")
endif()

set(PRT_INSTALL_CMAKEDIR "${CMAKE_INSTALL_LIBDIR}/cmake/prt")
set(PRT_OUTPUT_LIBDIR "${PROJECT_BINARY_DIR}/${CMAKE_INSTALL_LIBDIR}")
set(PRT_OUTPUT_DATADIR "${PROJECT_BINARY_DIR}/${CMAKE_INSTALL_DATADIR}/prt")
# Installed executables find the libraries relative to themselves.
set(PRT_EXECUTABLE_INSTALL_RPATH "$ORIGIN/${PRT_LIB_FROM_BINDIR}")

function(prt_library target component)
  cmake_parse_arguments(ARG "" "" "HEADERS" ${ARGN})
  set(headers)
  foreach(h IN LISTS ARG_HEADERS)
    set(f "${PROJECT_SOURCE_DIR}/include/prt/${h}")
    if(NOT EXISTS "${f}")
      message(FATAL_ERROR "prt_library(${target}): public header include/prt/${h} does not exist")
    endif()
    list(APPEND headers "${f}")
  endforeach()
  set_target_properties(${target} PROPERTIES
    EXPORT_NAME ${component}
    VERSION ${PROJECT_VERSION}
    SOVERSION ${PROJECT_VERSION_MAJOR}.${PROJECT_VERSION_MINOR}
    LIBRARY_OUTPUT_DIRECTORY "${PRT_OUTPUT_LIBDIR}"
    ARCHIVE_OUTPUT_DIRECTORY "${PRT_OUTPUT_LIBDIR}"
    INSTALL_RPATH "$ORIGIN")  # the other prt libraries lie beside it
  install(TARGETS ${target} EXPORT prt-${component}-targets
    LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
    ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
    INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
  install(FILES ${headers} DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/prt)
  install(EXPORT prt-${component}-targets NAMESPACE prt:: DESTINATION ${PRT_INSTALL_CMAKEDIR})
  set_property(GLOBAL APPEND PROPERTY PRT_COMPONENTS ${component})
  set_property(GLOBAL PROPERTY PRT_COMPONENT_TARGET_${component} ${target})
  set_property(GLOBAL APPEND PROPERTY PRT_PUBLIC_HEADERS ${ARG_HEADERS})
endfunction()

function(prt_bundled_data source_dir)
  set(outputs)
  foreach(f IN LISTS ARGN)
    set(out "${PRT_OUTPUT_DATADIR}/${f}")
    get_filename_component(dir "${out}" DIRECTORY)
    # A link, not a copy: the build tree's data is the source's, so prt view
    # sees envmaps/x.exr and share/prt/envmaps/x.exr as one map.
    add_custom_command(OUTPUT "${out}"
      COMMAND ${CMAKE_COMMAND} -E make_directory "${dir}"
      COMMAND ${CMAKE_COMMAND} -E create_symlink "${source_dir}/${f}" "${out}"
      DEPENDS "${source_dir}/${f}"
      COMMENT "prt data: ${CMAKE_INSTALL_DATADIR}/prt/${f}" VERBATIM)
    list(APPEND outputs "${out}")
    get_filename_component(sub "${f}" DIRECTORY)
    install(FILES "${source_dir}/${f}" DESTINATION "${CMAKE_INSTALL_DATADIR}/prt/${sub}")
  endforeach()
  add_custom_target(prt_data ALL DEPENDS ${outputs})
endfunction()

# What each dependency of a prt library needs in a consumer: the
# find_dependency() arguments ("PKG:<prefix>:<module>": a pkg-config
# IMPORTED_TARGET), and the pkg-config module (or "-l..." flags) for the .pc
# files. A library linking anything not listed here stops the configure, so
# prtConfig.cmake cannot fall out of step with the targets.
set(_prt_dep_table
  "glm::glm|glm|glm"
  "TBB::tbb|TBB|tbb"
  "OpenEXR::OpenEXR|OpenEXR|OpenEXR"
  "assimp::assimp|assimp|assimp"
  "embree|embree 3|-lembree3"
  "OpenGL::OpenGL|OpenGL COMPONENTS OpenGL EGL|opengl"
  "OpenGL::EGL|OpenGL COMPONENTS OpenGL EGL|egl"
  "PkgConfig::XXHASH|PKG:XXHASH:libxxhash|libxxhash"
  "PkgConfig::OPENBLAS|PKG:OPENBLAS:openblas|openblas"
  "PkgConfig::STB|PKG:STB:stb|stb"
  "astcenc::astcenc|astcenc CONFIG|-lastcenc"
  "fmt::fmt|fmt|fmt"
  "fmt::fmt-header-only|fmt|fmt"
  "spdlog::spdlog|spdlog|spdlog"
  "nlohmann_json::nlohmann_json|nlohmann_json|nlohmann_json"
  "Threads::Threads|Threads|-pthread"
  "MPI::MPI_CXX|MPI COMPONENTS CXX|ompi-cxx")

# For one link item of a prt library: sets <prefix>_KIND (skip, prt, dep,
# flag), <prefix>_NAME (the component, or the item), <prefix>_FIND, <prefix>_PC.
function(_prt_classify prefix item components)
  set(kind skip)
  set(name "${item}")
  set(find "")
  set(pc "")
  string(REGEX REPLACE "^\\$<LINK_ONLY:(.*)>$" "\\1" item "${item}")
  set(row_found "")
  foreach(row IN LISTS _prt_dep_table)
    string(REPLACE "|" ";" row "${row}")
    list(GET row 0 t)
    if(item STREQUAL t)
      set(row_found "${row}")
    endif()
  endforeach()
  if(item MATCHES "^\\$<BUILD_INTERFACE:" OR item STREQUAL "")
    # build tree only (prt_options): never exported
  elseif(NOT row_found STREQUAL "")
    # (imported targets are looked up by name: they live in the libraries' directories)
    set(kind dep)
    list(GET row_found 1 find)
    list(GET row_found 2 pc)
  elseif(TARGET "${item}")
    get_target_property(aliased "${item}" ALIASED_TARGET)
    if(aliased)
      set(item "${aliased}")
    endif()
    foreach(c IN LISTS components)
      get_property(t GLOBAL PROPERTY PRT_COMPONENT_TARGET_${c})
      if(item STREQUAL t)
        set(kind prt)
        set(name ${c})
      endif()
    endforeach()
    if(kind STREQUAL "skip")
      message(FATAL_ERROR "prt: a library links the target ${item}, which is no prt library")
    endif()
  elseif(item MATCHES "::")
    message(FATAL_ERROR "prt: a library links ${item}, which cmake/PrtPackage.cmake's _prt_dep_table "
                        "does not know: add how a consumer finds it (find_dependency, pkg-config)")
  elseif(item MATCHES "^-")
    set(kind flag)
    set(pc "${item}")
  elseif(item MATCHES "^[A-Za-z0-9_.+-]+$")
    set(kind flag)
    set(pc "-l${item}")
  else()
    message(FATAL_ERROR "prt: cannot export the link item '${item}' (cmake/PrtPackage.cmake)")
  endif()
  set(${prefix}_KIND "${kind}" PARENT_SCOPE)
  set(${prefix}_NAME "${name}" PARENT_SCOPE)
  set(${prefix}_FIND "${find}" PARENT_SCOPE)
  set(${prefix}_PC "${pc}" PARENT_SCOPE)
endfunction()

function(prt_install_package)
  get_property(components GLOBAL PROPERTY PRT_COMPONENTS)
  set(table "")
  set(pc_all "")
  foreach(c IN LISTS components)
    get_property(target GLOBAL PROPERTY PRT_COMPONENT_TARGET_${c})
    get_target_property(type ${target} TYPE)
    get_target_property(all ${target} LINK_LIBRARIES)
    get_target_property(iface ${target} INTERFACE_LINK_LIBRARIES)
    get_target_property(defs ${target} INTERFACE_COMPILE_DEFINITIONS)
    if(defs)
      message(FATAL_ERROR "prt: ${target} has INTERFACE_COMPILE_DEFINITIONS (${defs}); they would reach consumers")
    endif()
    if(NOT all)
      set(all "")
    endif()
    if(NOT iface)
      set(iface "")
    endif()
    set(below "")
    set(finds "")
    set(pc_requires "")
    set(pc_requires_private "")
    set(pc_libs_private "")
    if("prt_options" IN_LIST iface OR "$<LINK_ONLY:prt_options>" IN_LIST iface)
      message(FATAL_ERROR "prt: ${target} would export prt_options: link it as $<BUILD_INTERFACE:prt_options>")
    endif()
    list(REMOVE_ITEM all prt_options)
    foreach(item IN LISTS all)
      _prt_classify(i "${item}" "${components}")
      set(public FALSE)
      if(item IN_LIST iface)
        set(public TRUE)
      endif()
      if(i_KIND STREQUAL "prt")
        list(APPEND below ${i_NAME})
        list(APPEND pc_requires prt-${i_NAME})
      elseif(i_KIND STREQUAL "dep" OR i_KIND STREQUAL "flag")
        # A shared library's private dependencies stay inside it; a static
        # one's reach every consumer's link.
        if(public OR NOT type STREQUAL "SHARED_LIBRARY")
          if(i_FIND)
            list(APPEND finds "${i_FIND}")
          endif()
        endif()
        if(i_PC MATCHES "^-")
          if(public)
            message(FATAL_ERROR "prt: ${target} links ${item} PUBLIC; give it a pkg-config module in _prt_dep_table")
          elseif(NOT type STREQUAL "SHARED_LIBRARY")
            list(APPEND pc_libs_private "${i_PC}")
          endif()
        elseif(public)
          list(APPEND pc_requires "${i_PC}")
        elseif(NOT type STREQUAL "SHARED_LIBRARY")
          list(APPEND pc_requires_private "${i_PC}")
        endif()
      endif()
    endforeach()
    foreach(v below finds pc_requires pc_requires_private pc_libs_private)
      list(REMOVE_DUPLICATES ${v})
    endforeach()
    string(APPEND table "set(_prt_below_${c} \"${below}\")\nset(_prt_deps_${c} \"${finds}\")\n")
    set(PRT_PC_NAME "prt-${c}")
    set(PRT_PC_DESCRIPTION "prt::${c}, Precomputed Radiance Transfer toolkit")
    list(JOIN pc_requires " " PRT_PC_REQUIRES)
    list(JOIN pc_requires_private " " PRT_PC_REQUIRES_PRIVATE)
    get_target_property(output_name ${target} OUTPUT_NAME)
    if(NOT output_name)
      set(output_name ${target})
    endif()
    set(PRT_PC_LIBS "-L\${libdir} -l${output_name}")
    list(JOIN pc_libs_private " " PRT_PC_LIBS_PRIVATE)
    set(PRT_PC_CFLAGS "-I\${includedir}")
    configure_file("${PROJECT_SOURCE_DIR}/cmake/prt.pc.in" "${PROJECT_BINARY_DIR}/pkgconfig/prt-${c}.pc" @ONLY)
    install(FILES "${PROJECT_BINARY_DIR}/pkgconfig/prt-${c}.pc" DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig)
    list(APPEND pc_all prt-${c})
  endforeach()

  # prt.pc: every component installed.
  set(PRT_PC_NAME prt)
  list(JOIN components ", " names)
  set(PRT_PC_DESCRIPTION "Precomputed Radiance Transfer toolkit (all of: ${names})")
  list(JOIN pc_all " " PRT_PC_REQUIRES)
  set(PRT_PC_REQUIRES_PRIVATE "")
  set(PRT_PC_LIBS "")
  set(PRT_PC_LIBS_PRIVATE "")
  set(PRT_PC_CFLAGS "")
  configure_file("${PROJECT_SOURCE_DIR}/cmake/prt.pc.in" "${PROJECT_BINARY_DIR}/pkgconfig/prt.pc" @ONLY)
  install(FILES "${PROJECT_BINARY_DIR}/pkgconfig/prt.pc" DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig)

  # The public headers: every include/prt/*.h belongs to exactly one library.
  get_property(listed GLOBAL PROPERTY PRT_PUBLIC_HEADERS)
  set(dups "${listed}")
  list(REMOVE_DUPLICATES dups)
  list(LENGTH listed n_listed)
  list(LENGTH dups n_dups)
  if(NOT n_listed EQUAL n_dups)
    message(FATAL_ERROR "prt: a public header is listed by two libraries' prt_library(... HEADERS): ${listed}")
  endif()

  set(PRT_CONFIG_COMPONENT_TABLE "${table}")
  set(PRT_INSTALLED_COMPONENTS "${components}")
  configure_package_config_file("${PROJECT_SOURCE_DIR}/cmake/prtConfig.cmake.in"
    "${PROJECT_BINARY_DIR}/cmake/prtConfig.cmake" INSTALL_DESTINATION ${PRT_INSTALL_CMAKEDIR})
  # 0.x: a minor version may change the API.
  write_basic_package_version_file("${PROJECT_BINARY_DIR}/cmake/prtConfigVersion.cmake"
    COMPATIBILITY SameMinorVersion)
  install(FILES "${PROJECT_BINARY_DIR}/cmake/prtConfig.cmake" "${PROJECT_BINARY_DIR}/cmake/prtConfigVersion.cmake"
          DESTINATION ${PRT_INSTALL_CMAKEDIR})
endfunction()
