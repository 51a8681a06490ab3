"""linsense.firmware: the C controller library as a firmware project takes it.

:func:`linsense.firmware.project.firmware_files` (``linsense firmware export``) writes a folder that
builds with CMake alone, on the host and for a Cortex-M4F: the library's sources and headers (those
the wheel ships, :func:`linsense.get_include`), the drive's configuration designed for a motor
(``ls_cfg_<name>.h``, what ``linsense tune --format c`` writes), an example ``main.c`` with a
synthetic motor of the same data and a CMakeLists.txt (docs/firmware.md).
:func:`linsense.firmware.verified_export.export_firmware` is the command: those files for a drive
the quick certificate passes (``linsense firmware export``); :mod:`linsense.firmware.pil` closes the
loop through the Cortex-M4F under QEMU.
"""
