#include "ref/tracking/swept_response.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include "ref/base/errors.hpp"
#include "ref/base/faddeeva.hpp"
#include "ref/base/number_text.hpp"
#include "ref/base/parallel.hpp"

namespace rubref {

namespace {

using cplx = std::complex<double>;
constexpr cplx kJ(0.0, 1.0);
constexpr double kPi = std::numbers::pi;
const double kSqrtPi = std::sqrt(kPi);

// A mode basis worse conditioned than this (a mode at critical damping, where two eigenvectors
// merge) loses more digits than a table's noise allows: refused, not used.
constexpr double kMaxModalCondition = 1e8;

// Gauss-Legendre rules on [-1, 1] (Golub-Welsch), made once. A block's integrand turns by up to
// its phase span Phi (rad) over the block; n nodes integrate e^{j phi} to round-off once n exceeds
// about e Phi / 8 (the rule's error, (Phi / 4)^{2n} / (2n)!, falls super-exponentially beyond:
// 1e-20 at Phi = 4 pi, one revolution's e^{-2j theta}, with 16 nodes), so n >= 0.35 Phi + 8.
struct gauss_rule {
  std::vector<double> node, weight;
};
gauss_rule make_rule(int n) {
  Eigen::MatrixXd jacobi = Eigen::MatrixXd::Zero(n, n);
  for (int k = 1; k < n; ++k) {
    const double b = k / std::sqrt(4.0 * k * k - 1.0);
    jacobi(k, k - 1) = jacobi(k - 1, k) = b;
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(jacobi);
  gauss_rule r;
  for (int i = 0; i < n; ++i) {
    r.node.push_back(es.eigenvalues()(i));
    r.weight.push_back(2.0 * es.eigenvectors()(0, i) * es.eigenvectors()(0, i));
  }
  return r;
}
constexpr int kRuleSizes[] = {16, 24, 32, 48, 64};
const gauss_rule& rule_for(double phase_span) {
  static const std::vector<gauss_rule> rules = [] {
    std::vector<gauss_rule> out;
    for (const int n : kRuleSizes) out.push_back(make_rule(n));
    return out;
  }();
  const double need = 0.35 * phase_span + 8.0;
  for (std::size_t i = 0; i < std::size(kRuleSizes); ++i)
    if (kRuleSizes[i] >= need) return rules[i];
  return rules.back();  // callers split longer spans into panels of at most kMaxPanelPhase
}
constexpr double kMaxPanelPhase = 150.0;  // 0.35 * 150 + 8 = 60.5 <= 64 nodes

// The fastest phase rate of a block's integrands: S against e^{-2j theta} (2 Omega), a ringing
// mode against e^{-j theta} (Omega + |Im lambda|).
double phase_rate(const swept_response& s, double omega_hi) {
  double w = 0.0;
  for (const auto& m : s.modes()) w = std::max(w, std::abs(m.lambda.imag()));
  return std::max(2.0 * omega_hi, omega_hi + w);
}

}  // namespace

swept_response::swept_response(const linear_rotor& r, double omega_start, double alpha) : omega_start_(omega_start), alpha_(alpha) {
  if (!(alpha != 0.0) || !std::isfinite(alpha)) throw input_error("swept_response: the angular acceleration must be finite and not 0");
  Eigen::Matrix4d a = Eigen::Matrix4d::Zero();
  a(0, 2) = a(1, 3) = 1.0;
  a(2, 0) = -r.wx * r.wx, a(2, 1) = -r.kxy, a(2, 2) = -2.0 * r.zx * r.wx;
  a(3, 0) = -r.kyx, a(3, 1) = -r.wy * r.wy, a(3, 3) = -2.0 * r.zy * r.wy;
  const Eigen::EigenSolver<Eigen::Matrix4d> es(a);
  if (es.info() != Eigen::Success) throw numerical_error("swept_response: the rotor's modes could not be computed");
  const Eigen::Matrix4cd v = es.eigenvectors();
  const Eigen::Matrix4cd vinv = v.inverse();
  const double condition = v.norm() * vinv.norm();
  if (!std::isfinite(condition) || condition > kMaxModalCondition)
    throw numerical_error("swept_response: the rotor's modes are ill-conditioned (condition " + format_digits(condition) +
                          "; a mode at critical damping?)");
  // An unstable rotor (a cross-coupling past its onset) has no response a sweep could carry: its
  // free modes grow without bound.
  for (int k = 0; k < 4; ++k)
    if (!(es.eigenvalues()(k).real() < 0.0)) throw numerical_error("swept_response: the rotor is unstable (a mode with growth rate " + format_digits(es.eigenvalues()(k).real()) + " 1/s)");
  c_ = std::sqrt(cplx(0.0, -0.5 * alpha));
  const Eigen::Vector4cd d_unbalance(0.0, 0.0, 1.0, -kJ), d_bow(0.0, 0.0, r.wx * r.wx, -kJ * (r.wy * r.wy));
  const Eigen::Vector4cd p_u = vinv * d_unbalance, p_b = vinv * d_bow;
  for (int k = 0; k < 4; ++k) {
    mode m;
    m.lambda = es.eigenvalues()(k);
    m.p_unbalance = p_u(k), m.p_bow = p_b(k);
    m.x0 = -(kJ * omega_start - m.lambda) / (2.0 * c_);
    m.displacement = v.block<2, 1>(0, k);
    // Re x_k grows with t (Re c > 0 for either sign of alpha): one crossing at most.
    m.crossing = -m.x0.real() / c_.real();
    if (m.crossing > 0.0) {
      // Relative to the shaft's angle there, e^{j theta(t*)}: a phase a read takes from its own
      // block (the absolute angle of a slow sweep runs to 1e12 rad, whose last digits are noise).
      const cplx x = m.x0 + c_ * m.crossing;
      const cplx ring = kSqrtPi / c_ * std::exp(x * x);
      m.ring_unbalance = -m.lambda * m.lambda * m.p_unbalance * ring;
      m.ring_bow = m.p_bow * ring;
      m.crossing_speed = speed(m.crossing), m.crossing_angle = angle(m.crossing);
    }
    modes_.push_back(m);
  }
}

std::array<cplx, 2> swept_response::adiabatic_both(std::size_t k, double t) const {
  const mode& m = modes_[k];
  const cplx x = m.x0 + c_ * t;
  // The bounded branch: w(jx) in the upper half-plane (Re x >= 0), else -w(-jx) (the difference,
  // 2 e^{x^2} e^{j theta}, a free mode, is the ringing's).
  const cplx w = x.real() >= 0.0 ? faddeeva(kJ * x) : -faddeeva(-kJ * x);
  const cplx g = kSqrtPi / (2.0 * c_) * w;
  return {m.p_unbalance * (-kJ * speed(t) - m.lambda + m.lambda * m.lambda * g), -m.p_bow * g};
}

cplx swept_response::adiabatic(std::size_t k, double t, swept_forcing f) const { return adiabatic_both(k, t)[f == swept_forcing::bow ? 1 : 0]; }

cplx swept_response::ringing(std::size_t k, double t, swept_forcing f) const {
  const mode& m = modes_[k];
  if (!(m.crossing > 0.0) || t <= m.crossing) return 0.0;
  return (f == swept_forcing::bow ? m.ring_bow : m.ring_unbalance) * std::exp(kJ * m.crossing_angle + m.lambda * (t - m.crossing));
}

Eigen::Vector4cd swept_response::state(double t, swept_forcing f) const {
  // z = V eta: a mode's velocity rows are lambda_k times its displacement rows.
  Eigen::Vector4cd z = Eigen::Vector4cd::Zero();
  const cplx turn = std::polar(1.0, angle(t));
  for (std::size_t k = 0; k < modes_.size(); ++k) {
    const cplx eta = turn * adiabatic(k, t, f) + ringing(k, t, f);
    z.head<2>() += modes_[k].displacement * eta;
    z.tail<2>() += modes_[k].lambda * modes_[k].displacement * eta;
  }
  return z;
}

namespace {

// A probe's reading of one forcing: its weights gamma_k on the modes' displacements.
struct channel {
  std::vector<cplx> gamma;
  swept_forcing forcing;
};

// Each channel's block integrals A = integral rho e^{-j theta} Omega dt and B = integral conj(rho)
// e^{-j theta} Omega dt over the block t_mid +- half (speed omega_mid at its middle), rho =
// sum_k gamma_k eta_k, with the channels' adiabatic sums sum_k gamma_k S_k(t) given by
// `adiabatic_sums(t, out)` (exact or interpolated); per channel the columns per unit Re and Im of
// the amplitude: (A + B, j (A - B)) / (2 pi N). The channels share the nodes (one angle, one
// look-up of the sums per node). The shaft's angle is taken from the block's first keyphasor
// pulse, as the instrument takes it (a block is whole revolutions from a pulse), and a ringing
// mode's phase from its crossing by speeds: never an absolute angle (a slow sweep's runs to
// 1e12 rad, and its last digits would make the read jitter with the rate).
// The read's scratch space, made once per run of rows (not per row: a table has thousands).
struct block_workspace {
  struct ring_term {
    std::size_t channel;
    cplx lambda, ring;
    double since_mid, crossing_speed;
  };
  std::vector<cplx> sums, a, b, ring_a, ring_b;
  std::vector<ring_term> ringing;
};

template <class AdiabaticSums>
std::vector<std::array<cplx, 2>> block_read(const swept_response& s, double t_mid, double half, double omega_mid, double revolutions,
                                            const std::vector<channel>& channels, AdiabaticSums& adiabatic_sums, block_workspace& w) {
  const double alpha = s.alpha();
  const double span = phase_rate(s, omega_mid + std::abs(alpha) * half) * 2.0 * half;
  const int panels = std::max(1, static_cast<int>(std::ceil(span / kMaxPanelPhase)));
  const gauss_rule& rule = rule_for(span / panels);
  const double h = 2.0 * half / panels;
  const std::size_t n = channels.size();
  std::vector<cplx>& sums = w.sums;
  sums.assign(n, 0.0);
  // The modes still ringing over the block, per channel: a mode's ringing decays from its
  // crossing on, and one below 1e-17 of the adiabatic response at the block's start adds nothing a
  // double can hold. Its time since the crossing from the speeds: (omega_mid - Omega(t*)) / alpha.
  adiabatic_sums(t_mid - half, sums);
  std::vector<block_workspace::ring_term>& ringing = w.ringing;
  ringing.clear();
  for (std::size_t c = 0; c < n; ++c)
    for (const auto& m : s.modes()) {
      if (!(m.crossing > 0.0)) continue;
      const double since_mid = (omega_mid - m.crossing_speed) / alpha;
      if (since_mid + half <= 0.0) continue;
      const cplx ring = channels[c].gamma[&m - s.modes().data()] * (channels[c].forcing == swept_forcing::bow ? m.ring_bow : m.ring_unbalance);
      if (std::abs(ring) * std::exp(m.lambda.real() * std::max(0.0, since_mid - half)) > 1e-17 * std::abs(sums[c]))
        ringing.push_back({c, m.lambda, ring, since_mid, m.crossing_speed});
    }
  std::vector<cplx>&a = w.a, &b = w.b, &ring_a = w.ring_a, &ring_b = w.ring_b;
  a.assign(n, 0.0), b.assign(n, 0.0), ring_a.assign(n, 0.0), ring_b.assign(n, 0.0);
  for (int p = 0; p < panels; ++p) {
    const double mid = -half + (p + 0.5) * h;
    for (std::size_t i = 0; i < rule.node.size(); ++i) {
      const double tau = mid + 0.5 * h * rule.node[i], omega = omega_mid + alpha * tau;
      const double wt = 0.5 * h * rule.weight[i] * omega;
      // e^{-j theta(t)}, theta from the block's first keyphasor pulse (a block is whole revolutions
      // from one pulse: theta = 0 at its start, 2 pi N at its end).
      const cplx back = std::polar(1.0, -(omega_mid * (tau + half) + 0.5 * alpha * (tau * tau - half * half)));
      adiabatic_sums(t_mid + tau, sums);
      std::fill(ring_a.begin(), ring_a.end(), cplx(0.0)), std::fill(ring_b.begin(), ring_b.end(), cplx(0.0));
      for (const auto& r : ringing) {
        const double dt = r.since_mid + tau;  // since the crossing (0 before it: a block may hold the crossing)
        if (!(dt > 0.0)) continue;
        const double turned = (r.crossing_speed + 0.5 * alpha * dt) * dt;  // theta(t) - theta(t*)
        const cplx e = std::exp(r.lambda * dt - kJ * turned);  // (its conjugate is the conjugate term's: one exp for both)
        ring_a[r.channel] += r.ring * e;                                      // e^{-j theta} R
        ring_b[r.channel] += back * back * std::conj(r.ring) * std::conj(e);  // e^{-j theta} conj(R)
      }
      for (std::size_t c = 0; c < n; ++c) {
        a[c] += wt * (sums[c] + ring_a[c]);
        b[c] += wt * (back * back * std::conj(sums[c]) + ring_b[c]);
      }
    }
  }
  const double scale = 1.0 / (2.0 * kPi * revolutions);
  std::vector<std::array<cplx, 2>> out(n);
  for (std::size_t c = 0; c < n; ++c) out[c] = {scale * (a[c] + b[c]), scale * kJ * (a[c] - b[c])};
  return out;
}

std::vector<cplx> probe_weights(const swept_response& s, double beta) {
  std::vector<cplx> g;
  for (const auto& m : s.modes()) g.push_back(std::cos(beta) * m.displacement(0) + std::sin(beta) * m.displacement(1));
  return g;
}

}  // namespace

std::array<cplx, 2> swept_response::read(double ta, double tb, double revolutions, double beta, swept_forcing f) const {
  const std::vector<channel> channels{{probe_weights(*this, beta), f}};
  auto exact = [&](double t, std::vector<cplx>& out) {
    out[0] = 0.0;
    for (std::size_t k = 0; k < modes_.size(); ++k) out[0] += channels[0].gamma[k] * adiabatic(k, t, f);
  };
  const double t_mid = 0.5 * (ta + tb);
  block_workspace w;
  return block_read(*this, t_mid, 0.5 * (tb - ta), speed(t_mid), revolutions, channels, exact, w)[0];
}

swept_rows swept_row_times(const std::vector<double>& speeds, double alpha, double revolutions) {
  if (speeds.empty()) throw input_error("swept_row_times: no rows");
  if (!(revolutions >= 1.0)) throw input_error("swept_row_times: a row's block needs at least one revolution");
  const auto [lo, hi] = std::minmax_element(speeds.begin(), speeds.end());
  const double first = alpha > 0.0 ? *lo : *hi;
  swept_rows out;
  // Time 0 at the first row's block start: half its block (pi N / Omega) before it.
  out.omega_start = first - alpha * kPi * revolutions / first;
  for (const double w : speeds) {
    const double half = kPi * revolutions / w, t = (w - out.omega_start) / alpha;
    // Every block's speeds stay positive: the speed changes less within a block than it is.
    if (!(w > 0.0) || !(w - std::abs(alpha) * half > 0.0))
      throw input_error("a sweep of " + format_digits(alpha * 60.0 / (2.0 * kPi)) + " rpm/s with blocks of " + format_digits(revolutions) +
                        " revolutions is too fast for a row at " + format_digits(w * 60.0 / (2.0 * kPi)) + " rpm (its block would reach zero speed)");
    out.time.push_back(t), out.block_start.push_back(t - half), out.block_end.push_back(t + half);
  }
  return out;
}

namespace {

// Chebyshev interpolants of every channel's adiabatic sum sum_k gamma_k S_k(t), on spans over
// which each is smooth: 16 points, accepted when the last two coefficients are below 1e-13 of the
// coefficients' sum (else the span is halved). A span never crosses a mode's crossing (S_k
// changes branch there). One Faddeeva evaluation per mode and point, shared by the channels.
class adiabatic_spans {
 public:
  // At most max_spans spans: a response that needs more is not smooth where it should be (a
  // failed evaluation, never a silent blow-up).
  adiabatic_spans(const swept_response& s, const std::vector<channel>& channels, double t_end, double first_length, std::size_t max_spans)
      : s_(s), channels_(channels), t_end_(t_end), length_(first_length), max_spans_(max_spans) {
    for (const auto& m : s.modes())
      if (m.crossing > 0.0) breaks_.push_back(m.crossing);
    std::sort(breaks_.begin(), breaks_.end());
  }

