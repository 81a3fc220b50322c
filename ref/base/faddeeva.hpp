#pragma once
// The Faddeeva function w(z) = exp(-z^2) erfc(-i z), the scaled complex error function, from
// libcerf (Debian's libcerf-dev; S. G. Johnson's algorithm, relative accuracy about 1e-13 over the
// complex plane). A swept run-up's response through a critical speed is closed form in it
// (ref/tracking/swept_response.hpp). |w(z)| <= 1 in the upper half-plane; below it w grows as
// exp(-z^2), so callers reflect (w(-z) = 2 exp(-z^2) - w(z)) and keep the growing part apart.

#include <complex>

namespace rubref {

std::complex<double> faddeeva(std::complex<double> z);

}  // namespace rubref
