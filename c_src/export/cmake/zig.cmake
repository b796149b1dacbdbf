# A CMake toolchain file: cross-compile this export with zig's C compiler (clang with the C
# libraries of every target; PyPI `ziglang`, or a zig on PATH) for another platform.
#
#   cmake -S . -B build-aarch64-linux -DCMAKE_TOOLCHAIN_FILE=cmake/zig.cmake \
#         -DZIG_TARGET=aarch64-linux-gnu.2.17 -DCMAKE_BUILD_TYPE=Release
#   cmake --build build-aarch64-linux
#
# ZIG_TARGET  zig's target, <arch>-<os>[-<abi>] (`zig targets` lists them): aarch64-linux-gnu.2.17,
#             x86_64-linux-gnu.2.17, x86_64-windows-gnu, x86-windows-gnu, aarch64-windows-gnu,
#             x86_64-macos, aarch64-macos (README.md: one command per platform)
# ZIG         the zig executable; by default `zig` on PATH, else the one of the ziglang package
#             of the first python3 (or python) on PATH (python3 -m pip install ziglang)
#
# The compiler is given as a list (zig cc); tested with CMake 3.25 and 4.4.  zig's archiver goes
# through two small scripts in the build directory (zig-tools/), as CMake runs CMAKE_AR and
# CMAKE_RANLIB as one program each.  Windows targets: the MinGW ABI (-gnu), executables with
# their .pdb beside them.

set(ZIG_TARGET "${ZIG_TARGET}" CACHE STRING "zig's target, e.g. aarch64-linux-gnu.2.17")
if(NOT ZIG_TARGET)
  message(FATAL_ERROR "cmake/zig.cmake: ZIG_TARGET is not set; give -DZIG_TARGET=<arch>-<os>[-<abi>], "
                      "e.g. aarch64-linux-gnu.2.17, x86_64-windows-gnu, aarch64-macos")
endif()
string(REPLACE "-" ";" _zig_parts "${ZIG_TARGET}")
list(LENGTH _zig_parts _zig_n)
if(_zig_n LESS 2)
  message(FATAL_ERROR "cmake/zig.cmake: ZIG_TARGET '${ZIG_TARGET}' is not <arch>-<os>[-<abi>]")
endif()
list(GET _zig_parts 0 _zig_arch)
list(GET _zig_parts 1 _zig_os)
string(REGEX REPLACE "\\..*" "" _zig_os "${_zig_os}") # macos.13.0 -> macos
if(_zig_os STREQUAL "linux")
  set(CMAKE_SYSTEM_NAME Linux)
elseif(_zig_os STREQUAL "windows")
  set(CMAKE_SYSTEM_NAME Windows)
elseif(_zig_os STREQUAL "macos")
  set(CMAKE_SYSTEM_NAME Darwin)
else()
  message(FATAL_ERROR "cmake/zig.cmake: ZIG_TARGET '${ZIG_TARGET}': operating system '${_zig_os}' "
                      "is none of linux, windows, macos")
endif()
set(CMAKE_SYSTEM_PROCESSOR "${_zig_arch}")

if(NOT ZIG)
  find_program(_zig_on_path zig)
  if(_zig_on_path)
    set(_zig "${_zig_on_path}")
  else()
    find_program(_zig_python NAMES python3 python)
    if(_zig_python)
      execute_process(COMMAND "${_zig_python}" -c
                        "import os, ziglang; print(os.path.dirname(ziglang.__file__))"
                      OUTPUT_VARIABLE _zig_dir OUTPUT_STRIP_TRAILING_WHITESPACE
                      RESULT_VARIABLE _zig_status ERROR_QUIET)
      if(_zig_status EQUAL 0)
        find_program(_zig NAMES zig PATHS "${_zig_dir}" NO_DEFAULT_PATH)
      endif()
    endif()
  endif()
  if(NOT _zig)
    message(FATAL_ERROR "cmake/zig.cmake: no zig: neither `zig` on PATH nor Python's ziglang "
                        "package (python3 -m pip install ziglang); or give -DZIG=<zig executable>")
  endif()
  set(ZIG "${_zig}" CACHE FILEPATH "the zig executable")
endif()
# the try_compile projects CMake makes read this file again, with these
list(APPEND CMAKE_TRY_COMPILE_PLATFORM_VARIABLES ZIG_TARGET ZIG)

set(CMAKE_C_COMPILER "${ZIG}" cc)
set(CMAKE_C_COMPILER_TARGET "${ZIG_TARGET}")
# zig's archiver (llvm-ar, llvm-ranlib: every object format) through two small scripts, since
# CMake runs CMAKE_AR and CMAKE_RANLIB as one program each (Windows' link rules call the archiver
# directly, as `<CMAKE_AR> qc ...`)
set(_zig_tools "${CMAKE_BINARY_DIR}/zig-tools")
foreach(_zig_tool ar ranlib)
  if(CMAKE_HOST_WIN32)
    set(_zig_script "${_zig_tools}/zig-${_zig_tool}.cmd")
    file(WRITE "${_zig_script}" "@\"${ZIG}\" ${_zig_tool} %*\r\n")
  else() # written, then copied to be executable
    set(_zig_script "${_zig_tools}/zig-${_zig_tool}")
    file(WRITE "${_zig_tools}/text/zig-${_zig_tool}" "#!/bin/sh\nexec \"${ZIG}\" ${_zig_tool} \"$@\"\n")
    file(COPY "${_zig_tools}/text/zig-${_zig_tool}" DESTINATION "${_zig_tools}"
         FILE_PERMISSIONS OWNER_READ OWNER_WRITE OWNER_EXECUTE GROUP_READ GROUP_EXECUTE WORLD_READ
                          WORLD_EXECUTE)
  endif()
  string(TOUPPER "${_zig_tool}" _zig_var)
  set(CMAKE_${_zig_var} "${_zig_script}" CACHE FILEPATH "zig's ${_zig_tool}" FORCE)
endforeach()
# the target's libraries come from zig, never from this machine
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)