  // Spans over [a, b] (made in time order before any read, so that reads on several threads only
  // look them up).
  void cover(double a, double b) {
    for (double t = a;;) {
      const span& sp = spans_[span_at(t)];
      if (sp.hi >= b) return;
      t = std::nextafter(sp.hi, std::numeric_limits<double>::infinity());
    }
  }

  // A reader of every channel's sum at t in the covered spans; `last` is its own place.
  struct reader {
    const adiabatic_spans& spans;
    std::size_t last = 0;
    void operator()(double t, std::vector<cplx>& out) { spans.read(t, out, last); }
  };

 private:
  void read(double t, std::vector<cplx>& out, std::size_t& last) const {
    if (last >= spans_.size() || t < spans_[last].lo || t > spans_[last].hi) {
      const auto it = std::upper_bound(spans_.begin(), spans_.end(), t, [](double x, const span& sp) { return x < sp.lo; });
      if (it == spans_.begin() || t > std::prev(it)->hi) throw numerical_error("swept_response: a read outside the interpolated spans");
      last = static_cast<std::size_t>(std::prev(it) - spans_.begin());
    }
    const span& sp = spans_[last];
    const double u = (2.0 * t - sp.lo - sp.hi) / (sp.hi - sp.lo);
    for (std::size_t c = 0; c < channels_.size(); ++c) {  // Clenshaw
      const std::vector<cplx>& a = sp.coefficients[c];
      cplx b1 = 0.0, b2 = 0.0;
      for (std::size_t m = a.size(); m-- > 1;) {
        const cplx b0 = a[m] + 2.0 * u * b1 - b2;
        b2 = b1, b1 = b0;
      }
      out[c] = a[0] + u * b1 - b2;
    }
  }

