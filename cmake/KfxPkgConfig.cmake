# kfx.pc for pkg-config users (`pkg-config --cflags --libs kfx`), installed to LIBDIR/pkgconfig.
# A static libkfx lists SLICOT and BLAS/LAPACK in Libs (pkg-config users rarely pass --static); a shared
# one in Libs.private. Eigen comes through Requires: eigen3. kfx needs C++17: compilers whose default is
# older (clang 14, g++ < 11) need -std=c++17 from the user (Cflags does not force a standard).
set(kfx_pc_deps "${KFX_SLICOT_LIBRARY}")
foreach(lib IN LISTS LAPACK_LIBRARIES BLAS_LIBRARIES)
  if(NOT lib IN_LIST kfx_pc_deps)
    list(APPEND kfx_pc_deps "${lib}")
  endif()
endforeach()
list(JOIN kfx_pc_deps " " kfx_pc_deps)
if(KFX_LIBRARY_TYPE STREQUAL "SHARED_LIBRARY")
  set(KFX_PC_LIBS "-L\${libdir} -lkfx")
  set(KFX_PC_LIBS_PRIVATE "${kfx_pc_deps}")
else()
  set(KFX_PC_LIBS "-L\${libdir} -lkfx ${kfx_pc_deps}")
  set(KFX_PC_LIBS_PRIVATE "")
endif()
foreach(dir LIBDIR INCLUDEDIR)  # KFX_PC_LIBDIR, KFX_PC_INCLUDEDIR: relative to ${prefix} when they can be
  if(IS_ABSOLUTE "${CMAKE_INSTALL_${dir}}")
    set(KFX_PC_${dir} "${CMAKE_INSTALL_${dir}}")
  else()
    set(KFX_PC_${dir} "\${prefix}/${CMAKE_INSTALL_${dir}}")
  endif()
endforeach()
set(KFX_PC_PREFIX "@KFX_PC_PREFIX@")  # filled in at install time
configure_file(${CMAKE_CURRENT_LIST_DIR}/kfx.pc.in ${PROJECT_BINARY_DIR}/kfx.pc.in.configured @ONLY)
# The prefix is the one of `cmake --install --prefix P`, not only CMAKE_INSTALL_PREFIX: written at install.
install(CODE "
  file(READ \"${PROJECT_BINARY_DIR}/kfx.pc.in.configured\" pc)
  string(REPLACE \"@KFX_PC_PREFIX@\" \"\${CMAKE_INSTALL_PREFIX}\" pc \"\${pc}\")
  file(WRITE \"${PROJECT_BINARY_DIR}/kfx.pc\" \"\${pc}\")
")
install(FILES ${PROJECT_BINARY_DIR}/kfx.pc DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig)
