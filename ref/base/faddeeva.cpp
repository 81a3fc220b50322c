#include "ref/base/faddeeva.hpp"

// libcerf's C interface takes and returns C99 complex numbers, which C++ has as the GNU
// extension `__complex__` (GCC and clang alike, layout-compatible with std::complex<double>).
#if defined(__clang__)
#pragma clang diagnostic ignored "-Wc99-extensions"
#endif
extern "C" {
__complex__ double w_of_z(__complex__ double z);
}

namespace rubref {

std::complex<double> faddeeva(std::complex<double> z) {
  __complex__ double a;
  __real__ a = z.real();
  __imag__ a = z.imag();
  const __complex__ double w = w_of_z(a);
  return {__real__ w, __imag__ w};
}

}  // namespace rubref