  static constexpr int kPoints = 16;
  static constexpr double kTail = 1e-13;
  struct span {
    double lo, hi;
    std::vector<std::vector<cplx>> coefficients;  // per channel
  };

  std::size_t span_at(double t) {
    auto it = std::upper_bound(spans_.begin(), spans_.end(), t, [](double x, const span& sp) { return x < sp.lo; });
    if (it != spans_.begin() && t <= std::prev(it)->hi) return static_cast<std::size_t>(std::prev(it) - spans_.begin());
    // A new span from t, up to the next span, the next crossing and the sweep's end.
    double hi = t_end_ > t ? std::min(t + length_, t_end_) : t + length_;
    if (it != spans_.end()) hi = std::min(hi, it->lo);
    for (const double b : breaks_)
      if (b > t) {
        hi = std::min(hi, b);
        break;
      }
    if (spans_.size() >= max_spans_)
      throw numerical_error("swept_response: the adiabatic response needs more than " + std::to_string(max_spans_) + " interpolation spans (at t = " +
                            format_digits(t) + " s, span " + format_digits(hi - t) + " s)");
    for (int attempt = 0;; ++attempt) {
      span sp{t, hi, {}};
      if (fit(sp)) {
        length_ = std::max(length_, 1.5 * (hi - t));
        const auto at = spans_.insert(it, std::move(sp));  // (before begin(): the insertion may move the spans)
        return static_cast<std::size_t>(at - spans_.begin());
      }
      if (attempt > 60) throw numerical_error("swept_response: the adiabatic response could not be interpolated near t = " + format_digits(t) + " s");
      hi = t + 0.5 * (hi - t);
      length_ = hi - t;
    }
  }

