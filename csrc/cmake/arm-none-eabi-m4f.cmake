# CMake toolchain file: the Cortex-M4F with its single-precision FPU, GNU Arm Embedded (arm-none-eabi-gcc,
# Debian's gcc-arm-none-eabi and libnewlib-arm-none-eabi), bare metal.
#
#   cmake -S <source> -B build-m4f -DCMAKE_TOOLCHAIN_FILE=<this file>
#
# The firmware flags (CMAKE_C_FLAGS_INIT and CMAKE_EXE_LINKER_FLAGS_INIT below, each on one line: the
# repository's size check, tools/check_mcu.sh, and its processor in the loop, tools/pil.py, read
# them from here): -mcpu=cortex-m4 -mthumb -mfpu=fpv4-sp-d16 -mfloat-abi=hard -ffunction-sections
# -fdata-sections; executables linked with newlib-nano and no system calls (--specs=nano.specs
# --specs=nosys.specs) and -Wl,--gc-sections; MinSizeRel (-Os -flto) unless CMAKE_BUILD_TYPE says otherwise. Set ARM_NONE_EABI_PREFIX (e.g.
# /opt/arm/bin/arm-none-eabi-) for a toolchain that is not on PATH. An executable linked this way
# has no linker script for a part: give your part's (-T) and start-up code in your project.
set(CMAKE_SYSTEM_NAME Generic)
set(CMAKE_SYSTEM_PROCESSOR arm)

if(NOT DEFINED ARM_NONE_EABI_PREFIX)
  if(DEFINED ENV{ARM_NONE_EABI_PREFIX})
    set(ARM_NONE_EABI_PREFIX "$ENV{ARM_NONE_EABI_PREFIX}")
  else()
    set(ARM_NONE_EABI_PREFIX "arm-none-eabi-")
  endif()
endif()
set(CMAKE_C_COMPILER "${ARM_NONE_EABI_PREFIX}gcc")
set(CMAKE_ASM_COMPILER "${ARM_NONE_EABI_PREFIX}gcc")
# (gcc-ar and gcc-ranlib: the archive's index of the link-time-optimised objects needs GCC's plugin)
set(CMAKE_AR "${ARM_NONE_EABI_PREFIX}gcc-ar" CACHE FILEPATH "archiver")
set(CMAKE_RANLIB "${ARM_NONE_EABI_PREFIX}gcc-ranlib" CACHE FILEPATH "ranlib")
set(CMAKE_SIZE "${ARM_NONE_EABI_PREFIX}size" CACHE FILEPATH "size")
# (the compiler checks build a static library: a bare-metal link needs the part's start-up code)
set(CMAKE_TRY_COMPILE_TARGET_TYPE STATIC_LIBRARY)

set(CMAKE_C_FLAGS_INIT "-mcpu=cortex-m4 -mthumb -mfpu=fpv4-sp-d16 -mfloat-abi=hard -ffunction-sections -fdata-sections")
set(CMAKE_EXE_LINKER_FLAGS_INIT "--specs=nano.specs --specs=nosys.specs -Wl,--gc-sections")
# (read by linsense's CMakeLists.txt when no build type is given: the size the firmware ships)
set(LINSENSE_DEFAULT_BUILD_TYPE MinSizeRel)
# The shipped build (MinSizeRel): -Os with link-time optimisation, compile and link (CMake passes the
# build type's flags to both). On one line: tools/check_mcu.sh (the 32 kB budget) and tools/pil.py
# (the replay bit for bit) read it. docs/firmware.md, "The cost on the target": the library with the
# EMF estimate and the hand-over is 37.5 kB at -Os alone, 31.0 kB with LTO.
set(CMAKE_C_FLAGS_MINSIZEREL_INIT "-Os -flto -DNDEBUG")

set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)
