# Cross build for arm64 (aarch64) with Debian's cross compilers (crossbuild-essential-arm64) against a
# sysroot of Debian's arm64 packages. scripts/cross arm64 makes the sysroot and passes its path as
# VOG_SYSROOT; tests run under qemu-user-static through CMAKE_CROSSCOMPILING_EMULATOR.
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(CMAKE_LIBRARY_ARCHITECTURE aarch64-linux-gnu)
set(VOG_DEB_ARCHITECTURE arm64)
set(CMAKE_C_COMPILER aarch64-linux-gnu-gcc)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)

# try_compile projects see it too.
list(APPEND CMAKE_TRY_COMPILE_PLATFORM_VARIABLES VOG_SYSROOT)
if(NOT VOG_SYSROOT)
  message(FATAL_ERROR "VOG_SYSROOT is not set: scripts/cross arm64 makes the sysroot and sets it")
endif()
set(CMAKE_SYSROOT ${VOG_SYSROOT})
set(CMAKE_FIND_ROOT_PATH ${VOG_SYSROOT})
# Programs (protoc) from the build machine; libraries, headers and CMake packages from the sysroot.
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)

# The libraries' own dependencies (BLAS under Ceres, ...) are found through the sysroot's multiarch folders.
string(APPEND CMAKE_EXE_LINKER_FLAGS_INIT
  " -Wl,-rpath-link,${VOG_SYSROOT}/usr/lib/aarch64-linux-gnu -Wl,-rpath-link,${VOG_SYSROOT}/lib/aarch64-linux-gnu")
string(APPEND CMAKE_SHARED_LINKER_FLAGS_INIT
  " -Wl,-rpath-link,${VOG_SYSROOT}/usr/lib/aarch64-linux-gnu -Wl,-rpath-link,${VOG_SYSROOT}/lib/aarch64-linux-gnu")

set(ENV{PKG_CONFIG_SYSROOT_DIR} ${VOG_SYSROOT})
set(ENV{PKG_CONFIG_LIBDIR} "${VOG_SYSROOT}/usr/lib/aarch64-linux-gnu/pkgconfig:${VOG_SYSROOT}/usr/share/pkgconfig")
set(ENV{PKG_CONFIG_PATH} "")

set(CMAKE_CROSSCOMPILING_EMULATOR qemu-aarch64-static -L ${VOG_SYSROOT})