  // The rule's cosines, cos(pi m (j + 1/2) / kPoints) (row 1: the nodes), made once: made anew at
  // every span, they were about a fifth of a swept fit's time (perf, 2026-12-02).
  using cosine_table = std::array<std::array<double, kPoints>, kPoints>;
  static const cosine_table& cosines() {
    static const cosine_table table = [] {
      cosine_table c{};
      for (int m = 0; m < kPoints; ++m)
        for (int j = 0; j < kPoints; ++j) c[static_cast<std::size_t>(m)][static_cast<std::size_t>(j)] = std::cos(kPi * m * (j + 0.5) / kPoints);
      return c;
    }();
    return table;
  }

  bool fit(span& sp) const {
    const double mid = 0.5 * (sp.lo + sp.hi), half = 0.5 * (sp.hi - sp.lo);
    const cosine_table& cs = cosines();
    std::vector<std::vector<cplx>> values(channels_.size(), std::vector<cplx>(kPoints, 0.0));
    for (int j = 0; j < kPoints; ++j) {
      const double t = mid + half * cs[1][static_cast<std::size_t>(j)];
      for (std::size_t k = 0; k < s_.modes().size(); ++k) {
        const std::array<cplx, 2> both = s_.adiabatic_both(k, t);
        for (std::size_t c = 0; c < channels_.size(); ++c)
          values[c][static_cast<std::size_t>(j)] += channels_[c].gamma[k] * both[channels_[c].forcing == swept_forcing::bow ? 1 : 0];
      }
    }
    for (const auto& v : values) {
      std::vector<cplx> a(kPoints, 0.0);
      double size = 0.0;
      for (int m = 0; m < kPoints; ++m) {
        for (int j = 0; j < kPoints; ++j) a[static_cast<std::size_t>(m)] += v[static_cast<std::size_t>(j)] * cs[static_cast<std::size_t>(m)][static_cast<std::size_t>(j)];
        a[static_cast<std::size_t>(m)] *= (m == 0 ? 1.0 : 2.0) / kPoints;
        size += std::abs(a[static_cast<std::size_t>(m)]);
      }
      if (!std::isfinite(size)) throw numerical_error("swept_response: the adiabatic response is not finite");
      if (std::abs(a[kPoints - 1]) + std::abs(a[kPoints - 2]) > kTail * size) return false;
      sp.coefficients.push_back(std::move(a));
    }
    return true;
  }

