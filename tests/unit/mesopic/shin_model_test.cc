// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/mesopic/shin_model.h"

#include <gtest/gtest.h>

namespace hdrstereo::mesopic {
namespace {
TEST(ShinModelTest, Placeholder) { EXPECT_EQ(kKwPrime, 78.4); }
}  // namespace
}  // namespace hdrstereo::mesopic
