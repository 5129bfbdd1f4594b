// SPDX-License-Identifier: GPL-3.0-or-later
//
// Gphoto2Api over the real libgphoto2 (one GPContext and one Camera).
#ifndef HDRSTEREO_HARDWARE_GPHOTO2_LIBGPHOTO2_API_H_
#define HDRSTEREO_HARDWARE_GPHOTO2_LIBGPHOTO2_API_H_

#include <memory>

#include "hardware/gphoto2/gphoto2_api.h"

namespace hdrstereo::gphoto2 {

// Camera drivers (camlibs) and port drivers (iolibs) are loaded from the
// directories libgphoto2 was built with, unless the CAMLIBS / IOLIBS
// environment variables name others.
std::unique_ptr<Gphoto2Api> NewLibgphoto2Api();

}  // namespace hdrstereo::gphoto2

#endif  // HDRSTEREO_HARDWARE_GPHOTO2_LIBGPHOTO2_API_H_
