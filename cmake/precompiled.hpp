#pragma once
// The headers nearly every file of the library and its tests parses, compiled once per build as a
// precompiled header (option RUBREF_PRECOMPILED_HEADERS; docs/robustness.md, "CI time"). Headers
// from outside the project, and ref/integrate/odeint.hpp, which only wraps one of them.
#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <filesystem>
#include <functional>
#include <limits>
#include <map>
#include <numbers>
#include <optional>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Dense>
#include "ref/integrate/odeint.hpp"
#include <boost/math/distributions/chi_squared.hpp>
#include <nlohmann/json.hpp>
