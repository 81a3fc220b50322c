#pragma once
// Model validity by residual correlation tests (Billings and Voon 1986): for an adequate model
// the residual e is white and unrelated to the inputs, here z and z_dot:
//   phi_ee(tau) = 0 (tau != 0), phi_ue(tau) = 0, phi_u2'e(tau) = 0, phi_u2'e2(tau) = 0,
// with u2' = u^2 - mean(u^2). Correlations pair samples within one contact episode only, and
// are compared with the 95 % band +-1.96 / sqrt(N).

#include <string>
#include <vector>

namespace rubref {

struct correlation_test {
  std::string name;             // e.g. "phi_ee", "phi_z_e"
  std::vector<int> lags;
  std::vector<double> values;
  double band = 0.0;            // 1.96 / sqrt(N)
  double max_abs = 0.0;
  double outside_fraction = 0.0;
  bool pass = false;            // at most 5 % of the lags outside the band
};

// Series are grouped by contact episode: e[k], z[k], zd[k] hold episode k's samples in time order.
std::vector<correlation_test> residual_tests(const std::vector<std::vector<double>>& e,
                                             const std::vector<std::vector<double>>& z,
                                             const std::vector<std::vector<double>>& zd, int max_lag);

}  // namespace rubref
