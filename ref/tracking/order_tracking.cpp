#include "ref/tracking/order_tracking.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <Eigen/Dense>

#include "ref/identification/dwells.hpp"

namespace rubref {

order_table track_orders(const record& r, const std::string& source) {
  order_table t;
  t.source = source;
  t.conventions = "tracked by rubref from " + source + ": metres, 0-peak, lead, keyphasor at theta = 0";
  std::vector<dwell> dwells = split_dwells(r, source);
  constexpr int kOrders = 2;
  // The least squares carry orders up to 8: a rubbing orbit's higher harmonics are not orthogonal
  // to the 1X over a dwell that is not a whole number of revolutions, and left out they leak into it.
  constexpr int kFitted = 8;
  for (const char* probe : {"x", "y"})
    for (int k = 1; k <= kOrders; ++k) {
      tracked_order o;
      o.probe = probe, o.order = k;
      o.probe_angle = std::string(probe) == "x" ? 0.0 : std::numbers::pi / 2.0;
      o.amplitude_column = std::string(probe) + "_amp_" + std::to_string(k) + "x_m";
      o.phase_column = std::string(probe) + "_phase_" + std::to_string(k) + "x_rad";
      t.orders.push_back(o);
    }
  for (auto& d : dwells) {
    align_by_keyphasor(d, t.notes);
    const double w = d.omega();
    // s(t) = a0 + sum_k (a_k cos k w t + b_k sin k w t) = a0 + sum_k Re((a_k - j b_k) e^{j k w t}).
    Eigen::MatrixXd basis(static_cast<Eigen::Index>(d.size()), 1 + 2 * kFitted);
    for (std::size_t i = 0; i < d.size(); ++i) {
      const auto row = static_cast<Eigen::Index>(i);
      basis(row, 0) = 1.0;
      for (int k = 1; k <= kFitted; ++k) basis(row, 2 * k - 1) = std::cos(k * w * d.t[i]), basis(row, 2 * k) = std::sin(k * w * d.t[i]);
    }
    const auto qr = basis.colPivHouseholderQr();
    const Eigen::VectorXd cx = qr.solve(Eigen::Map<const Eigen::VectorXd>(d.x.data(), static_cast<Eigen::Index>(d.size())));
    const Eigen::VectorXd cy = qr.solve(Eigen::Map<const Eigen::VectorXd>(d.y.data(), static_cast<Eigen::Index>(d.size())));
    t.rpm.push_back(d.rpm);
    t.line.push_back(t.rpm.size());  // the dwell's place in time, as a file's line is the row's place in it
    std::size_t o = 0;
    for (const Eigen::VectorXd* c : {&cx, &cy})
      for (int k = 1; k <= kOrders; ++k) t.orders[o++].vector.emplace_back((*c)(2 * k - 1), -(*c)(2 * k));
  }
  // Rows in rising speed, as a table read from a file has them.
  std::vector<std::size_t> order(t.rows());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return t.rpm[a] < t.rpm[b]; });
  order_table sorted = t;
  for (std::size_t i = 0; i < order.size(); ++i) {
    sorted.rpm[i] = t.rpm[order[i]], sorted.line[i] = t.line[order[i]];
    for (std::size_t o = 0; o < t.orders.size(); ++o) sorted.orders[o].vector[i] = t.orders[o].vector[order[i]];
  }
  return sorted;
}

}  // namespace rubref
