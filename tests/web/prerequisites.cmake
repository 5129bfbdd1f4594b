# SPDX-License-Identifier: GPL-3.0-or-later
#
# cmake -DCHROMIUM=... -DCONSOLE=... -DPACKAGES=... -P prerequisites.cmake
# Fails naming what the browser tests lack and how to get it.
set(missing "")
if(NOT EXISTS "${CHROMIUM}")
  string(APPEND missing "\n  the browser ${CHROMIUM}: install Debian's chromium "
    "(deploy/setup-deps.sh does)")
endif()
if(NOT EXISTS "${CONSOLE}")
  string(APPEND missing "\n  the built console ${CONSOLE}: build the web_console "
    "target")
endif()
if(NOT EXISTS "${PACKAGES}")
  string(APPEND missing "\n  the tests' npm packages (${PACKAGES}): build the "
    "web_test_deps target (npm ci in tests/web)")
endif()
if(missing)
  message(FATAL_ERROR "The console's browser tests cannot run; missing:${missing}")
endif()
message(STATUS "browser tests: ${CHROMIUM}, ${CONSOLE}, playwright-core present")
