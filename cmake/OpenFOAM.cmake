# Locate OpenFOAM v1912 for building the OpenFOAM-side code.
#
# Headers: TQ_OPENFOAM_SRC (set by scripts/bootstrap.sh to the unpacked Debian source package),
#          or $FOAM_SRC / $WM_PROJECT_DIR/src of a full install.
# Libraries: TQ_OPENFOAM_LIBDIR, or $FOAM_LIBBIN of a full install, or Debian's /usr/lib.
# Defines the interface target OpenFOAM::OpenFOAM carrying OpenFOAM's own compile flags.
set(TQ_OPENFOAM_SRC "" CACHE PATH "OpenFOAM src/ folder with lnInclude/ subfolders")
set(TQ_OPENFOAM_LIBDIR "" CACHE PATH "folder holding libOpenFOAM.so")

if(NOT TQ_OPENFOAM_SRC)
  if(DEFINED ENV{FOAM_SRC})
    set(TQ_OPENFOAM_SRC "$ENV{FOAM_SRC}")
  elseif(DEFINED ENV{WM_PROJECT_DIR})
    set(TQ_OPENFOAM_SRC "$ENV{WM_PROJECT_DIR}/src")
  else()
    set(TQ_OPENFOAM_SRC "$ENV{HOME}/.cache/tunnelquake/openfoam-1912/src")
  endif()
endif()
if(NOT EXISTS "${TQ_OPENFOAM_SRC}/finiteVolume/lnInclude/fvCFD.H")
  message(FATAL_ERROR "OpenFOAM headers not found in '${TQ_OPENFOAM_SRC}' "
    "(expected finiteVolume/lnInclude/fvCFD.H). Run scripts/bootstrap.sh, or pass "
    "-DTQ_OPENFOAM_SRC=<OpenFOAM>/src, or configure with -DTQ_BUILD_OPENFOAM=OFF.")
endif()

if(NOT TQ_OPENFOAM_LIBDIR)
  if(DEFINED ENV{FOAM_LIBBIN})
    set(TQ_OPENFOAM_LIBDIR "$ENV{FOAM_LIBBIN}")
  else()
    set(TQ_OPENFOAM_LIBDIR "/usr/lib")
  endif()
endif()
find_library(TQ_OF_LIB_OpenFOAM OpenFOAM PATHS "${TQ_OPENFOAM_LIBDIR}" NO_DEFAULT_PATH)
if(NOT TQ_OF_LIB_OpenFOAM)
  message(FATAL_ERROR "libOpenFOAM.so not found in '${TQ_OPENFOAM_LIBDIR}'. Install Debian's "
    "'openfoam' package (scripts/bootstrap.sh does) or pass -DTQ_OPENFOAM_LIBDIR=<dir>.")
endif()
message(STATUS "OpenFOAM headers: ${TQ_OPENFOAM_SRC}")
message(STATUS "OpenFOAM libraries: ${TQ_OPENFOAM_LIBDIR}")

add_library(OpenFOAM::OpenFOAM INTERFACE IMPORTED)
# OpenFOAM's own flags (wmake/rules/linux64Gcc): double precision, 32-bit labels.
target_compile_definitions(OpenFOAM::OpenFOAM INTERFACE
  WM_DP WM_LABEL_SIZE=32 NoRepository linux64 WM_ARCH_OPTION=64)
target_compile_options(OpenFOAM::OpenFOAM INTERFACE
  -m64 -ftemplate-depth-100 -Wno-old-style-cast -Wno-unused-parameter -Wno-deprecated-copy
  -Wno-class-memaccess)
target_include_directories(OpenFOAM::OpenFOAM SYSTEM INTERFACE
  "${TQ_OPENFOAM_SRC}/OpenFOAM/lnInclude"
  "${TQ_OPENFOAM_SRC}/OSspecific/POSIX/lnInclude"
  "${TQ_OPENFOAM_SRC}/finiteVolume/lnInclude"
  "${TQ_OPENFOAM_SRC}/meshTools/lnInclude"
  "${TQ_OPENFOAM_SRC}/dynamicMesh/lnInclude"
  "${TQ_OPENFOAM_SRC}/dynamicFvMesh/lnInclude"
  "${TQ_OPENFOAM_SRC}/fileFormats/lnInclude"
  "${TQ_OPENFOAM_SRC}/surfMesh/lnInclude"
  "${TQ_OPENFOAM_SRC}/functionObjects/forces/lnInclude"
  "${TQ_OPENFOAM_SRC}/transportModels"
  "${TQ_OPENFOAM_SRC}/transportModels/incompressible/lnInclude"
  "${TQ_OPENFOAM_SRC}/TurbulenceModels/turbulenceModels/lnInclude"
  "${TQ_OPENFOAM_SRC}/TurbulenceModels/incompressible/lnInclude"
  "${TQ_OPENFOAM_SRC}/TurbulenceModels/compressible/lnInclude"
  "${TQ_OPENFOAM_SRC}/thermophysicalModels/basic/lnInclude")
foreach(lib OpenFOAM finiteVolume meshTools dynamicMesh dynamicFvMesh fileFormats surfMesh)
  find_library(TQ_OF_LIB_${lib} ${lib} PATHS "${TQ_OPENFOAM_LIBDIR}" NO_DEFAULT_PATH REQUIRED)
  target_link_libraries(OpenFOAM::OpenFOAM INTERFACE "${TQ_OF_LIB_${lib}}")
endforeach()
target_link_libraries(OpenFOAM::OpenFOAM INTERFACE dl m)

# Where Debian's OpenFOAM binaries find their etc/ (its etc/bashrc does not work as shipped).
if(EXISTS "/usr/share/openfoam/etc/controlDict")
  set(TQ_OPENFOAM_PROJECT_DIR "/usr/share/openfoam" CACHE PATH "WM_PROJECT_DIR for running OpenFOAM")
endif()
