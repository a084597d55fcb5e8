# CMake toolchain file: cross-compile for 64-bit ARM Linux (aarch64) with Debian's cross
# toolchain (apt-get install g++-aarch64-linux-gnu). The NEON kernels are compiled in
# automatically (NEON is mandatory on aarch64). Run the results on an ARM board, or on x86
# under qemu-user (apt-get install qemu-user):
#   cmake -S . -B build-arm -DCMAKE_TOOLCHAIN_FILE=cmake/aarch64-linux-gnu.cmake ...
#   QEMU_LD_PREFIX=/usr/aarch64-linux-gnu qemu-aarch64 build-arm/tests/test_gemm
# A full configure needs aarch64 builds of OpenCV/Eigen (Debian multiarch: libopencv-dev:arm64
# ...); .ci/steps/50_aarch64.sh builds only the DenseNet tests, which need neither.
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(CMAKE_C_COMPILER aarch64-linux-gnu-gcc)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)
set(CMAKE_FIND_ROOT_PATH /usr/aarch64-linux-gnu /usr/lib/aarch64-linux-gnu)
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE BOTH)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)
set(CMAKE_LIBRARY_ARCHITECTURE aarch64-linux-gnu)
find_program(SHADOWSENSE_QEMU_AARCH64 qemu-aarch64)
if(SHADOWSENSE_QEMU_AARCH64)
  set(CMAKE_CROSSCOMPILING_EMULATOR ${SHADOWSENSE_QEMU_AARCH64} -L /usr/aarch64-linux-gnu)
endif()
