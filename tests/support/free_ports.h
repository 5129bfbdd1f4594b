// SPDX-License-Identifier: GPL-3.0-or-later
//
// Loopback ports for a process a test starts later to bind (Slurm's
// daemons, a network camera that comes up after the daemon).
#ifndef HDRSTEREO_TESTS_SUPPORT_FREE_PORTS_H_
#define HDRSTEREO_TESTS_SUPPORT_FREE_PORTS_H_

#include <vector>

#include "absl/status/statusor.h"

namespace hdrstereo::testing {

// `count` distinct ports free now on 127.0.0.1 (held while choosing, so
// they differ), drawn below the kernel's ephemeral range: a port the
// kernel chose (bind to port 0) is also the next it gives another test's
// outgoing connection, which may then hold it when the port's owner binds
// it. Outside that range only a process that binds that very port can
// take it. The kernel's choice for a port when 100 draws found none free.
absl::StatusOr<std::vector<int>> FreeLoopbackPorts(int count);

}  // namespace hdrstereo::testing

#endif  // HDRSTEREO_TESTS_SUPPORT_FREE_PORTS_H_
