# SPDX-License-Identifier: GPL-3.0-or-later
#
# cmake -DNPM=<npm> -DDIR=<package folder> -DSTAMP=<file> -P npm_ci.cmake
#
# `npm ci` in DIR from its package-lock.json when DIR/node_modules is
# missing or older than that lockfile (npm writes
# node_modules/.package-lock.json at every install), then touches STAMP;
# otherwise STAMP is touched only when missing, so that what depends on it
# is built again only after an install. node_modules installed by another
# build tree, or by an engineer's `npm install --save-exact`, counts: a
# second build tree does not delete node_modules under a build using it.
foreach(var NPM DIR STAMP)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "npm_ci.cmake: -D${var}=... is missing")
  endif()
endforeach()

set(lock "${DIR}/package-lock.json")
set(installed "${DIR}/node_modules/.package-lock.json")
# Two build trees building at once share DIR: one installs, the other waits
# and then finds node_modules current.
file(LOCK "${DIR}/.npm-ci.lock" GUARD PROCESS TIMEOUT 900)
if(EXISTS "${installed}" AND NOT "${lock}" IS_NEWER_THAN "${installed}")
  if(NOT EXISTS "${STAMP}")
    file(TOUCH "${STAMP}")
  endif()
  return()
endif()
execute_process(COMMAND "${NPM}" ci --no-audit --no-fund
  WORKING_DIRECTORY "${DIR}" RESULT_VARIABLE result)
if(NOT result EQUAL 0)
  message(FATAL_ERROR "npm ci in ${DIR} failed (${result}): it needs the npm "
    "registry or npm's cache; see its output above")
endif()
file(TOUCH "${STAMP}")
