# Toolchain file: bare-metal ARM Cortex-M4 (no FPU use) with the GNU Arm Embedded toolchain
# (Debian: gcc-arm-none-eabi, libstdc++-arm-none-eabi-newlib, binutils-arm-none-eabi).
#   cmake --preset firmware      (or -DCMAKE_TOOLCHAIN_FILE=cmake/arm-none-eabi.cmake)
set(CMAKE_SYSTEM_NAME Generic)
set(CMAKE_SYSTEM_PROCESSOR arm)

# No OS to run a test executable on: try_compile builds static libraries instead.
set(CMAKE_TRY_COMPILE_TARGET_TYPE STATIC_LIBRARY)

set(FERRULE_ARM_PREFIX "arm-none-eabi-" CACHE STRING "Prefix of the cross tools")
set(CMAKE_C_COMPILER   ${FERRULE_ARM_PREFIX}gcc)
set(CMAKE_CXX_COMPILER ${FERRULE_ARM_PREFIX}g++)
set(CMAKE_ASM_COMPILER ${FERRULE_ARM_PREFIX}gcc)
find_program(CMAKE_OBJCOPY ${FERRULE_ARM_PREFIX}objcopy)
find_program(CMAKE_SIZE    ${FERRULE_ARM_PREFIX}size)
find_program(CMAKE_NM      ${FERRULE_ARM_PREFIX}nm)

set(ferrule_arm_flags
    "-mcpu=cortex-m4 -mthumb -mfloat-abi=soft -Os -ffunction-sections -fdata-sections")
set(CMAKE_C_FLAGS_INIT   "${ferrule_arm_flags}")
set(CMAKE_ASM_FLAGS_INIT "${ferrule_arm_flags}")
set(CMAKE_CXX_FLAGS_INIT "${ferrule_arm_flags} -fno-exceptions -fno-rtti -fno-threadsafe-statics")
# The board brings its start-up code and linker script (examples/firmware/board/): no crt0, and
# no system-call stubs, so anything that needs malloc or stdio fails to link.
set(CMAKE_EXE_LINKER_FLAGS_INIT "-Wl,--gc-sections --specs=nano.specs -nostartfiles")

# Search the host for programs, the target sysroot for everything else.
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)