  const swept_response& s_;
  const std::vector<channel>& channels_;
  double t_end_;
  double length_;
  std::size_t max_spans_;
  std::vector<double> breaks_;
  std::vector<span> spans_;
};

}  // namespace

swept_table_columns swept_1x(const linear_rotor& rotor, const std::vector<double>& speeds, double alpha, double revolutions,
                             const std::vector<double>& probe_angles, bool with_bow) {
  const swept_rows rows = swept_row_times(speeds, alpha, revolutions);
  const swept_response s(rotor, rows.omega_start, alpha);
  const double t_end = *std::max_element(rows.block_end.begin(), rows.block_end.end());
  std::vector<std::vector<cplx>> gammas;
  for (const double beta : probe_angles) gammas.push_back(probe_weights(s, beta));
  std::vector<std::size_t> order(speeds.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) { return rows.time[x] < rows.time[y]; });

  // Every probe's reading of each forcing, as one set of channels sharing the nodes.
  std::vector<channel> channels;
  for (const auto& g : gammas) {
    channels.push_back({g, swept_forcing::unbalance});
    if (with_bow) channels.push_back({g, swept_forcing::bow});
  }
  // (A span per row at most, and as many again: a smooth response needs far fewer.)
  adiabatic_spans spans(s, channels, t_end, rows.block_end[order.front()] - rows.block_start[order.front()], 2 * speeds.size() + 64);
  swept_table_columns out;
  out.columns.assign(probe_angles.size(), std::vector<std::array<cplx, 4>>(speeds.size(), {0.0, 0.0, 0.0, 0.0}));
  for (const std::size_t i : order) spans.cover(rows.block_start[i], rows.block_end[i]);
  // The rows' reads on the machine's threads, in chunks (each writes its own rows).
  constexpr std::size_t kChunk = 64;
  parallel_for((order.size() + kChunk - 1) / kChunk, 0, [&](std::size_t chunk) {
    adiabatic_spans::reader read{spans};
    block_workspace w;
    for (std::size_t k = chunk * kChunk; k < std::min(order.size(), (chunk + 1) * kChunk); ++k) {
      const std::size_t i = order[k];
      const auto reads = block_read(s, rows.time[i], kPi * revolutions / speeds[i], speeds[i], revolutions, channels, read, w);
      for (std::size_t p = 0, c = 0; p < probe_angles.size(); ++p) {
        out.columns[p][i][0] = reads[c][0], out.columns[p][i][1] = reads[c][1], ++c;
        if (with_bow) out.columns[p][i][2] = reads[c][0], out.columns[p][i][3] = reads[c][1], ++c;
      }
    }
  });
  return out;
}

}  // namespace rubref
