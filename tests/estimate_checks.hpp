#pragma once
// Shared by the table tests: a fitted quantity's 95 % interval holds the truth.

#include <gtest/gtest.h>

#include <cmath>

#include "ref/tracking/response_fit.hpp"

namespace rubref::testing {

// An estimate's 95 % interval holds the truth, widened by `slack` of the truth (the interval is
// the linearised one; the truth sits in it 95 % of the time, the slack covers the nonlinearity).
inline void expect_within(const estimate& e, double truth_value, double slack, const char* what) {
  EXPECT_LE(e.lo - slack * std::abs(truth_value), truth_value) << what << " " << e.value << " [" << e.lo << ", " << e.hi << "]";
  EXPECT_GE(e.hi + slack * std::abs(truth_value), truth_value) << what << " " << e.value << " [" << e.lo << ", " << e.hi << "]";
}

}  // namespace rubref::testing
